"""vtk_contact_check.py FOLDER LABEL [closed]: a run's contact series checked field by field against its
contact_history.csv, contact.csv, history.csv and summary.json, each file read by its own reader
(the .vtu by VTK, tests/vtkread.py). One line per check: "0<TAB>description" when it holds,
"1<TAB>description" when not; "# ..." lines are diagnostics. The run must have written
contact_history.csv at every step and the VTK series (output.vtk) at steps the history holds."""
import csv
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vtkread  # noqa: E402

STATUS = {"open": 0, "stick": 1, "slide": 2}
folder, label = sys.argv[1], sys.argv[2]
closed_only = len(sys.argv) > 3 and sys.argv[3] == "closed"  # output.vtk.contacts = "closed"


def say(good, text):
    print("%d\t%s: %s" % (0 if good else 1, label, text))


def close(a, b, scale, rel=2e-9):
    """a and b agree to the 10 digits of the CSV files, relative to the column's scale."""
    return abs(a - b) <= rel * max(abs(a), abs(b), scale) + 1e-300


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


summary = json.load(open(os.path.join(folder, "summary.json")))
settings = summary["settings"]
bodies = [b["name"] for b in settings["bodies"]]
pairs = [p["name"] for p in settings["contact"]["pairs"] if p.get("active", True)]
hist = rows(os.path.join(folder, "history.csv"))
chist = rows(os.path.join(folder, "contact_history.csv"))
last = rows(os.path.join(folder, "contact.csv"))
with open(os.path.join(folder, "contact.csv")) as f:
    header = f.readline().strip().split(",")

# the local order: normal first, U and R alike
loc = [c[1:] for c in header if c in ("UN", "UT", "US")]
rloc = [c[1:] for c in header if c in ("RN", "RT", "RS")]
d = len(loc)
say(loc == ["N", "T", "S"][:d] and rloc == loc and header.index("UN") < header.index("RN"),
    "contact.csv orders U and R alike, normal first (%s)" % ",".join(c for c in header if c[:1] in "UR" and len(c) == 2))
say(all(c in header for c in ("R%s_other" % x for x in loc)) and
    [c for c in header if c.endswith("_other")] == ["R%s_other" % x for x in loc],
    "the other representation's columns in the same order")

# contact_history.csv: one block per step, the last one contact.csv (the columns they share)
blocks = {}
for r in chist:
    blocks.setdefault(int(r["step"]), []).append(r)
steps = summary["time"]["steps_done"]
say(sorted(blocks) == list(range(steps + 1)), "contact_history.csv has a block for each of the %d steps and t = 0" % steps)
lastb = blocks.get(steps, [])
shared = [c for c in header if not c.endswith("_other")]
same = len(lastb) == len(last) and all(
    (a[c] == b[c]) if c in ("pair", "status", "representation", "slave", "master", "candidate", "node")
    else close(float(a[c]), float(b[c]), 0) for a, b in zip(lastb, last) for c in shared)
say(same, "its last block is contact.csv, value for value (%d candidates)" % len(last))
tcol = [float(r["t"]) for r in hist]
say(all(abs(float(b[0]["t"]) - tcol[k]) <= 1e-12 * max(1, abs(tcol[k])) for k, b in blocks.items() if b),
    "each block's t is history.csv's t of its step")

# the contact points' frames, against the block of their step
frames = vtkread.frames(folder, "contact_points")
say(len(frames) >= 2, "contact_points.pvd lists %d frames" % len(frames))
kstep = {}
for k, tk in enumerate(tcol):
    kstep.setdefault(round(tk, 15), k)
bad = {}


def fail(what, why):
    bad.setdefault(what, why)


nchecked = 0
scale = {}
for c in ("gap", "measure", "lambda") + tuple("U" + x for x in loc) + tuple("R" + x for x in loc):
    scale[c] = max([abs(float(r[c])) for r in chist] + [1e-300])
