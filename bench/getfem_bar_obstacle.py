#!/usr/bin/python3
# getfem_bar_obstacle.py: the bar-obstacle benchmark (Doyen-Ern-Piperno 2011, benchmark 1;
# doc/architecture.md §11; cases/bar-obstacle) solved by GetFEM, measured the way moreau
# measures its own runs, and written as rows of `moreau compare`'s CSV so that
# `moreau compare CASE --peer FILE.csv` puts them on the same error-against-run-time figure.
#
# Run it with Debian's interpreter, which sees python3-getfem:
#
#   /usr/bin/python3 bench/getfem_bar_obstacle.py --nx 100 --dt 0.02,0.01,0.005,0.0025 \
#       --schemes newmark-nitsche,newmark-multipliers,massred-multipliers --out getfem.csv
#   /usr/bin/python3 bench/getfem_bar_obstacle.py --verify out/bar-obstacle
#
# The second form checks this script's closed form and metrics against a moreau run of
# cases/bar-obstacle (its history.csv exact columns and summary.json; the field errors too when
# the run wrote its fields at every step). bench/README.md says what each scheme is, how the
# runs are timed, and what was measured.
#
# Only GetFEM's public Python API is used (Mesh, MeshFem, MeshIm, Model and its bricks, asm_generic,
# linsolve_mumps); numpy comes with python3-getfem. The linear solver is MUMPS: SuperLU crashes in
# this Debian build.
"""The bar-obstacle benchmark solved by GetFEM, rows for `moreau compare --peer`."""

import argparse
import csv
import math
import os
import subprocess
import sys
import time

# One thread for MUMPS and BLAS, as moreau's runs use one: the figure compares work, not cores.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

EXIT_FAILED = 1      # a run failed or --verify found a disagreement
EXIT_USAGE = 2       # bad command line
EXIT_NO_GETFEM = 3   # GetFEM (or numpy) cannot be imported: callers skip

# The benchmark (doc/architecture.md §11, doc/theory.md §3.4): bar on [0, L], E = rho = A = 1 (wave speed c = 1), clamped at
# x = L, Signorini u(0, t) >= 0, u0 = a (1 - x / L) with a = 1/2, v0 = 0; period 3, T = 12.
LENGTH = 1.0
YOUNG = 1.0
DENSITY = 1.0
AREA = 1.0
AMPLITUDE = 0.5

# GetFEM schemes: (mass matrix, contact treatment). See bench/README.md.
SCHEMES = {
    "newmark-nitsche": ("consistent", "nitsche"),
    "newmark-penalty": ("consistent", "penalty"),
    "newmark-multipliers": ("consistent", "multipliers"),
    "massred-nitsche": ("redistributed", "nitsche"),
    "massred-multipliers": ("redistributed", "multipliers"),
}

# Mesh regions.
CONTACT, CLAMP, FIRST_ELEMENT, OTHER_ELEMENTS = 1, 2, 3, 4

# Columns, named as in moreau's compare.csv (summary.json flattened). Those moreau computes and
# this script does not (Delassus builds, linear-solver statistics...) are left out.
PROBE_KEYS = ("l2_rel", "linf_rel", "linf_abs", "samples")
PROBES = ("end.ux", "end.vx", "end.cx", "end.pn")
FIELD_KEYS = ("u_l2l2_rel", "v_l2l2_rel", "u_linfl2_rel", "v_linfl2_rel", "u_l2h1_rel")
CONTACT_KEYS = ("max_penetration", "max_vn_in_contact", "velocity_scale", "oscillation_index",
                "status_flips", "release_time", "release_time_exact", "release_time_error",
                "impulse", "impulse_exact", "impulse_error", "energy_after_impacts_last",
                "impact_end_times_last", "impacts", "energy_after_last_impact",
                "last_impact_end_time", "steps_with_contact", "iterations_total",
                "iterations_max", "iterations_mean")
ENERGY_KEYS = ("initial", "final", "ratio", "max_relative_drift", "max_growth",
               "ratio_mechanical")
METRIC_COLUMNS = ([p + "." + k for p in PROBES for k in PROBE_KEYS]
                  + ["field." + k for k in FIELD_KEYS]
                  + ["contact." + k for k in CONTACT_KEYS]
                  + ["energy." + k for k in ENERGY_KEYS]
                  + ["scene.hmin"])
# Columns of this script only (moreau compare ignores them in its figure).
EXTRA_COLUMNS = ("cpu_s", "loop_wall_s", "setup_s", "post_s", "nx", "beta", "gamma",
                 "nitsche_gamma0", "nitsche_theta", "penalty", "peer")
LEAD_COLUMNS = ("solver", "dt", "wall_s", "steps", "status", "reason")


class RunFailed(Exception):
    """A GetFEM run that did not reach the end: the message says where and why."""


