#!/usr/bin/python3
# siconos_pile.py: the deposition scene of bench/README.md (cases/disk-pile, the scene of
# bench/box2d_pile.cc) run by Siconos 4.4 (Debian python3-siconos), then by moreau, and the ratio
# of their times per step.
#
#   /usr/bin/python3 bench/siconos_pile.py [N [STEPS [MOREAU]]]
#
# N disks (default 1000), STEPS steps of 1 ms (default 1000, 1 s), MOREAU the binary (default
# build/moreau of this repository). Run it with Debian's interpreter, the one that sees
# python3-siconos. The last line is `RATIO moreau/siconos time-per-step: R`.
#
# The scene, as in moreau's case file: radii R (1 + 0.2 (2u - 1)), R = 5 mm, on the loose lattice
# of moreau's pack generator (33 columns, spacing s = 2.2 R 1.2, jitter 0.5 of the room left),
# rebuilt here bit for bit from the same counter-based generator and checked against a one-step
# moreau run (radii to moreau's 12 printed digits, positions to 1e-4 m); density 2600 kg/m^3 per
# unit thickness (m = rho pi r^2, I = m r^2 / 2), gravity -9.81 along y; a floor y = 0 and walls
# x = 0 and x = W = 33 s; mu = 0.5 everywhere, e = 0, h = 1 ms.
#
# Siconos, as used (all of it public API of the Debian package, nothing rebuilt):
# - bodies: siconos.mechanics.collision.bodies.Disk, a LagrangianDS on q = (x, y, theta) with
#   M = diag(m, m, m r^2 / 2), gravity as a constant external force.
# - detection: siconos.mechanics.collision.native.SpaceFilter, Siconos' broad phase for disks
#   (a spatial hash, Teschner et al. 2003), run by TimeStepping at the start of every step as its
#   InteractionManager: it rehashes every disk, then links a DiskDiskR (gap and 2D frame of the two
#   disks, rotations included) for every pair whose gap is below r1 + r2 and a DiskPlanR for every
#   disk within r of a line, and unlinks them beyond; O(N) per step. Its cell size is an unsigned
#   int in length units, so lengths are in cm here (x 100, gravity x 100, masses in kg: the same
#   discrete problem, and NSGS's criteria are relative) with cell 1 cm = 2 R and bounding boxes of
#   3 radii, which finds every pair within 0.8 R (4 mm) of contact.
# - the box: three infinite lines of SpaceFilter (DiskPlanR's gap is |A x + B y + C| / |(A, B)| - r:
#   a two-sided line, the same as a half-space while no disk crosses it).
# - law and scheme: NewtonImpactFrictionNSL(e_n = 0, e_t = 0, mu = 0.5, size 2); MoreauJeanOSI
#   with theta = 0.5; a contact enters the one-step problem when g + h/2 dg/dt <= 0.
# - one-step problem: FrictionContact(2) solved by SICONOS_FRICTION_2D_NSGS (fc2d_nsgs_sbm) on
#   NM_SPARSE_BLOCK storage, which keeps the last step's reactions as its start (LinearOSNS's
#   keepLambdaAndYState, default on); tol 1e-4 and 1000 sweeps at most (Siconos' defaults), its
#   default stop: the reactions' relative change below tol, then the full 2D residual
#   (fc2d_compute_error, relative to max(|r|, |u|, |q|)) below tol, or more sweeps.
# - BLAS on one thread (OPENBLAS_NUM_THREADS = 1 and the like, unless set): Debian's threaded
#   OpenBLAS spins in sched_yield on Siconos' small products (4x slower at N = 100).
#
# Debian's build keeps assert() on (no NDEBUG). In 4.4 no environment variable or run-time option
# turns its checks off (the kernel and numerics read only SICONOS_SPARSE_SOLVER,
# SICONOS_SPARSE_SOLVER_PROCS and SICONOS_HDF5_NAME): this script runs them as installed. The
# costly ones are SiconosGraph::state_assert and adjacent_vertices_ok, which walk a whole graph (a
# map look-up per vertex and neighbour) at every removal of an interaction from an index set (a
# contact that opens, one that SpaceFilter drops): 80 % of the time of the first 250 steps at
# N = 1000 (perf). Stubbed out by hand for one measurement (an LD_PRELOAD library whose four
# functions return true; not part of this script), the full run took 254 ms per step against 545
# and 569 as installed (2-core machine shared with other jobs), with the same results to the last
# digit; what is left is NSGS (40 %, mostly its block products through cblas_dgemv on 2x2
# blocks) and the kernel's per-interaction work.
#
# Measured: wall (and process CPU) time of the time loop only: SpaceFilter, computeOneStep,
# nextStep and a few counters read per step; not the import nor the set-up (TimeStepping.initialize
# runs before; the first step's detection, which links the initial interactions, is in the loop).
# Contacts: the size of the one-step problem (interactions active at the step) averaged over the
# steps; interactions: what SpaceFilter holds; NSGS sweeps over the steps with contacts, and the
# steps whose final residual stayed above tol. Final state: pile height max(y + r), kinetic energy
# (translation and rotation, J per m of thickness), the largest overlap of two disks or of a disk
# and the box.
#
# moreau: `MOREAU run cases/disk-pile --out TMP --quiet` (its case: nscd, Jean's quad criterion at
# 1e-4; with --set for N and the end time when they differ from the case's), time per step =
# summary.json's timings.wall / time.steps_done (its output files included, as in its own runs);
# contacts: history.csv's contact.closed averaged over its rows (every 10 steps); final state
# from bodies.csv, and its own max_penetration over the run.
#
# Measured 2026-11-25, N = 1000, 1000 steps, on the shared 2-core machine: Siconos 569 ms per step
# (559 of CPU), 1529 contacts in the one-step problem, 5587 interactions, 258 NSGS sweeps per
# solve, 187 steps stopped at 1000 sweeps above tol (during the impacts, t = 0.1-0.4 s); pile
# 0.2400 m, kinetic energy 1.7e-6 J/m, largest overlap 1.3 mm. moreau 2.21 ms per step, 1496
# closed contacts, 26 sweeps per solve; pile 0.2367 m, kinetic energy 1.0e-2 J/m (its grains still
# move at tol 1e-4), largest overlap 1.3 mm. RATIO 0.0039.
"""The disk-pile deposition scene in Siconos and in moreau: time per step, physics check."""

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time