for t, path in frames:
    p, ncell, a = vtkread.read(path)
    if a["TimeValue"][1] != (t,):
        fail("time", "TimeValue %s against the collection's %r in %s" % (a["TimeValue"][1], t, path))
    step = None
    for k, tk in enumerate(tcol):
        if abs(tk - t) <= 1e-12 * max(1.0, abs(t)):
            step = k
            break
    if step is None:
        fail("time", "no history row at t = %r" % t)
        continue
    want = blocks[step]
    if closed_only:
        want = [r for r in want if r["status"] != "open" or any(float(r["R" + x]) != 0 for x in loc)]
    if p != ncell or list(a["types"][1]) != [1] * p:
        fail("cells", "%s: %d points, %d cells, not one vertex each" % (path, p, ncell))
    byc = {int(r["candidate"]): r for r in want}
    cand = a["candidate"][1]
    if sorted(cand) != sorted(byc):
        fail("candidates", "%s holds candidates %s, the block %s" % (path, sorted(cand)[:8], sorted(byc)[:8]))
        continue
    X = vtkread.tuples(a, "points")
    for i, c in enumerate(cand):
        r = byc[c]
        nchecked += 1
        geom = max(1.0, max(abs(v) for v in X[i]))
        if a["pair"][1][i] != pairs.index(r["pair"]):
            fail("pair", "candidate %d: pair %d, contact_history says %s" % (c, a["pair"][1][i], r["pair"]))
        if a["node"][1][i] != int(r["node"]):
            fail("node", "candidate %d: node %d against %s" % (c, a["node"][1][i], r["node"]))
        if a["status"][1][i] != STATUS[r["status"]]:
            fail("status", "candidate %d: status %d against %s" % (c, a["status"][1][i], r["status"]))
        if bodies[a["slave"][1][i]] != r["slave"] or (r["master"] and bodies[a["master"][1][i]] != r["master"]):
            fail("bodies", "candidate %d: bodies %d %d against %s %s" % (c, a["slave"][1][i], a["master"][1][i],
                                                                          r["slave"], r["master"]))
        for name, cols in (("reference", "xyz"), ("displacement", ("D1", "D2", "D3"))):
            v = vtkread.tuples(a, name)[i]
            for j, col in enumerate(cols):
                want_v = float(r[col]) if col in r else 0.0
                if not close(v[j], want_v, geom * 1e-3):
                    fail(name, "candidate %d: %s[%d] %.17g against %s" % (c, name, j, v[j], r.get(col)))
        for name, pre in (("R", "R"), ("U", "U")):
            v = vtkread.tuples(a, name)[i]
            if len(v) != d:
                fail(name, "%d components, contact.csv has %d" % (len(v), d))
            for j, x in enumerate(loc):
                if not close(v[j], float(r[pre + x]), scale[pre + x]):
                    fail(name, "candidate %d: %s%s %.17g against %s" % (c, pre, x, v[j], r[pre + x]))
        for name in ("gap", "measure", "lambda"):
            if not close(a[name][1][i], float(r[name]), scale[name]):
                fail(name, "candidate %d: %s %.17g against %s" % (c, name, a[name][1][i], r[name]))
        # world axes: a unit normal, the force and the relative velocity whose normal parts are R_N, U_N
        n = vtkread.tuples(a, "normal")[i]
        f = vtkread.tuples(a, "force")[i]
        w = vtkread.tuples(a, "relative_velocity")[i]
        Rl, Ul = vtkread.tuples(a, "R")[i], vtkread.tuples(a, "U")[i]
        dot = lambda x, y: sum(x[k] * y[k] for k in range(3))
        if abs(dot(n, n) - 1) > 1e-12:
            fail("normal", "candidate %d: |n|^2 = %.17g" % (c, dot(n, n)))
        if abs(dot(f, n) - Rl[0]) > 1e-12 * scale["RN"] or abs(dot(f, f) - sum(x * x for x in Rl)) > 1e-11 * scale["RN"] ** 2:
            fail("force", "candidate %d: force %s against R %s" % (c, f, Rl))
        if abs(dot(w, n) - Ul[0]) > 1e-12 * max(scale["UN"], 1) or abs(dot(w, w) - sum(x * x for x in Ul)) > 1e-11 * max(scale["UN"], 1) ** 2:
            fail("relative_velocity", "candidate %d: %s against U %s" % (c, w, Ul))
        # a mesh point sits at its reference position plus its displacement
        if int(r["node"]) >= 0:
            ref = vtkread.tuples(a, "reference")[i]
            dis = vtkread.tuples(a, "displacement")[i]
            if any(abs(X[i][j] - ref[j] - dis[j]) > 1e-12 * geom for j in range(3)):
                fail("points", "candidate %d: point %s, reference + displacement %s" % (c, X[i], [ref[j] + dis[j] for j in range(3)]))
for what in ("time", "cells", "candidates", "pair", "node", "status", "bodies", "reference", "displacement", "R", "U",
             "gap", "measure", "lambda", "normal", "force", "relative_velocity", "points"):
    if what in bad:
        print("# " + bad[what])
    say(what not in bad, "contact_points: %s against contact_history.csv (%d points in %d frames)" % (what, nchecked, len(frames))
        if what not in ("normal", "force", "relative_velocity", "points", "time", "cells") else "contact_points: %s" % {
            "normal": "unit normals", "force": "force . n = R_N and |force| = |R|",
            "relative_velocity": "relative_velocity . n = U_N and |relative_velocity| = |U|",
            "points": "a mesh point is at reference + displacement",
            "time": "each file's TimeValue is its collection's time, a step of history.csv",
            "cells": "one vertex cell per point"}[what])

