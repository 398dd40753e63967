"""moreau: nonsmooth contact dynamics from Python, over libmoreau (doc/python.md).

    import moreau
    r = moreau.run("cases/ball-bounce", solver="nscd", set={"time.end": 2.0}, out="/tmp/bb")
    r.history["t"], r.history["ball.y"]      # numpy arrays, one per column of history.csv
    r.summary["energy"]                       # summary.json as a dict
    r.contacts["RN"]                          # contact.csv, the last step per candidate
    c = moreau.compare("cases/bar-obstacle", solvers=["nscd", "levelset"], dt=[0.02, 0.01])
    c.table.rows(solver="nscd")["wall_s"]     # compare.csv
    moreau.read_output("out/ball-bounce")     # any output folder, as run() returns it

Runs and comparisons go through libmoreau's opaque interface (moreau/api.h) by ctypes; their
results are read back from the files they write, by the readers below.
"""
import ctypes
import os

from ._lib import Context, MoreauError, arg, lib, text
from .readers import Table, read_compare, read_contacts, read_csv, read_history, read_summary

__all__ = ["run", "check", "compare", "solvers", "version", "read_output", "read_history", "read_summary",
           "read_contacts", "read_compare", "read_csv", "Result", "Comparison", "Table", "MoreauError"]


def version():
    """libmoreau's version."""
    return text(lib().mo_version())