# --- the closed form -----------------------------------------------------------------------------
#
# Derived from the description in doc/theory.md §3.4 (not from moreau's code): d'Alembert's
# construction, one phase at a time, in the benchmark's units (L = c = 1, a = 1/2); p = t mod 3.
#
#  Phase 1, 0 <= p <= 1, the end released: a release wave leaves x = 0 at speed 1. Behind it
#  (x < p) the bar is unstrained and moves at -1/2; ahead of it the initial state holds:
#      u = (1 - max(x, p)) / 2,  v = -1/2 [x < p],  eps = -1/2 [x > p].
#  At p = 1 the wave reaches the clamp as the end reaches the obstacle: u = 0, v = -1/2.
#
#  Phase 2, 1 < p <= 2, tau = p - 1, the end held at u = 0: from rest at u = 0 with v = -1/2,
#  both ends fixed. A compression wave leaves x = 0 (x < tau: v += 1/2, eps -= 1/2) and a
#  tension wave leaves x = 1 (x > 1 - tau: v += 1/2, eps += 1/2); they cross at tau = 1/2:
#      v = -1/2 + [x < tau]/2 + [x > 1 - tau]/2,  eps = -[x < tau]/2 + [x > 1 - tau]/2,
#      u = -tau/2 + max(0, tau - x)/2 + max(0, tau - 1 + x)/2.
#  The contact stress is eps(0) = -1/2 throughout: pressure 1/2. At p = 2, u = 0, v = +1/2.
#
#  Phase 3, 2 < p < 3, s = p - 2, the end leaves: the bar moves at +1/2 until the wave from the
#  clamp (x > 1 - s: v = 0, eps = -1/2) sweeps it back to the initial state at s = 1:
#      u = min(s, 1 - x)/2,  v = 1/2 [x < 1 - s],  eps = -1/2 [x > 1 - s].
#
# The exact energy is 1/8 at all times; the impulse of one contact phase is 1/2.

def exact_fields(np, x, t):
    """u, v, eps of the benchmark at the points x (array) and the time t >= 0."""
    x = np.asarray(x, dtype=float)
    p = math.fmod(t, 3.0)
    if p <= 1.0:
        u = 0.5 * (1.0 - np.maximum(x, p))
        v = np.where(x < p, -0.5, 0.0)
        eps = np.where(x > p, -0.5, 0.0)
    elif p <= 2.0:
        tau = p - 1.0
        left = x < tau
        right = x > 1.0 - tau
        v = -0.5 + 0.5 * left + 0.5 * right
        eps = -0.5 * left + 0.5 * right
        u = -0.5 * tau + 0.5 * np.maximum(0.0, tau - x) + 0.5 * np.maximum(0.0, tau - 1.0 + x)
    else:
        s = p - 2.0
        u = 0.5 * np.minimum(s, 1.0 - x)
        v = np.where(x < 1.0 - s, 0.5, 0.0)
        eps = np.where(x > 1.0 - s, -0.5, 0.0)
    return u, v, eps


def exact_pressure(t):
    """Contact pressure at x = 0 (compressive positive): 1/2 while in contact, 1 <= p <= 2."""
    p = math.fmod(t, 3.0)
    return 0.5 if 1.0 <= p <= 2.0 else 0.0


def exact_impulse(T):
    """The normal impulse over (0, T): 1/2 per unit time of contact."""
    n = math.floor(T / 3.0)
    rem = T - 3.0 * n
    return 0.5 * (n + min(max(rem - 1.0, 0.0), 1.0))


EXACT_RELEASE_TIME = 2.0


# The end's velocity and pressure jump at the impacts (t = 1 + 3k), releases (t = 2 + 3k) and
# the ends of the periods (t = 3k): a sample there takes the mean of the one-sided limits, so
# that a scheme is charged half the jump whichever side of it its step lands.
JUMP_DELTA = 1e-9


def exact_end(np, t):
    """u, v and the contact pressure at x = 0, and whether v or p jumps at t."""
    u = float(exact_fields(np, np.array([0.0]), t)[0][0])
    if t <= 0.0:
        return u, 0.0, 0.0, False
    vm = float(exact_fields(np, np.array([0.0]), t - JUMP_DELTA)[1][0])
    vp = float(exact_fields(np, np.array([0.0]), t + JUMP_DELTA)[1][0])
    pm, pp = exact_pressure(t - JUMP_DELTA), exact_pressure(t + JUMP_DELTA)
    return u, 0.5 * (vm + vp), 0.5 * (pm + pp), vm != vp or pm != pp


# --- metrics, as moreau computes them (doc/theory.md §10, src/metrics.c, src/run.c) --------------

def probe_metrics(np, values, exact):
    """l2_rel = sqrt(sum e^2 / sum r^2) over every step, linf_rel = max |e| / max |r|."""
    values = np.asarray(values, dtype=float)
    exact = np.asarray(exact, dtype=float)
    e = np.abs(values - exact)
    sr2 = float(np.sum(exact * exact))
    rmax = float(np.max(np.abs(exact))) if exact.size else 0.0
    return {"l2_rel": math.sqrt(float(np.sum(e * e)) / sr2) if sr2 > 0 else float("nan"),
            "linf_rel": float(np.max(e)) / rmax if rmax > 0 else float("nan"),
            "linf_abs": float(np.max(e)) if e.size else float("nan"),
            "samples": int(values.size)}


