# yade_pile.py: the deposition scene of bench/README.md (cases/disk-pile) run by Yade 2023.02a
# (Debian `yade`), the soft-contact DEM reference: N polydisperse grains (radii 0.8-1.2 x 5 mm) on
# the loose lattice of moreau's pack generator (the same radii and centres, from the same
# counter-based generator as src/body_rigid.c), in a box with a floor and two walls, mu = 0.5.
#
# Yade is 3D: the disks are spheres of the same radii held in the plane z = 0 (blockedDOFs 'zXY':
# no z translation, no rotation about x or y), the box is three Wall bodies (infinite planes, as
# moreau's). Density 2600 for the spheres: their mass is not the disks' per unit thickness, which
# leaves the motion under gravity unchanged but not the forces or energies.
#
# Yade's usual soft-contact model: linear springs (Ip2_FrictMat_FrictMat_FrictPhys: kn = E D1 E D2
# / (E D1 + E D2) from E = 1e8 Pa, ks = 0.3 kn, FrictMat's `poisson` being that ratio for this
# functor) with Coulomb friction tan(phi) = 0.5 (Law2_ScGeom_FrictPhys_CundallStrack). No contact
# damping: the springs are elastic, energy is taken out only by NewtonIntegrator's non-viscous
# damping 0.2 (Yade's default and that of most of its examples), which scales each force component
# by 1 - 0.2 sign(F v): an isolated impact has a restitution of about sqrt(0.8 / 1.2) = 0.82 (not
# moreau's 0), and gravity included, a grain falls freely at 0.8 g, so the pile forms a little
# later than in moreau (its rest state is unaffected).
# dt = 0.5 PWaveTimeStep().
#
#   yade -n -x -j1 bench/yade_pile.py [N] [SIMULATED_SECONDS]
# prints one line: yade N=... t_end=... steps=... dt=... wall_s=... (the O.run of the time loop
# alone, set-up excluded) wall_per_sim_s=... cpu_s=... (process CPU over the same loop: about
# wall_s when one core works) threads=... interactions=... (real interactions, averaged over the
# loop every 100 steps) interactions_end=... pile_height=... (highest sphere top, m) y_mean=...
# (mean centre height, m) kinetic=... (translational, J, sphere masses) v_rms=... (m/s) sum_r=...
# (sum of the radii, to check the scene against moreau's bodies.csv).
import math
import sys
import time

from yade import *  # noqa: F401,F403 (already in the namespace of a script run by yade)
from yade import utils

N = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
T = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0

R, DISP, JIT, RHO, MU = 0.005, 0.2, 0.5, 2600.0, 0.5
S = 2.2 * R * (1 + DISP)  # lattice spacing, 13.2 mm
COLS = 33                 # cases/disk-pile: pack.box = [0, 0.4356, 0, 2] holds 33 columns
W = COLS * S              # box width, 0.4356 m
M64 = (1 << 64) - 1


def pack_uniform(seed, grain, draw):
    """moreau's pack_uniform: SplitMix64's finalizer on (seed, grain, draw), in [0, 1)."""
    z = (seed * 0x9E3779B97F4A7C15 + grain * 0xBF58476D1CE4E5B9 + draw * 0x94D049BB133111EB
         + 0x632BE59BD9B4E019) & M64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    z ^= z >> 31
    return (z >> 11) * 2.0 ** -53


def grain(k):
    """Centre (x, y) and radius of grain k: column k % COLS, row k // COLS, jitter inside the cell."""
    r = R * (1 + DISP * (2 * pack_uniform(1, k, 0) - 1))
    free = 0.5 * S - r
    x = S * (k % COLS + 0.5) + JIT * free * (2 * pack_uniform(1, k, 1) - 1)
    y = S * (k // COLS + 0.5) + JIT * free * (2 * pack_uniform(1, k, 2) - 1)
    return x, y, r


mat = O.materials.append(FrictMat(young=1e8, poisson=0.3, frictionAngle=math.atan(MU), density=RHO))
O.bodies.append([utils.wall(0.0, axis=1, material=mat),   # floor y = 0
                 utils.wall(0.0, axis=0, material=mat),   # left x = 0
                 utils.wall(W, axis=0, material=mat)])    # right x = W
grains = []
for k in range(N):
    x, y, r = grain(k)
    b = utils.sphere((x, y, 0.0), r, material=mat)
    b.state.blockedDOFs = 'zXY'
    grains.append(O.bodies.append(b))

samples = []  # real interactions, every 100 steps


def sample():
    samples.append(O.interactions.countReal())


O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack()]),
    NewtonIntegrator(gravity=(0, -9.81, 0), damping=0.2),
    PyRunner(command='sample()', iterPeriod=100),
]
O.dt = 0.5 * utils.PWaveTimeStep()
steps = int(math.ceil(T / O.dt - 1e-9))

c0, t0 = time.process_time(), time.perf_counter()
O.run(steps, True)
t1, c1 = time.perf_counter(), time.process_time()

top = ek = v2 = ysum = 0.0
for i in grains:
    b = O.bodies[i]
    v = b.state.vel.norm()
    top = max(top, b.state.pos[1] + b.shape.radius)
    ysum += b.state.pos[1]
    ek += 0.5 * b.state.mass * v * v
    v2 += v * v
print('yade N=%d t_end=%.6g steps=%d dt=%.6e wall_s=%.3f wall_per_sim_s=%.3f cpu_s=%.3f threads=%d '
      'interactions=%.1f interactions_end=%d pile_height=%.4f y_mean=%.4f kinetic=%.3e v_rms=%.3e sum_r=%.9f'
      % (N, O.time, O.iter, O.dt, t1 - t0, (t1 - t0) / O.time, c1 - c0, O.numThreads,
         sum(samples) / max(len(samples), 1), O.interactions.countReal(), top, ysum / max(N, 1), ek,
         math.sqrt(v2 / max(N, 1)), sum(grain(k)[2] for k in range(N))))
sys.stdout.flush()