def _value(v):
    """A Python value in case-file syntax (the value of --set KEY=VALUE)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float) or hasattr(v, "dtype"):
        return repr(float(v))
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    s = str(v)
    bare = s and all(ch.isalnum() or ch in "_.-+" for ch in s)
    return s if bare else '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _assignments(sets):
    """--set assignments from a dict {key: value} or a list of "key=value" strings."""
    if sets is None:
        return []
    if isinstance(sets, dict):
        return ["%s=%s" % (k, _value(v)) for k, v in sets.items()]
    if isinstance(sets, str):
        return [sets]
    return [str(s) for s in sets]


class Result:
    """A run's outputs: the folder, history (Table of history.csv), summary (dict of summary.json),
    contacts (Table of contact.csv, None without contact), and from the run itself (or summary.json
    when read from a folder) steps, t, wall, step_wall, energy0, energy1, complete, metrics
    ({quantity: {"l2": .., "linf": ..}} relative errors against the case's reference)."""

    def __init__(self, outdir, steps=None, t=None, wall=None, step_wall=None, energy=(None, None), complete=None,
                 metrics=None):
        self.outdir = outdir
        self.history = read_history(outdir)
        self.summary = read_summary(outdir)
        cpath = os.path.join(outdir, "contact.csv")
        self.contacts = read_contacts(cpath) if os.path.exists(cpath) else None
        sm = self.summary
        tm = sm.get("time", {})
        self.steps = steps if steps is not None else tm.get("steps_done")
        self.t = t if t is not None else (float(self.history["t"][-1]) if len(self.history) else None)
        self.wall = wall if wall is not None else sm.get("timings", {}).get("wall")
        self.step_wall = step_wall if step_wall is not None else sm.get("timings", {}).get("steps")
        en = sm.get("energy", {})
        self.energy0 = energy[0] if energy[0] is not None else en.get("initial")
        self.energy1 = energy[1] if energy[1] is not None else en.get("final")
        self.complete = complete if complete is not None else sm.get("status") == "complete"
        if metrics is None:
            metrics = {k: {"l2": v.get("l2_rel"), "linf": v.get("linf_rel")}
                       for k, v in sm.get("metrics", {}).items() if isinstance(v, dict) and "l2_rel" in v}
        self.metrics = metrics

    def __repr__(self):
        return "Result(%r: %s steps to t = %.6g, %s; history %d x %d%s)" % (
            self.outdir, self.steps, self.t if self.t is not None else float("nan"),
            "complete" if self.complete else "incomplete", len(self.history),
            len(self.history.columns), ", %d contacts" % len(self.contacts) if self.contacts is not None else "")


def read_output(outdir):
    """An output folder of `moreau run` (history.csv and summary.json; contact.csv when there) as
    the Result that run() returns."""
    return Result(os.fspath(outdir))


def _run_job(ctx, case, solver, set, out, dump_fclib, log):
    L = ctx.lib
    job = ctypes.c_void_p()
    ctx.check(L.mo_run_job_create(arg(case), ctypes.byref(job), ctx.ptr))
    try:
        if solver is not None:
            ctx.check(L.mo_run_job_solver(job, arg(solver), ctx.ptr))
        for a in _assignments(set):
            ctx.check(L.mo_run_job_add_set(job, arg(a), ctx.ptr))
        if out is not None:
            ctx.check(L.mo_run_job_outdir(job, arg(out), ctx.ptr))
        if dump_fclib is not None:
            ctx.check(L.mo_run_job_dump_fclib(job, arg(dump_fclib), ctx.ptr))
        L.mo_run_job_log(job, 1 if log else 0)
        return job
    except BaseException:
        L.mo_run_job_free(job)
        raise


def run(case, solver=None, set=None, out=None, plugins=(), log=False, verbose=False, dump_fclib=None):
    """Run a case (a folder holding case.cfg, or a file) as `moreau run` does and return its Result.

    solver: a back end or formulation ("nscd", "levelset:bdz07", "nscd[theta=0.5]"); set: {key:
    value} or ["key=value", ...] overrides; out: the output folder (default out/<case name>);
    plugins: plug-in back ends (files or names, doc/backends.md) besides the plug-in folders';
    log: the timing table on stderr; verbose: the library's messages on stderr. A run that fails
    raises MoreauError, whose outdir and steps tell how far it got."""
    with Context(plugins, verbose) as ctx:
        L = ctx.lib
        job = _run_job(ctx, case, solver, set, out, dump_fclib, log)
        try:
            st = L.mo_run_job_exec(job, ctx.ptr)
            outdir = text(L.mo_run_job_out(job))
            ctx.check(st, outdir, L.mo_run_job_steps(job))
            metrics = {}
            for k in range(L.mo_run_job_nmetrics(job)):
                l2, linf = ctypes.c_double(), ctypes.c_double()
                name = text(L.mo_run_job_metric(job, k, ctypes.byref(l2), ctypes.byref(linf)))
                metrics[name] = {"l2": l2.value, "linf": linf.value}
            return Result(outdir, L.mo_run_job_steps(job), L.mo_run_job_time(job), L.mo_run_job_wall(job),
                          L.mo_run_job_step_wall(job), (L.mo_run_job_energy(job, 0), L.mo_run_job_energy(job, 1)),
                          bool(L.mo_run_job_complete(job)), metrics)
        finally:
            L.mo_run_job_free(job)


def check(case, solver=None, set=None, plugins=(), verbose=False):
    """Load, override, validate and build a case without running it (`moreau check`); raises
    MoreauError with the file, line and key of what is wrong."""
    with Context(plugins, verbose) as ctx:
        job = _run_job(ctx, case, solver, set, None, None, False)
        try:
            ctx.check(ctx.lib.mo_run_job_check(job, ctx.ptr))
        finally:
            ctx.lib.mo_run_job_free(job)


class Comparison:
    """A comparison's outputs: the folder, table (Table of compare.csv), counts (runs by class),
    report (report.md's path), orders and stability (Tables of orders.csv and stability.csv, None
    when not written), and run(label): one run's Result (labels: the folders under runs/)."""

    def __init__(self, outdir, counts=None):
        self.outdir = outdir
        self.table = read_compare(outdir)
        self.counts = counts
        self.report = os.path.join(outdir, "report.md")
        o, s = os.path.join(outdir, "orders.csv"), os.path.join(outdir, "stability.csv")
        self.orders = read_csv(o) if os.path.exists(o) else None
        self.stability = read_csv(s) if os.path.exists(s) else None

    @property
    def labels(self):
        d = os.path.join(self.outdir, "runs")
        return sorted(os.listdir(d)) if os.path.isdir(d) else []

    def run(self, label):
        return read_output(os.path.join(self.outdir, "runs", label))

    def __repr__(self):
        return "Comparison(%r: %d runs, %s)" % (self.outdir, len(self.table), self.counts)


def compare(case, solvers=None, dt=None, vary=None, set=None, out=None, metric=None, repeat=None, reference=None,
            penetration_tol=None, peers=(), plugins=(), verbose=False):
    """The same scene by several back ends, time steps and parameter grids, as `moreau compare`
    does; returns its Comparison.

    solvers: back ends or formulations; dt: time steps; vary: {key: [values]} (a grid over every
    key, in order); set: overrides for every run; out: the folder (default out/compare-<case>);
    metric: compare.csv's column of the work-precision figure; repeat: runs per cell (None:
    adaptive); reference: one more run per back end at this dt, the reference of the others;
    peers: CSV files of another program's rows; plugins: plug-in back ends."""
    with Context(plugins, verbose) as ctx:
        L = ctx.lib
        job = ctypes.c_void_p()
        ctx.check(L.mo_compare_job_create(arg(case), ctypes.byref(job), ctx.ptr))
        try:
            for s in ([solvers] if isinstance(solvers, str) else solvers or []):
                ctx.check(L.mo_compare_job_add_solver(job, arg(s), ctx.ptr))
            for h in ([dt] if isinstance(dt, (int, float)) else dt if dt is not None else []):
                ctx.check(L.mo_compare_job_add_dt(job, float(h), ctx.ptr))
            for key, values in (vary or {}).items():
                for v in values:
                    ctx.check(L.mo_compare_job_add_vary(job, arg(key), arg(_value(v)), ctx.ptr))
            for a in _assignments(set):
                ctx.check(L.mo_compare_job_add_set(job, arg(a), ctx.ptr))
            for p in ([peers] if isinstance(peers, str) else peers):
                ctx.check(L.mo_compare_job_add_peer(job, arg(p), ctx.ptr))
            if out is not None:
                ctx.check(L.mo_compare_job_outdir(job, arg(out), ctx.ptr))
            if metric is not None:
                ctx.check(L.mo_compare_job_metric(job, arg(metric), ctx.ptr))
            if repeat is not None:
                ctx.check(L.mo_compare_job_repeat(job, int(repeat), ctx.ptr))
            if reference is not None:
                ctx.check(L.mo_compare_job_reference(job, float(reference), ctx.ptr))
            if penetration_tol is not None:
                ctx.check(L.mo_compare_job_penetration_tol(job, float(penetration_tol), ctx.ptr))
            st = L.mo_compare_job_exec(job, ctx.ptr)
            outdir = text(L.mo_compare_job_out(job))
            ctx.check(st, outdir)
            counts = {w: L.mo_compare_job_count(job, w.encode()) for w in
                      ("run", "stable", "chatter", "unstable", "failed", "marked", "figures", "rendered", "peer")}
            return Comparison(outdir, counts)
        finally:
            L.mo_compare_job_free(job)


def solvers(plugins=()):
    """The back ends a run can name: [(name, summary)], the shipped ones then the plug-ins'
    (those given and those of the plug-in folders)."""
    with Context(plugins) as ctx:
        out = []
        for i in range(ctx.lib.mo_backend_count(ctx.ptr)):
            summ = ctypes.c_char_p()
            name = text(ctx.lib.mo_backend_name(ctx.ptr, i, ctypes.byref(summ)))
            out.append((name, text(summ.value)))
        return out