def field_metrics(np, x, times, U, V):
    """L2(0,T;L2), Linf(0,T;L2) of u and v and L2(0,T;H1) of u, relative, with nodal values U, V
    (steps x nodes, nodes sorted by x) interpolated linearly and two Gauss points per element;
    the time sums run over every step, t = 0 included, as moreau's."""
    xa, xb = x[:-1], x[1:]
    le = xb - xa
    g = 0.5773502691896257645
    eu2 = ru2 = ev2 = rv2 = eh2 = rh2 = 0.0
    eumax = rumax = evmax = rvmax = 0.0
    w = 0.5 * np.abs(le)
    for k, t in enumerate(times):
        ua, ub, va, vb = U[k, :-1], U[k, 1:], V[k, :-1], V[k, 1:]
        eps_h = (ub - ua) / le
        eu = ru = ev = rv = eh = rh = 0.0
        for q in (-g, g):
            na, nb = 0.5 * (1.0 - q), 0.5 * (1.0 + q)
            xq = na * xa + nb * xb
            u, v, ep = exact_fields(np, xq, t)
            uh = na * ua + nb * ub
            vh = na * va + nb * vb
            eu += float(np.sum(w * (uh - u) ** 2))
            ru += float(np.sum(w * u * u))
            ev += float(np.sum(w * (vh - v) ** 2))
            rv += float(np.sum(w * v * v))
            eh += float(np.sum(w * (eps_h - ep) ** 2))
            rh += float(np.sum(w * ep * ep))
        eu2 += eu; ru2 += ru; ev2 += ev; rv2 += rv; eh2 += eh; rh2 += rh
        eumax = max(eumax, math.sqrt(eu)); rumax = max(rumax, math.sqrt(ru))
        evmax = max(evmax, math.sqrt(ev)); rvmax = max(rvmax, math.sqrt(rv))
    nan = float("nan")
    return {"u_l2l2_rel": math.sqrt(eu2 / ru2) if ru2 > 0 else nan,
            "v_l2l2_rel": math.sqrt(ev2 / rv2) if rv2 > 0 else nan,
            "u_linfl2_rel": eumax / rumax if rumax > 0 else nan,
            "v_linfl2_rel": evmax / rvmax if rvmax > 0 else nan,
            "u_l2h1_rel": math.sqrt(eh2 / rh2) if rh2 > 0 else nan}


def contact_metrics(times, gap, vn, pressure, energy_ratio, dt, hmin):
    """moreau's contact measures for one candidate (src/metrics.c): a step bears when its
    reaction is compressive; the velocity jump and its variation are measured between two
    bearing steps; a release is the first step with no reaction and an open gap after bearing;
    an impact ends when the candidate is open again."""
    gtol = 1e-9 * hmin
    max_pen = max_vn = vscale = tv = impulse = 0.0
    first_release = float("nan")
    flips = nimpact = closed_prev = steps_with_contact = 0
    prev_status = 0
    incontact = False
    un_prev = 0.0
    impacts_e, impacts_t = [], []
    for k, t in enumerate(times):
        un, g = float(vn[k]), float(gap[k])
        vscale = max(vscale, abs(un))
        inc = k > 0 and pressure[k] > 0
        max_pen = max(max_pen, -g)
        closed = 1 if inc else 0
        if inc:
            steps_with_contact += 1
            if incontact:
                max_vn = max(max_vn, abs(un))
                tv += abs(un - un_prev)
        elif incontact and g > gtol and math.isnan(first_release):
            first_release = t
        if k > 0:
            status = 1 if inc else 0
            if status != prev_status:
                flips += 1
            prev_status = status
        incontact = inc or (incontact and g <= gtol)
        un_prev = un
        if k > 0:
            impulse += float(pressure[k]) * AREA * dt
        if closed_prev > 0 and closed == 0:
            nimpact += 1
            impacts_e.append(float(energy_ratio[k]))
            impacts_t.append(t)
        closed_prev = closed
    nan = float("nan")
    T = times[-1]
    iref = exact_impulse(T)
    out = {"max_penetration": max_pen, "max_vn_in_contact": max_vn, "velocity_scale": vscale,
           "oscillation_index": tv / vscale if vscale > 0 else 0.0, "status_flips": flips,
           "release_time": first_release, "release_time_exact": EXACT_RELEASE_TIME,
           "release_time_error": first_release - EXACT_RELEASE_TIME,
           "impulse": impulse, "impulse_exact": iref,
           "impulse_error": (impulse - iref) / iref if iref else nan,
           "energy_after_impacts_last": impacts_e[-1] if impacts_e else nan,
           "impact_end_times_last": impacts_t[-1] if impacts_t else nan,
           "impacts": nimpact, "steps_with_contact": steps_with_contact}
    if nimpact:
        out["energy_after_last_impact"] = impacts_e[-1]
        out["last_impact_end_time"] = impacts_t[-1]
    return out


# --- GetFEM ---------------------------------------------------------------------------------------

def import_getfem():
    """GetFEM and numpy, or a message naming the Debian package and exit status 3."""
    try:
        import numpy as np
        import getfem as gf
    except ImportError as err:
        sys.stderr.write(
            "getfem_bar_obstacle.py: cannot import GetFEM (%s).\n"
            "  It is Debian's python3-getfem (apt-get install python3-getfem), which only Debian's\n"
            "  interpreter sees: run this script with /usr/bin/python3 (%s was used).\n"
            % (err, sys.executable))
        sys.exit(EXIT_NO_GETFEM)
    gf.util_trace_level(0)
    gf.util_warning_level(0)
    return np, gf


def getfem_version():
    try:
        out = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "python3-getfem"],
                             capture_output=True, text=True, timeout=10)
        if out.returncode == 0 and out.stdout:
            return "getfem " + out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return "getfem"


