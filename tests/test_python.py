"""test_python.py: the moreau Python module (python/moreau) over the library of the build tree,
as TAP. A run checked against the closed forms of its scene and against the same run by the
command line read back by the readers; contact data against the block's equilibrium; a
comparison's table against its runs' summaries; errors; a plug-in back end from Python.

Environment (tests/test_python.sh sets it): MOREAU (the program), MOREAU_SRCDIR, WORK (a
scratch folder), JACOBI (the example plug-in built for this test, may be empty)."""
import math
import os
import subprocess
import sys

import numpy as np

import moreau

n = 0
failed = 0


def ok(good, text):
    global n, failed
    n += 1
    print("%s %d - %s" % ("ok" if good else "not ok", n, text))
    if not good:
        failed += 1


def skip(text):
    global n
    n += 1
    print("ok %d - # SKIP %s" % (n, text))


C = os.path.join(os.environ["MOREAU_SRCDIR"], "cases")
W = os.environ["WORK"]
g = 9.81

# 1. the module and the library
ok(moreau.version() == os.environ.get("MOREAU_VERSION", moreau.version()), "moreau.version() is libmoreau's")
names = [s[0] for s in moreau.solvers()]
ok(names[:3] == ["nscd", "levelset", "newmark"], "moreau.solvers(): the registry's back ends (%s)" % ", ".join(names))

# 2. a run: a disk dropped from h0 = 1 m on a plane, e = 0.8 (cases/ball-bounce README)
r = moreau.run(os.path.join(C, "ball-bounce"), solver="nscd",
               set={"time.end": 1.2, "output.draw.gif": False}, out=os.path.join(W, "bb"))
h = r.history
ok(r.complete and r.steps == 1200 and abs(r.t - 1.2) < 1e-12, "run: complete, 1200 steps to t = %.6g" % r.t)
ok(isinstance(h["t"], np.ndarray) and h["t"].dtype == float and len(h) == 1201,
   "history: numpy float arrays of 1201 rows (%d columns)" % len(h.columns))
ok(np.all(np.diff(h["t"]) > 0) and abs(h["t"][1] - 1e-3) < 1e-15, "history['t'] increases by dt = 1e-3")
t1 = math.sqrt(2 * 1.0 / g)                       # first impact (centre at h0 + R)
fall = h["t"] < t1 - 2e-3
ok(np.max(np.abs(h["ball.y"][fall] - (1.05 - 0.5 * g * h["t"][fall] ** 2))) < 1e-9,
   "free fall before the impact: y = h0 + R - g t^2 / 2 within 1e-9 m")
after = (h["t"] > t1 + 2e-3) & (h["t"] < t1 + 0.05)
v_up = np.max(h["ball.vy"][after])
ok(abs(v_up - 0.8 * math.sqrt(2 * g * 1.0)) < 2 * g * 1e-3, "rebound velocity %.5f m/s = e sqrt(2 g h0) = %.5f within 2 g dt"
   % (v_up, 0.8 * math.sqrt(2 * g)))
ok(np.max(np.abs(h["ball.y"] - h["ball.y.exact"])) < 0.01, "ball.y against the core's closed form column within 1 cm")
ok(abs(r.metrics["ball.y"]["linf"] - r.summary["metrics"]["ball.y"]["linf_rel"]) < 1e-12 * r.metrics["ball.y"]["linf"],
   "Result.metrics (from the run) equal summary.json's")
ok(r.summary["status"] == "complete" and r.summary["time"]["steps_done"] == r.steps, "summary: a dict of summary.json")
ok(r.contacts is not None and all(k in r.contacts for k in ("pair", "gap", "UN", "RN", "status")),
   "contact.csv read: the candidates' pair, gap, UN, RN, status (%d rows)" % len(r.contacts))

# 3. the same run by the command line, read back by the readers: the same numbers
cli = os.path.join(W, "bb-cli")
p = subprocess.run([os.environ["MOREAU"], "run", os.path.join(C, "ball-bounce"), "--solver", "nscd", "--set", "time.end=1.2",
                    "--set", "output.draw.gif=false", "--out", cli, "--quiet"], stderr=subprocess.PIPE)
ok(p.returncode == 0, "the command line's run: exit 0")
o = moreau.read_output(cli)
ok(o.history.columns == h.columns and all(np.array_equal(o.history[c], h[c]) for c in h.columns),
   "read_output: the command line's history equals the module's, column by column")
ok(o.steps == r.steps and o.complete and abs(o.metrics["ball.vy"]["l2"] - r.metrics["ball.vy"]["l2"]) < 1e-10,
   "read_output: steps, status and metrics from summary.json")
hh = moreau.read_history(os.path.join(cli, "history.csv"))
ok(np.array_equal(hh["ball.vy"], h["ball.vy"]), "read_history takes the file as well as the folder")
try:
    import pandas  # noqa: F401
    df = moreau.read_history(cli, pandas=True)
    ok(list(df.columns) == h.columns and np.allclose(df["ball.y"].to_numpy(), h["ball.y"], rtol=1e-15, atol=0),
       "pandas: read_history(pandas=True) is the same table")
    ok(h.to_pandas().shape == (1201, len(h.columns)), "pandas: Table.to_pandas()")