# One BLAS thread, as moreau runs on one: set before numpy or Siconos load OpenBLAS.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CASE = os.path.join(REPO, "cases", "disk-pile")

# The scene (cases/disk-pile/case.cfg).
RADIUS = 0.005          # mean radius R (m)
DISPERSION = 0.2        # radii uniform in R (1 +- 0.2)
JITTER = 0.5            # fraction of the room left in a lattice cell
COLUMNS = 33
SEED = 1
DENSITY = 2600.0        # kg/m^3, per unit thickness
GRAVITY = 9.81
MU = 0.5
DT = 1e-3
THETA = 0.5
TOL = 1e-4
MAX_SWEEPS = 1000
SPACING = 2.2 * RADIUS * (1 + DISPERSION)
WIDTH = COLUMNS * SPACING

SCALE = 100.0           # Siconos' lengths in cm: SpaceFilter's cell size is an integer
CELL = 1                # SpaceFilter cell (cm) = 2 R
BBOX = 3                # SpaceFilter bounding box half-size, in radii

MASK64 = (1 << 64) - 1


def pack_uniform(seed, grain, draw):
    """moreau's pack_uniform (src/body_rigid.c): SplitMix64's finalizer on (seed, grain, draw)."""
    z = (seed * 0x9E3779B97F4A7C15 + grain * 0xBF58476D1CE4E5B9 + draw * 0x94D049BB133111EB
         + 0x632BE59BD9B4E019) & MASK64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    z ^= z >> 31
    return (z >> 11) * (1.0 / 9007199254740992.0)