def run_getfem(np, gf, scheme, nx, dt, T, prm):
    """One run: returns the histories (nodes sorted by x) and the timings; raises RunFailed."""
    mass, treatment = SCHEMES[scheme]
    steps = int(round(T / dt))
    if steps < 1 or abs(steps * dt - T) > 1e-9 * T:
        raise RunFailed("the end time %g is not a whole number of steps of %g" % (T, dt))
    h = LENGTH / nx
    w0 = time.perf_counter()

    mesh = gf.Mesh("cartesian", np.linspace(0.0, LENGTH, nx + 1))
    faces = mesh.outer_faces()
    normals = mesh.normal_of_faces(faces)
    left = faces[:, normals[0] < 0]
    mesh.set_region(CONTACT, left)
    mesh.set_region(CLAMP, faces[:, normals[0] > 0])
    first = int(left[0, 0])
    mesh.set_region(FIRST_ELEMENT, np.array([[first]]))
    mesh.set_region(OTHER_ELEMENTS, np.array([[c for c in range(nx) if c != first]]))

    mfu = gf.MeshFem(mesh, 1)
    mfu.set_classical_fem(1)                            # P1, as moreau's bar2
    mim = gf.MeshIm(mesh, gf.Integ("IM_GAUSS1D(2)"))    # exact for the P1 mass and stiffness
    x = mfu.basic_dof_nodes()[0]
    order = np.argsort(x)
    xs = x[order]

    md = gf.Model("real")
    md.add_fem_variable("u", mfu)
    md.add_initialized_data("E", [YOUNG * AREA])
    md.add_initialized_data("rho", [DENSITY * AREA])
    md.add_initialized_data("h", [h])
    md.add_linear_term(mim, "E*Grad_u.Grad_Test_u")
    md.add_Dirichlet_condition_with_simplification("u", CLAMP)
    md.add_Newmark_scheme("u", prm.beta, prm.gamma)
    if mass == "consistent":
        mass_terms = [(mim, "rho", -1)]
    else:
        # Mass redistribution (Khenous, Laborde, Renard 2008): the contact node carries no
        # inertia. The first element's mass goes to its inner node: its mass term is integrated
        # by the two-point Newton-Cotes rule (the element's nodes) with the weight 2 x / h, which
        # vanishes at x = 0 and is 2 at x = h, so that its matrix is diag(0, rho h). The total
        # mass is kept; the other elements keep the consistent mass.
        mim_nodes = gf.MeshIm(mesh, gf.Integ("IM_NC(1,1)"))
        mass_terms = [(mim, "rho", OTHER_ELEMENTS), (mim_nodes, "rho*2*X(1)/h", FIRST_ELEMENT)]
    for im, rho, region in mass_terms:
        md.add_mass_brick(im, "Dot2_u", rho, region)
    # mass and stiffness matrices, for the initial acceleration and the energy (assembled while
    # u is the model's only variable)
    M = None
    for im, rho, region in mass_terms:
        Mr = gf.asm_generic(im, 2, rho + "*u*Test_u", region, md)
        M = Mr if M is None else gf.Spmat("add", M, Mr)
    K = gf.asm_generic(mim, 2, "E*Grad_u.Grad_Test_u", -1, md)

    mfo = gf.MeshFem(mesh, 1)
    mfo.set_classical_fem(1)
    md.add_initialized_fem_data("obstacle", mfo, mfo.basic_dof_nodes()[0])   # signed distance: x
    if treatment == "nitsche":
        # GetFEM's Nitsche brick: the contact stress is -(sigma_n + (gamma0 / h) u_n)_-, gamma0
        # a stiffness (its brick divides by the element size).
        md.add_initialized_data("gamma0", [prm.nitsche_gamma0 * YOUNG])
        md.add_Nitsche_contact_with_rigid_obstacle_brick(
            mim, "u", md.Neumann_term("u", CONTACT), "obstacle", "gamma0", CONTACT,
            prm.nitsche_theta)
    elif treatment == "penalty":
        md.add_initialized_data("penalty", [prm.penalty * YOUNG / h])
        md.add_penalized_contact_with_rigid_obstacle_brick(mim, "u", "obstacle", "penalty", CONTACT)
    elif treatment == "multipliers":
        # Exact Signorini at the contact node: a multiplier on the contact boundary and
        # Alart-Curnier's augmented Lagrangian (non-symmetric version), solved by GetFEM's Newton.
        md.add_filtered_fem_variable("lambda", mfo, CONTACT)
        md.add_initialized_data("r_aug", [YOUNG / h])
        md.add_integral_contact_with_rigid_obstacle_brick(mim, "u", "lambda", "obstacle", "r_aug",
                                                          CONTACT, 1)

    clamp_dofs = set(int(d) for d in mfu.basic_dof_on_region(CLAMP))
    massive = [d for d in range(x.size) if d not in clamp_dofs and M[d, d] > 0]

    U0, V0, _ = exact_fields(np, x, 0.0)
    U0 = np.array(U0, dtype=float)
    V0 = np.array(V0, dtype=float)
    # M a0 = -K u0 on the dofs with mass; a massless dof has none (it does not enter the scheme).
    A0 = np.zeros(x.size)
    Mm = gf.Spmat("copy", M, massive, massive)
    rhs = -np.asarray(K.mult(U0))[massive]
    A0[massive] = np.asarray(gf.linsolve_mumps(Mm, rhs)).ravel()
    md.set_variable("u", U0)
    md.set_variable("Previous_u", U0)
    md.set_variable("Previous_Dot_u", V0)
    md.set_variable("Previous_Dot2_u", A0)
    md.set_time_step(dt)
    md.set_time(0.0)
    setup_wall = time.perf_counter() - w0

    # the time loop: GetFEM's Newton (MUMPS) on each step, histories kept in memory
    nn = x.size
    U = np.empty((steps + 1, nn))
    V = np.empty((steps + 1, nn))
    lam = np.zeros(steps + 1)
    iters = np.zeros(steps + 1, dtype=int)
    U[0], V[0] = U0[order], V0[order]
    lw0, lc0 = time.perf_counter(), time.process_time()
    for k in range(1, steps + 1):
        md.set_time(k * dt)
        try:
            nit, converged = md.solve("lsolver", "mumps", "max_iter", prm.max_iter,
                                      "max_res", prm.tol)
        except RuntimeError as err:
            msg = str(err).strip().splitlines()
            raise RunFailed("step %d (t = %g): GetFEM: %s" % (k, k * dt, msg[-1] if msg else err))
        u = md.variable("u")
        if not converged:
            raise RunFailed("step %d (t = %g): GetFEM's Newton did not converge in %d iterations"
                            % (k, k * dt, prm.max_iter))
        if not np.all(np.isfinite(u)):
            raise RunFailed("step %d (t = %g): non-finite displacement" % (k, k * dt))
        U[k] = u[order]
        V[k] = md.variable("Dot_u")[order]
        iters[k] = nit
        if treatment == "multipliers":
            lam[k] = float(np.asarray(md.variable("lambda")).ravel()[0])
        md.shift_variables_for_time_integration()
    loop_wall = time.perf_counter() - lw0
    loop_cpu = time.process_time() - lc0

    # contact pressure at x = 0, compressive positive
    if treatment == "nitsche":
        sigma = YOUNG * (U[:, 1] - U[:, 0]) / (xs[1] - xs[0])
        pressure = np.maximum(0.0, -(sigma + prm.nitsche_gamma0 * YOUNG / h * U[:, 0]))
    elif treatment == "penalty":
        pressure = prm.penalty * YOUNG / h * np.maximum(0.0, -U[:, 0])
    else:
        # GetFEM's multiplier is the contact stress vector on the body: -pressure along +x here
        pressure = np.maximum(0.0, -lam)
    # GetFEM's Newton leaves round-off (1e-16 and below) in an open contact's multiplier: a
    # pressure below 1e-9 of the benchmark's (E a / L) is no contact
    pressure[pressure < 1e-9 * YOUNG * AMPLITUDE / LENGTH] = 0.0
    pressure[0] = 0.0
    if mass == "redistributed":
        # the contact node has no inertia: its Newmark velocity is not a state of the scheme
        # (its acceleration is free); its velocity is the displacement's difference quotient
        V[1:, 0] = (U[1:, 0] - U[:-1, 0]) / dt
    energy = np.empty(steps + 1)
    inv = np.empty(nn, dtype=int)
    inv[order] = np.arange(nn)
    for k in range(steps + 1):
        uk = U[k][inv]
        vk = V[k][inv]
        energy[k] = 0.5 * float(np.dot(vk, M.mult(vk))) + 0.5 * float(np.dot(uk, K.mult(uk)))
    return {"x": xs, "U": U, "V": V, "pressure": pressure, "energy": energy, "iters": iters,
            "steps": steps, "setup_s": setup_wall, "loop_wall_s": loop_wall, "cpu_s": loop_cpu}