except ImportError:
    skip("pandas not installed: the readers' pandas form untested")
    skip("pandas not installed")

# 4. contact data: a block resting on a 20 degree slope, mu = 0.5 (cases/incline-block): the two
#    corner reactions carry m g cos 20 normally and m g sin 20 tangentially
r = moreau.run(os.path.join(C, "incline-block"), set={"time.end": 0.1, "output.draw.gif": False},
               out=os.path.join(W, "ib"))
c = r.contacts
a = math.radians(20)
ok(len(c) == 2 and c["status"].dtype.kind == "U" and c["RN"].dtype == float and list(c["status"]) == ["stick", "stick"],
   "contacts: two corners, both sticking (%s; text and number columns)" % list(c["status"]))
ok(abs(np.sum(c["RN"]) - g * math.cos(a)) < 1e-6, "sum of RN = m g cos 20 = %.6f N (%.9f)" % (g * math.cos(a), np.sum(c["RN"])))
ok(abs(abs(np.sum(c["RT"])) - g * math.sin(a)) < 1e-6, "|sum of RT| = m g sin 20 = %.6f N (%.9f)" % (g * math.sin(a), abs(np.sum(c["RT"]))))

# 5. a comparison: its table against its runs' summaries
cmp = moreau.compare(os.path.join(C, "bar-obstacle"), solvers=["nscd", "levelset"], dt=[0.04, 0.02],
                     set={"bodies.bar.mesh.elements": 25, "time.end": 3.0}, repeat=1, out=os.path.join(W, "cmp"))
t = cmp.table
ok(cmp.counts["run"] == 4 and len(t) == 4, "compare: 4 runs, 4 rows of compare.csv (%s)" % cmp.counts)
ok(sorted(set(t["solver"])) == ["levelset", "nscd"] and sorted(set(t["dt"])) == [0.02, 0.04], "compare.csv: solvers and dt")
ok(len(cmp.labels) == 4, "compare: the runs' folders (%s)" % ", ".join(cmp.labels))
good = True
for lab in cmp.labels:
    run = cmp.run(lab)
    solver, dt = lab.split("-dt")
    row = t.rows(solver=solver, dt=float(dt))
    good &= len(row) == 1 and int(row["steps"][0]) == run.steps
    for m, v in run.metrics.items():
        col = m + ".l2_rel"
        if col in row:
            good &= abs(row[col][0] - v["l2"]) <= 1e-9 * max(abs(v["l2"]), 1e-300)
ok(good, "compare.csv: each row's steps and errors equal its run's summary.json")
ok(np.array_equal(moreau.read_compare(cmp.outdir)["wall_s"], t["wall_s"]), "read_compare on the folder")

# 6. errors: bad input names the key; a missing case; a failed run keeps its partial outputs
try:
    moreau.run(os.path.join(C, "ball-bounce"), set={"time.dt": -1.0}, out=os.path.join(W, "bad"))
    ok(False, "a negative time step is refused")
except moreau.MoreauError as e:
    ok(e.status == 2 and "time.dt" in str(e), "a negative time step: MoreauError status 2 naming time.dt (%s)" % e)
try:
    moreau.check(os.path.join(C, "no-such-case"))
    ok(False, "a missing case is refused")
except moreau.MoreauError as e:
    ok(e.status in (2, 3) and "no-such-case" in str(e), "check of a missing case: MoreauError naming it")
try:
    moreau.run(os.path.join(C, "ball-bounce"), plugins=[os.path.join(W, "none.so")], out=os.path.join(W, "np"))
    ok(False, "a missing plug-in is refused")
except moreau.MoreauError as e:
    ok("no such file" in str(e), "a missing plug-in file: MoreauError (%s)" % e)

# 7. a plug-in back end from Python: Newton's cradle by the example Jacobi, (-1/3, 2/3, 2/3) v0
J = os.environ.get("JACOBI")
if J:
    ok("jacobi" in [s[0] for s in moreau.solvers(plugins=[J])], "moreau.solvers(plugins=[jacobi.so]) lists it")
    r = moreau.run(os.path.join(C, "newton-cradle"), solver="jacobi", plugins=[J], set={"output.draw.gif": False},
                   out=os.path.join(W, "nc"))
    v = [r.history[b + ".vx"][-1] for b in ("b1", "b2", "b3")]
    ok(np.allclose(v, [-1 / 3, 2 / 3, 2 / 3], atol=1e-7), "newton-cradle by the plug-in: %s" % v)
    ok(r.summary["contact"]["solver"] == "jacobi", "summary.json names the plug-in's back end")
else:
    for _ in range(3):
        skip("no C compiler to build the example plug-in")

print("1..%d" % n)
sys.exit(1 if failed else 0)