def pack(n):
    """Radii and centres (m) of moreau's pack for the disk-pile case: lists r, x, y."""
    r, x, y = [], [], []
    for k in range(n):
        rk = RADIUS * (1 + DISPERSION * (2 * pack_uniform(SEED, k, 0) - 1))
        shift = JITTER * (0.5 * SPACING - rk)             # jitter: a part of the room left
        r.append(rk)
        x.append(SPACING * (k % COLUMNS + 0.5) + shift * (2 * pack_uniform(SEED, k, 1) - 1))
        y.append(SPACING * (k // COLUMNS + 0.5) + shift * (2 * pack_uniform(SEED, k, 2) - 1))
    return r, x, y


def max_overlap(np, x, y, r):
    """Largest overlap (m) between two disks or a disk and the floor or a wall; 0 if none."""
    worst = max(0.0, float(np.max(r - y)), float(np.max(r - x)), float(np.max(x + r - WIDTH)))
    for i in range(0, len(x), 256):                       # all pairs, in blocks of rows
        rows = np.arange(i, min(i + 256, len(x)))
        ov = r[rows, None] + r[None, :] - np.hypot(x[rows, None] - x, y[rows, None] - y)
        ov[rows - i, rows] = -1.0                         # not a disk with itself
        worst = max(worst, float(ov.max()))
    return worst


def moreau_args(moreau, n, steps, out):
    cmd = [moreau, "run", CASE, "--out", out, "--quiet"]
    if n != 1000:
        cmd += ["--set", "bodies.grains.pack.count=%d" % n]
    if steps != 1000:
        cmd += ["--set", "time.end=%r" % round(steps * DT, 9)]
    return cmd


def read_bodies(path):
    """bodies.csv's disks: {index: row}, row as strings."""
    with open(path, newline="") as f:
        return {int(row["name"].split(".")[1]): row for row in csv.DictReader(f)
                if row["group"] == "grains"}


def check_pack(moreau, n, r, x, y):
    """Compare the pack with moreau's after one step: radii to its 12 digits, centres to 1e-4 m."""
    with tempfile.TemporaryDirectory(prefix="siconos_pile_") as out:
        cmd = moreau_args(moreau, n, 1000, out) + ["--set", "time.end=0.001"]
        subprocess.run(cmd, check=True)
        rows = read_bodies(os.path.join(out, "bodies.csv"))
    if len(rows) != n:
        sys.exit("pack check: moreau has %d disks, this script %d" % (len(rows), n))
    bad_r = [k for k in range(n) if rows[k]["radius"] != "%.12g" % r[k]]
    dpos = max(math.hypot(float(rows[k]["x"]) - x[k], float(rows[k]["y"]) - y[k]) for k in range(n))
    print("pack check against moreau (one step): %d radii differ, largest centre offset %.2e m"
          % (len(bad_r), dpos))
    if bad_r or dpos > 1e-4:
        sys.exit("pack check failed: radii of disks %s, centre offset %.2e m" % (bad_r[:5], dpos))


def run_siconos(n, steps):
    import numpy as np
    import siconos.kernel as sk
    import siconos.numerics as sn
    from siconos.mechanics.collision.bodies import Disk
    from siconos.mechanics.collision.native import SpaceFilter

    L = SCALE
    r, x, y = pack(n)
    nsds = sk.NonSmoothDynamicalSystem(0.0, steps * DT)
    disks, mass = [], []
    for k in range(n):
        m = DENSITY * math.pi * r[k] ** 2
        d = Disk(L * r[k], m, [L * x[k], L * y[k], 0.0], [0.0, 0.0, 0.0])
        d.setFExtPtr(np.array([0.0, -m * GRAVITY * L, 0.0]))
        nsds.insertDynamicalSystem(d)
        disks.append(d)
        mass.append(m)

    # Lines A x + B y + C = 0, centre, width (infinite): floor, left wall, right wall.
    lines = np.array([[0.0, 1.0, 0.0, 0.0, 0.0, math.inf],
                      [1.0, 0.0, 0.0, 0.0, 0.0, math.inf],
                      [-1.0, 0.0, L * WIDTH, L * WIDTH, 0.0, math.inf]])
    law = sk.NewtonImpactFrictionNSL(0.0, 0.0, MU, 2)
    detector = SpaceFilter(BBOX, CELL, lines)
    detector.insertNonSmoothLaw(law, 0, 0)

    osi = sk.MoreauJeanOSI(THETA)
    osnspb = sk.FrictionContact(2, sn.SICONOS_FRICTION_2D_NSGS)
    osnspb.setMStorageType(sn.NM_SPARSE_BLOCK)
    opts = osnspb.numericsSolverOptions()
    opts.dparam[sn.SICONOS_DPARAM_TOL] = TOL
    opts.iparam[sn.SICONOS_IPARAM_MAX_ITER] = MAX_SWEEPS
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(0.0, DT), osi, osnspb)
    sim.insertInteractionManager(detector)
    sim.initialize()

    # Siconos prints a warning on stdout (C++) at every step NSGS ends unconverged: counted
    # below, so stdout goes to /dev/null during the loop; progress goes to stderr.
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    contacts = interactions = solves = sweeps = sweeps_max = unconverged = 0
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        for k in range(steps):
            sim.computeOneStep()
            size = osnspb.getSizeOutput() // 2
            contacts += size
            interactions += nsds.getNumberOfInteractions()
            if size:                                      # NSGS ran (its counters are this step's)
                solves += 1
                it = opts.iparam[sn.SICONOS_IPARAM_ITER_DONE]
                sweeps += it
                sweeps_max = max(sweeps_max, it)
                unconverged += opts.dparam[sn.SICONOS_DPARAM_RESIDU] > TOL
            sim.nextStep()
            if (k + 1) % 100 == 0:
                print("siconos: step %d, %.1f s" % (k + 1, time.perf_counter() - t0),
                      file=sys.stderr, flush=True)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)

    q = np.array([d.q() for d in disks]) / L                  # x, y in m; theta unchanged
    v = np.array([d.velocity() for d in disks])
    rr, m = np.array(r), np.array(mass)
    kinetic = float(np.sum(0.5 * m * ((v[:, 0] / L) ** 2 + (v[:, 1] / L) ** 2)
                           + 0.25 * m * rr ** 2 * v[:, 2] ** 2))
    return dict(ms=1e3 * wall / steps, cpu_ms=1e3 * cpu / steps, contacts=contacts / steps,
                interactions=interactions / steps, sweeps=sweeps / max(1, solves),
                sweeps_max=sweeps_max, unconverged=unconverged,
                height=float(np.max(q[:, 1] + rr)), kinetic=kinetic,
                overlap=max_overlap(np, q[:, 0], q[:, 1], rr))