def run_metrics(np, res, dt, h):
    """Every metric column for one run."""
    steps = res["steps"]
    times = [k * dt for k in range(steps + 1)]
    x, U, V, p, energy = res["x"], res["U"], res["V"], res["pressure"], res["energy"]
    out = {}
    ex = [exact_end(np, t) for t in times]
    ue = np.array([e[0] for e in ex])
    ve = np.array([e[1] for e in ex])
    pe = np.array([e[2] for e in ex])
    for name, num, ref in (("end.ux", U[:, 0], ue), ("end.vx", V[:, 0], ve),
                           ("end.cx", p * AREA, pe * AREA), ("end.pn", p, pe)):
        for k, v in probe_metrics(np, num, ref).items():
            out[name + "." + k] = v
    for k, v in field_metrics(np, x, times, U, V).items():
        out["field." + k] = v
    e0 = energy[0]
    ratio = energy / e0
    for k, v in contact_metrics(times, U[:, 0], V[:, 0], p, ratio, dt, h).items():
        out["contact." + k] = v
    it = res["iters"][1:]
    out["contact.iterations_total"] = int(np.sum(it))
    out["contact.iterations_max"] = int(np.max(it))
    out["contact.iterations_mean"] = float(np.mean(it))
    out.update({"energy.initial": e0, "energy.final": energy[-1], "energy.ratio": ratio[-1],
                "energy.max_relative_drift": float(np.max(np.abs(ratio - 1.0))),
                "energy.max_growth": max(0.0, float(np.max(ratio - 1.0))),
                "energy.ratio_mechanical": ratio[-1], "scene.hmin": h})
    return out