# the summary: the impulse is the normal reactions summed over candidates and steps (times h)
h = summary["time"]["dt"]
imp = sum(float(r["RN"]) for k, b in blocks.items() if k > 0 for r in b) * h
ref = summary["metrics"]["contact"]["impulse"]
say(close(imp, ref, 0, 1e-8), "sum of RN h over contact_history.csv = summary's impulse (%.10g, %.10g)" % (imp, ref))
pen = max(max(0.0, -float(r["gap"])) for r in chist)
mp = summary["metrics"]["contact"]["max_penetration"]
say(pen <= mp * (1 + 1e-9) + 1e-300, "the deepest gap in contact_history.csv is within max_penetration (%.6g <= %.6g)" % (pen, mp))
fp = max([0.0] + [-float(r["gap"]) for r in last])
say(close(fp, max(summary["metrics"]["contact"]["final_penetration"], 0.0), 1e-300, 1e-8),
    "contact.csv's deepest gap is final_penetration (%.6g)" % fp)
# history.csv's contact.closed at each step: the candidates with a status other than open
good = all(int(float(hist[k]["contact.closed"])) == sum(1 for r in b if r["status"] != "open") for k, b in blocks.items() if k > 0)
say(good, "history.csv's contact.closed counts contact_history.csv's closed candidates at every step")

# the planes: each one's corners on its plane at its time, the bodies' points over it
if os.path.exists(os.path.join(folder, "planes.pvd")):
    planes = [(k, b) for k, b in enumerate(settings["bodies"]) if b.get("type") == "plane"]
    pf = vtkread.frames(folder, "planes")
    say([t for t, _ in pf] == [t for t, _ in frames], "planes.pvd has the frames of contact_points.pvd")
    worst, inside, shape = 0.0, True, True
    for t, path in pf:
        p, nc, a = vtkread.read(path)
        X = vtkread.tuples(a, "points")
        nv = p // max(nc, 1)
        for i, (k, b) in enumerate(planes):
            D = len(b["normal"])
            nn = math.sqrt(sum(x * x for x in b["normal"]))
            n = [x / nn for x in b["normal"]] + [0.0] * (3 - D)
            v = b.get("velocity", [0.0] * D) + [0.0] * (3 - D)
            p0 = [b["point"][j] + v[j] * t if j < D else 0.0 for j in range(3)]
            if a["body"][1][i] != k or any(abs(a["normal"][1][3 * i + j] - n[j]) > 1e-15 for j in range(3)):
                shape = False
            corners = X[nv * i:nv * (i + 1)]
            for x in corners:
                worst = max(worst, abs(sum((x[j] - p0[j]) * n[j] for j in range(3))))
            if nv == 4:
                e1 = [corners[1][j] - corners[0][j] for j in range(3)]
                e2 = [corners[3][j] - corners[0][j] for j in range(3)]
                l1, l2 = math.sqrt(sum(x * x for x in e1)), math.sqrt(sum(x * x for x in e2))
                shape &= abs(l1 - l2) <= 1e-9 * l1 and abs(sum(e1[j] * e2[j] for j in range(3))) <= 1e-9 * l1 * l2
    say(worst <= 1e-12, "planes: every corner on its plane at the frame's time (%.2g m off at most)" % worst)
    say(shape, "planes: body, unit normal and (3D) a square")
    # the points of the contact series project inside their plane's drawing
    t, path = frames[-1]
    p, nc, a = vtkread.read(path)
    _, _, b = vtkread.read(pf[-1][1])
    P = vtkread.tuples(b, "points")
    nv = len(P) // max(len(planes), 1)
    for i, (k, bd) in enumerate(planes):
        if nv < 2:
            continue  # 1D: the plane is a point
        corners = P[nv * i:nv * (i + 1)]
        ctr = [sum(c[j] for c in corners) / nv for j in range(3)]
        n = b["normal"][1][3 * i:3 * i + 3]
        # the half-side along each edge direction: the projection of a point on the plane's
        # drawing lies within it
        edges = [[corners[1][j] - corners[0][j] for j in range(3)]]
        if nv == 4:
            edges.append([corners[3][j] - corners[0][j] for j in range(3)])
        for x in vtkread.tuples(a, "points"):
            r = [x[j] - ctr[j] for j in range(3)]
            for e in edges:
                le = math.sqrt(sum(v * v for v in e))
                if abs(sum(r[j] * e[j] for j in range(3))) / le > 0.5 * le * (1 + 1e-9):
                    inside = False
    say(inside, "planes: drawn over every contact point of the last frame")