def run_moreau(moreau, n, steps):
    import numpy as np
    with tempfile.TemporaryDirectory(prefix="moreau_pile_") as out:
        subprocess.run(moreau_args(moreau, n, steps, out), check=True)
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
        with open(os.path.join(out, "history.csv"), newline="") as f:
            closed = [float(row["contact.closed"]) for row in csv.DictReader(f)]
        rows = read_bodies(os.path.join(out, "bodies.csv"))
    m, r, x, y, vx, vy, w = (np.array([float(row[c]) for row in rows.values()])
                             for c in ("mass", "radius", "x", "y", "vx", "vy", "omega"))
    done = summary["time"]["steps_done"]
    return dict(ms=1e3 * summary["timings"]["wall"] / done, steps=done,
                contacts=sum(closed) / max(1, len(closed)),
                sweeps=summary["contact"]["iterations_mean"],
                sweeps_max=summary["contact"]["iterations_max"], height=float(np.max(y + r)),
                kinetic=float(np.sum(0.5 * m * (vx * vx + vy * vy) + 0.25 * m * r * r * w * w)),
                overlap=max_overlap(np, x, y, r),
                penetration=summary["metrics"]["contact"]["max_penetration"])


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("n", nargs="?", type=int, default=1000, help="disks (default 1000)")
    ap.add_argument("steps", nargs="?", type=int, default=1000, help="steps of 1 ms (default 1000)")
    ap.add_argument("moreau", nargs="?", default=os.path.join(REPO, "build", "moreau"),
                    help="moreau binary (default build/moreau of this repository)")
    args = ap.parse_args(argv)
    if args.n < 1 or args.steps < 1:
        ap.error("N and STEPS must be positive")
    try:
        import siconos.kernel  # noqa: F401  (the package is there before anything runs)
    except ImportError as e:
        sys.exit("siconos_pile: cannot import Siconos (%s); run /usr/bin/python3 with Debian's "
                 "python3-siconos installed" % e)
    version = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "python3-siconos"],
                             capture_output=True, text=True).stdout or "unknown"

    r, x, y = pack(args.n)
    check_pack(args.moreau, args.n, r, x, y)

    s = run_siconos(args.n, args.steps)
    print("siconos %s (MoreauJeanOSI theta=0.5, FC2D NSGS sparse-block tol=%g, SpaceFilter) N=%d "
          "steps=%d%s" % (version, TOL, args.n, args.steps,
                          "" if args.steps == 1000 else " (fewer than the scene's 1000)"))
    print("siconos time_per_step_ms=%.3f cpu_per_step_ms=%.3f contacts=%.1f interactions=%.1f "
          "nsgs_sweeps_mean=%.1f nsgs_sweeps_max=%d unconverged_steps=%d"
          % (s["ms"], s["cpu_ms"], s["contacts"], s["interactions"], s["sweeps"], s["sweeps_max"],
             s["unconverged"]))
    print("siconos pile_height=%.4f kinetic=%.3e max_overlap=%.2e"
          % (s["height"], s["kinetic"], s["overlap"]))

    m = run_moreau(args.moreau, args.n, args.steps)
    print("moreau (nscd, quad criterion, tol 1e-4) N=%d steps=%d" % (args.n, m["steps"]))
    print("moreau time_per_step_ms=%.3f contacts=%.1f nscd_sweeps_mean=%.1f nscd_sweeps_max=%d"
          % (m["ms"], m["contacts"], m["sweeps"], m["sweeps_max"]))
    print("moreau pile_height=%.4f kinetic=%.3e max_overlap=%.2e (over the run: %.2e)"
          % (m["height"], m["kinetic"], m["overlap"], m["penetration"]))
    print("RATIO moreau/siconos time-per-step: %.4g" % (m["ms"] / s["ms"]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