# --- output -------------------------------------------------------------------------------------

def fmt(v):
    if v is None:
        return ""
    if isinstance(v, str):
        return v.replace("\n", " ")
    if isinstance(v, int) and not isinstance(v, bool):
        return str(v)
    v = float(v)
    return "" if math.isnan(v) else "%.10g" % v


def write_csv(path, rows):
    """compare.csv's layout, one row per run, quoted as RFC 4180 asks; written whole, then
    renamed, so that a reader never sees half a file."""
    cols = list(LEAD_COLUMNS) + METRIC_COLUMNS + list(EXTRA_COLUMNS)
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(cols)
        for r in rows:
            w.writerow([fmt(r.get(c)) for c in cols])
    os.replace(tmp, path)


# --- --verify: this script's closed form and metrics against a moreau run -----------------------

def read_history(path):
    with open(path) as f:
        head = f.readline().strip().split(",")
        data = [[float(c) if c else float("nan") for c in line.strip().split(",")]
                for line in f if line.strip()]
    return head, data


def read_vtu(np, path):
    """The arrays of one of moreau's .vtu files: {name: values (n x components)}, 'points' among
    them. moreau appends them raw (format="appended", encoding="raw", UInt64 byte counts); an
    ASCII file (older runs) is read too."""
    import xml.etree.ElementTree as ET
    with open(path, "rb") as f:
        raw = f.read()
    cut = raw.find(b"<AppendedData")
    if cut < 0:
        root, data = ET.fromstring(raw.decode()), b""
    else:
        root = ET.fromstring(raw[:cut].decode() + "</VTKFile>")
        data = raw[raw.index(b"_", cut) + 1:]
    order = "<" if root.get("byte_order", "LittleEndian") == "LittleEndian" else ">"
    kinds = {"Float64": "f8", "Int32": "i4", "UInt8": "u1"}
    out = {}
    for da in root.iter("DataArray"):
        name, ncomp = da.get("Name"), int(da.get("NumberOfComponents", "1"))
        if da.get("format") == "appended":
            off = int(da.get("offset"))
            nbytes = int(np.frombuffer(data[off:off + 8], dtype=order + "u8")[0])
            vals = np.frombuffer(data[off + 8:off + 8 + nbytes], dtype=order + kinds[da.get("type")])
        else:
            vals = np.array([float(s) for s in da.text.split()]) if da.text else np.array([])
        out[name if name is not None else "points"] = vals.reshape(-1, ncomp) if ncomp > 1 else vals
    return out


def read_fields(np, run_dir):
    """The displacement and velocity of every frame of fields.pvd (nodes sorted by x)."""
    import xml.etree.ElementTree as ET
    pvd = os.path.join(run_dir, "fields.pvd")
    if not os.path.exists(pvd):
        return None
    frames = []
    for ds in ET.parse(pvd).getroot().iter("DataSet"):
        t = float(ds.get("timestep"))
        arrays = read_vtu(np, os.path.join(run_dir, ds.get("file")))
        pts = arrays["points"][:, 0]
        order = np.argsort(pts)
        frames.append((t, pts[order], arrays["displacement"][:, 0][order], arrays["velocity"][:, 0][order]))
    return frames


def verify(np, run_dir, tol_exact, tol_metric):
    """Check this script against a moreau run of cases/bar-obstacle: (1) the closed form against
    the run's exact columns, (2) the probe metrics' formulas on the run's histories against its
    summary.json, (3) the field metrics on its fields (when written at every step). Prints one
    line per check; returns whether all agree."""
    import json
    head, rows = read_history(os.path.join(run_dir, "history.csv"))
    with open(os.path.join(run_dir, "summary.json")) as f:
        summary = json.load(f)
    col = {name: i for i, name in enumerate(head)}
    need = ("t", "end.ux", "end.vx", "end.pn", "end.ux.exact", "end.vx.exact", "end.pn.exact")
    missing = [c for c in need if c not in col]
    if missing:
        print("verify: %s/history.csv lacks the columns %s" % (run_dir, ", ".join(missing)))
        return False
    if len(rows) != summary["time"]["steps_done"] + 1:
        print("verify: history.csv must hold every step (output.every = 1)")
        return False
    ok = True
    times = [r[col["t"]] for r in rows]
    ends = [exact_end(np, t) for t in times]
    jumps = sum(1 for e in ends if e[3])
    # (1) the closed form, away from the instants where the end's velocity or pressure jumps:
    # there each code's value is a convention (moreau's steps accumulate t += h, so that they
    # land on either side of a jump)
    for q, idx, area in (("ux", 0, 1.0), ("vx", 1, 1.0), ("pn", 2, 1.0), ("cx", 2, AREA)):
        c = col.get("end.%s.exact" % q)
        if c is None:
            continue
        worst = max((abs(area * e[idx] - r[c]) for e, r in zip(ends, rows) if q == "ux" or not e[3]),
                    default=0.0)
        good = worst <= tol_exact
        ok &= good
        print("verify: closed form end.%s: max |this - moreau| = %.3g over %d steps%s  %s"
              % (q, worst, len(rows), "" if q == "ux" else " (%d jump instants skipped)" % jumps,
                 "ok" if good else "DIFFERS"))
    # (2) the probe metrics: the formulas, on moreau's history and its exact columns
    mets = summary["metrics"]
    for q in ("ux", "vx", "pn", "cx"):
        name = "end." + q
        if name not in col or name + ".exact" not in col or name not in mets:
            continue
        mine = probe_metrics(np, [r[col[name]] for r in rows], [r[col[name + ".exact"]] for r in rows])
        for k in ("l2_rel", "linf_rel", "linf_abs", "samples"):
            a, b = mine[k], mets[name][k]
            rel = abs(a - b) / abs(b) if b else abs(a)
            good = rel <= tol_metric
            ok &= good
            print("verify: metric %s.%s: this %.9g, moreau %.9g (relative difference %.2g)  %s"
                  % (name, k, a, b, rel, "ok" if good else "DIFFERS"))
        # the same with this script's closed form (its convention at the jump instants)
        ref = [(AREA if q == "cx" else 1.0) * e[{"ux": 0, "vx": 1}.get(q, 2)] for e in ends]
        own = probe_metrics(np, [r[col[name]] for r in rows], ref)
        print("verify: for information, %s.l2_rel with this closed form's jump convention: %.6g"
              % (name, own["l2_rel"]))
    # (3) the contact measures, from the end's histories (gap = u(0), U_n = v(0), bearing when
    # the pressure is positive) and the energy ratio
    if "energy.ratio" in col and "contact" in mets:
        dt = summary["time"]["dt"]
        mine = contact_metrics(times, [r[col["end.ux"]] for r in rows], [r[col["end.vx"]] for r in rows],
                               [r[col["end.pn"]] for r in rows], [r[col["energy.ratio"]] for r in rows],
                               dt, summary["scene"]["hmin"])
        for k in ("max_penetration", "max_vn_in_contact", "velocity_scale", "oscillation_index",
                  "status_flips", "release_time", "impulse", "impacts", "energy_after_last_impact",
                  "last_impact_end_time"):
            a, b = mine.get(k, float("nan")), mets["contact"].get(k, float("nan"))
            # history.csv holds 10 digits: a velocity jump of 1e-16 reads as 0 there
            scale = max(abs(b), 1e-9 if k in ("max_vn_in_contact", "oscillation_index") else 0.0)
            rel = abs(a - b) / scale if scale else abs(a - b)
            good = rel <= max(tol_metric, 1e-8)
            ok &= good
            print("verify: metric contact.%s: this %.9g, moreau %.9g  %s"
                  % (k, a, b, "ok" if good else "DIFFERS"))
    # (4) the field metrics, when the run wrote its fields at every step
    frames = read_fields(np, run_dir)
    nsteps = summary["time"]["steps_done"]
    if frames is None or len(frames) != nsteps + 1:
        print("verify: field metrics not checked (%s frames for %d steps; --set output.vtk.every=1 "
              "writes them all)" % ("no" if frames is None else len(frames), nsteps))
    else:
        x = frames[0][1]
        U = np.array([f[2] for f in frames])
        V = np.array([f[3] for f in frames])
        mine = field_metrics(np, x, [f[0] for f in frames], U, V)
        for k in FIELD_KEYS:
            a, b = mine[k], mets["field"][k]
            rel = abs(a - b) / abs(b) if b else abs(a)
            good = rel <= tol_metric
            ok &= good
            print("verify: metric field.%s: this %.9g, moreau %.9g (relative difference %.2g)  %s"
                  % (k, a, b, rel, "ok" if good else "DIFFERS"))
    return ok


def parse_scheme(spec, args):
    """NAME[:key=value]...: a scheme of SCHEMES and its parameters (beta, gamma, gamma0, theta,
    penalty; the command line's by default). The solver's name is getfem-NAME, followed by the
    parameters given in the spec (getfem-newmark-multipliers-beta=0.3025-gamma=0.6)."""
    parts = spec.split(":")
    name = parts[0]
    if name not in SCHEMES:
        raise ValueError("unknown scheme '%s' (schemes: %s)" % (name, ", ".join(SCHEMES)))
    prm = argparse.Namespace(beta=args.beta, gamma=args.gamma, nitsche_gamma0=args.nitsche_gamma0,
                             nitsche_theta=args.nitsche_theta, penalty=args.penalty,
                             max_iter=args.max_iter, tol=args.tol)
    attr = {"beta": "beta", "gamma": "gamma", "gamma0": "nitsche_gamma0",
            "theta": "nitsche_theta", "penalty": "penalty"}
    label = "getfem-" + name
    for kv in parts[1:]:
        key, eq, val = kv.partition("=")
        if key not in attr or not eq:
            raise ValueError("'%s' in '%s': parameters are %s, as key=value"
                             % (kv, spec, ", ".join(attr)))
        try:
            setattr(prm, attr[key], float(val))
        except ValueError:
            raise ValueError("'%s' in '%s': not a number" % (val, spec))
        label += "-%s=%s" % (key, val)
    if not (prm.beta > 0 and prm.gamma >= 0.5):
        raise ValueError("'%s': the implicit Newmark scheme needs beta > 0 and gamma >= 1/2" % spec)
    return name, label, prm


# --- command line -------------------------------------------------------------------------------

def parse_args(argv):
    ap = argparse.ArgumentParser(
        description="The bar-obstacle benchmark (Doyen-Ern-Piperno 1) with GetFEM, as rows of "
                    "moreau compare's CSV (for moreau compare --peer).")
    ap.add_argument("--nx", type=int, default=100, help="elements (default 100, as cases/bar-obstacle)")
    ap.add_argument("--dt", default="0.01", help="time steps, comma-separated (default 0.01)")
    ap.add_argument("--end", type=float, default=12.0, help="end time (default 12: four periods)")
    ap.add_argument("--schemes", default="newmark-nitsche,newmark-multipliers,massred-multipliers",
                    help="comma-separated NAME[:key=value...], NAME from: " + ", ".join(SCHEMES)
                    + "; keys beta, gamma, gamma0, theta, penalty override the options below")
    ap.add_argument("--beta", type=float, default=0.25, help="Newmark beta (default 1/4)")
    ap.add_argument("--gamma", type=float, default=0.5, help="Newmark gamma (default 1/2)")
    ap.add_argument("--nitsche-gamma0", type=float, default=5.0,
                    help="Nitsche parameter: the stiffness is gamma0 E / h (default 5)")
    ap.add_argument("--nitsche-theta", type=float, default=0.0,
                    help="Nitsche variant: 1 symmetric, 0 (default), -1 skew-symmetric")
    ap.add_argument("--penalty", type=float, default=10.0,
                    help="penalty stiffness in units of E / h (default 10)")
    ap.add_argument("--max-iter", type=int, default=50, help="Newton iterations per step (50)")
    ap.add_argument("--tol", type=float, default=1e-10, help="Newton residual (1e-10)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="run each case N times and keep the fastest (the machine's load varies)")
    ap.add_argument("--out", help="CSV file to write (moreau compare's columns)")
    ap.add_argument("--verify", metavar="RUN_DIR",
                    help="check the closed form and the metrics against a moreau run of "
                         "cases/bar-obstacle instead of running GetFEM")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    return a


def main(argv):
    a = parse_args(argv)
    if a.verify:
        try:
            import numpy as np
        except ImportError:
            sys.stderr.write("getfem_bar_obstacle.py: --verify needs numpy (python3-numpy)\n")
            return EXIT_NO_GETFEM
        return 0 if verify(np, a.verify, 1e-9, 1e-6) else EXIT_FAILED
    if not a.out:
        sys.stderr.write("getfem_bar_obstacle.py: --out FILE.csv is required (or --verify RUN_DIR)\n")
        return EXIT_USAGE
    try:
        dts = [float(s) for s in a.dt.split(",") if s]
    except ValueError:
        sys.stderr.write("getfem_bar_obstacle.py: --dt: '%s' is not a list of numbers\n" % a.dt)
        return EXIT_USAGE
    try:
        schemes = [parse_scheme(spec, a) for spec in a.schemes.split(",") if spec]
    except ValueError as err:
        sys.stderr.write("getfem_bar_obstacle.py: --schemes: %s\n" % err)
        return EXIT_USAGE
    if not schemes or not dts or any(not (d > 0) for d in dts) or a.nx < 2 or not (a.end > 0):
        sys.stderr.write("getfem_bar_obstacle.py: at least one scheme, positive time steps and end "
                         "time, nx >= 2\n")
        return EXIT_USAGE
    np, gf = import_getfem()
    version = getfem_version()
    rows = []
    failed = 0
    h = LENGTH / a.nx
    for s, label, prm in schemes:
        for dt in dts:
            row = {"solver": label, "dt": dt, "nx": a.nx, "beta": prm.beta, "gamma": prm.gamma,
                   "peer": version}
            if SCHEMES[s][1] == "nitsche":
                row.update({"nitsche_gamma0": prm.nitsche_gamma0, "nitsche_theta": prm.nitsche_theta})
            elif SCHEMES[s][1] == "penalty":
                row["penalty"] = prm.penalty
            try:
                res = None
                for _ in range(max(1, a.repeat)):
                    r = run_getfem(np, gf, s, a.nx, dt, a.end, prm)
                    if res is None or r["setup_s"] + r["loop_wall_s"] < res["setup_s"] + res["loop_wall_s"]:
                        res = r
            except RunFailed as err:
                failed += 1
                row.update({"status": "failed", "reason": str(err), "steps": None})
                sys.stderr.write("%s dt %g: failed: %s\n" % (label, dt, err))
                rows.append(row)
                continue
            p0 = time.perf_counter()
            row.update(run_metrics(np, res, dt, h))
            row.update({"status": "complete", "reason": "", "steps": res["steps"],
                        "wall_s": res["setup_s"] + res["loop_wall_s"], "cpu_s": res["cpu_s"],
                        "loop_wall_s": res["loop_wall_s"], "setup_s": res["setup_s"],
                        "post_s": time.perf_counter() - p0})
            rows.append(row)
            if not a.quiet:
                print("%-44s dt %-7g %5d steps  wall %7.3f s (loop CPU %7.3f s)  "
                      "u L2L2 %.4g  v L2L2 %.4g  E(T)/E0 %.4f"
                      % (label, dt, res["steps"], row["wall_s"], row["cpu_s"],
                         row["field.u_l2l2_rel"], row["field.v_l2l2_rel"], row["energy.ratio"]))
                sys.stdout.flush()
    write_csv(a.out, rows)
    if not a.quiet:
        print("%d runs (%d failed): %s" % (len(rows), failed, a.out))
    return EXIT_FAILED if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
