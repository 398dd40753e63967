"""compare_check.py: checks of the outputs of `moreau compare` for tests/test_compare.sh.

Each check prints one line "0<TAB>description" (pass) or "1<TAB>description" (fail, followed
by "#"-lines of detail); the shell test turns them into TAP results.

    compare_check.py table DIR SOLVERS DTS   compare.csv against the runs' summary.json, report.md
    compare_check.py plots DIR SOLVERS GNUPLOT   plot data and scripts (PNG and SVG if GNUPLOT=1)
    compare_check.py grid DIR                stability.csv of the cylinder-wall grid
    compare_check.py penetration DIR         nscd on cylinder-wall with unconverged solves kept
    compare_check.py blowup DIR              a run that blows up and stops on NaN
    compare_check.py finite DIR              non-finite values only in diagnosed runs
    compare_check.py verdict DIR             rods-1d: chatter and stable verdicts, no duplicate rows
    compare_check.py timings DIR N           step times over N repeats, min <= median <= max
    compare_check.py orders DIR S:P,...      Richardson orders of end.ux within 0.2 of P
    compare_check.py reference DIR DT        errors against the --reference run at DT
"""
import csv
import json
import math
import os
import re
import sys


def report(passed, text, details=()):
    """One result; its details only when it fails."""
    print("%d\t%s" % (0 if passed else 1, text))
    for d in ([] if passed else details[:12]):
        print("#   %s" % d)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def number(text):
    """The float of a cell, None when it is not a finite number."""
    try:
        v = float(text)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def flatten(obj, prefix, out):
    """summary.json's numbers as compare.c names them: keys joined by '.', a list by its last
    value under name_last."""
    for key, val in obj.items():
        name = prefix + "." + key if prefix else key
        if isinstance(val, dict):
            flatten(val, name, out)
        elif isinstance(val, bool):
            continue
        elif isinstance(val, (int, float)):
            out[name] = float(val)
        elif isinstance(val, list) and val and isinstance(val[-1], (int, float)):
            out[name + "_last"] = float(val[-1])


def summary_columns(summary):
    """The columns compare.csv must have for this run: metrics, energy, contact."""
    out = {}
    flatten(summary.get("metrics", {}), "", out)
    flatten(summary.get("energy", {}), "energy", out)
    flatten(summary.get("contact", {}), "contact", out)
    return out


def optional_columns(summary):
    """Columns compare.csv may add from elsewhere in the summary: scene.hmin, and the wall time
    of each phase as time.<phase>_s."""
    out = {}
    if isinstance(summary.get("scene", {}).get("hmin"), (int, float)):
        out["scene.hmin"] = float(summary["scene"]["hmin"])
    for key, val in summary.get("timings", {}).items():
        if isinstance(val, (int, float)) and not isinstance(val, bool):
            out["time.%s_s" % key] = float(val)
    return out


FIXED = ["solver", "dt"]
AFTER = ["wall_s", "steps", "status", "class", "reason", "time_min_s", "time_median_s", "time_max_s", "repeats"]
NFIX = len(FIXED) + len(AFTER)
CLASSES = ("stable", "chatter", "unstable", "failed")


def run_label(solver, dt, vary=()):
    """A run's folder: a key the back end ignores ("ignored" in compare.csv) is not in it."""
    label = solver + ("-dt%g" % dt if dt is not None else "")
    for key, val in vary:
        if val != "ignored":
            label += "-" + key.split(".")[-1] + val
    return re.sub(r"[/ =,]", "_", label)


def check_table(d, solvers, dts):
    head, rows = read_csv(os.path.join(d, "compare.csv"))
    report(head[:NFIX] == FIXED + AFTER, "compare.csv begins with solver, dt, wall_s, steps, status, class, reason, "
           "time_min_s, time_median_s, time_max_s, repeats", [",".join(head[:NFIX])])
    want = [(s, float(t)) for s in solvers for t in dts]
    got = [(r[0], float(r[1])) for r in rows]
    report(got == want, "compare.csv: one row per (back end, time step), %d rows in order" % len(want),
           ["got %s" % got])
    idx = {name: k for k, name in enumerate(head)}
    bad = [r[0] + " " + r[1] for r in rows
           if not (number(r[idx["wall_s"]]) and number(r[idx["wall_s"]]) > 0)
           or number(r[idx["steps"]]) is None]
    report(not bad, "compare.csv: wall_s positive and steps numeric in every row", bad)
    metric_cols = head[NFIX:]
    nonnum = []
    for r in rows:
        for name, cell in zip(metric_cols, r[NFIX:]):
            if cell != "" and number(cell) is None:
                nonnum.append("%s %s: %s = %r" % (r[0], r[1], name, cell))
    report(not nonnum, "compare.csv: every metric cell is a finite number or empty (%d columns x %d rows)"
           % (len(metric_cols), len(rows)), nonnum)
    missing, wrong, empty_bad, steps_bad = [], [], [], []
    for r in rows:
        solver, dt = r[0], float(r[1])
        with open(os.path.join(d, "runs", run_label(solver, dt), "summary.json")) as f:
            summary = json.load(f)
        cols = summary_columns(summary)
        known = dict(cols, **optional_columns(summary))
        for name, val in known.items():
            if name not in cols and name not in idx:
                continue
            if name not in idx:
                missing.append("%s %g: %s" % (solver, dt, name))
            else:
                cell = number(r[idx[name]])
                if cell is None or abs(cell - val) > 1e-9 * max(abs(val), 1e-300):
                    wrong.append("%s %g: %s = %s, summary %.10g" % (solver, dt, name, r[idx[name]], val))
        for name, cell in zip(metric_cols, r[NFIX:]):
            if cell == "" and name in known:
                empty_bad.append("%s %g: %s empty, summary %.10g" % (solver, dt, name, known[name]))
            # ref.*: the distances to the finest run of the sweep, computed by compare itself
            if cell != "" and name not in known and not name.startswith("ref."):
                empty_bad.append("%s %g: %s = %s, absent from the summary" % (solver, dt, name, cell))
        if int(float(r[idx["steps"]])) != summary["time"]["steps_done"]:
            steps_bad.append("%s %g: %s steps, summary %d" % (solver, dt, r[idx["steps"]], summary["time"]["steps_done"]))
    report(not missing, "compare.csv: a column for every number of summary.json's metrics, energy and contact, "
           "named as there", missing)
    report(not wrong, "compare.csv: every value equal to the run's summary.json (10 digits)", wrong)
    report(not empty_bad, "compare.csv: a cell is empty exactly where the run has no such metric", empty_bad)
    report(not steps_bad, "compare.csv: steps as in each summary", steps_bad)
    # metrics.contact and the solver's contact block share the prefix "contact.": no name in both
    with open(os.path.join(d, "runs", run_label(rows[0][0], float(rows[0][1])), "summary.json")) as f:
        summary = json.load(f)
    both = set(summary["metrics"].get("contact", {})) & set(summary.get("contact", {}))
    report(not both, "summary.json: metrics.contact and contact name different quantities (one column each)",
           sorted(both))
    with open(os.path.join(d, "report.md")) as f:
        text = f.read()
    classes = [r[idx["class"]] for r in rows]
    line = "%d runs: %d stable, %d chatter, %d unstable, %d failed" % (
        len(rows), classes.count("stable"), classes.count("chatter"), classes.count("unstable"), classes.count("failed"))
    labels = [run_label(r[0], float(r[1])) for r in rows]
    report(line in text and all("| %s |" % lab in text for lab in labels),
           "report.md: '%s' and a table row per run" % line)


GP_REF = re.compile(r"'(\.\./runs/[^']+/history\.csv)' using 1:(\d+)")


def check_plots(d, solvers, gnuplot):
    p = os.path.join(d, "plots")
    with open(os.path.join(d, "compare.csv"), newline="") as f:
        head, rows = read_csv(os.path.join(d, "compare.csv"))
    idx = {name: k for k, name in enumerate(head)}
    bad = []
    for s in solvers:
        path = os.path.join(p, "work-precision-%s.csv" % s)
        if not os.path.exists(path):
            bad.append("%s missing" % path)
            continue
        with open(path) as f:
            data = [line.strip().split(",") for line in f if line.strip()]
        mine = [r for r in rows if r[0] == s and r[idx["status"]] == "complete"]
        if len(data) != len(mine) or any(len(x) != 3 or None in map(number, x) for x in data):
            bad.append("%s: %d rows for %d runs: %s" % (path, len(data), len(mine), data))
            continue
        for x, r in zip(data, mine):
            if abs(float(x[1]) - float(r[idx["field.u_l2l2_rel"]])) > 1e-5 * float(x[1]) or float(x[2]) != float(r[1]):
                bad.append("%s: %s against %s" % (path, x, r[:2]))
    report(not bad, "plots: work-precision data per back end (wall, field.u_l2l2_rel, dt of each run)", bad)
    scripts = sorted(f for f in os.listdir(p) if f.endswith(".gp"))
    need = ["work-precision.gp", "energy.gp", "history-end.ux.gp", "history-end.vx.gp"]
    report(all(n in scripts for n in need), "plots: gnuplot scripts kept (%s)" % ", ".join(scripts))
    bad = []
    for sc in scripts:
        with open(os.path.join(p, sc)) as f:
            text = f.read()
        for ref, col in GP_REF.findall(text):
            path = os.path.normpath(os.path.join(p, ref))
            if not os.path.exists(path):
                bad.append("%s: %s missing" % (sc, ref))
                continue
            with open(path) as f:
                header = f.readline().strip().split(",")
            if int(col) > len(header):
                bad.append("%s: column %s of %s (%d columns)" % (sc, col, ref, len(header)))
            elif sc.startswith("history-") and header[int(col) - 1] not in (sc[8:-3], sc[8:-3] + ".exact"):
                bad.append("%s: column %s of %s is %s" % (sc, col, ref, header[int(col) - 1]))
            elif sc == "energy.gp" and header[int(col) - 1] != "energy.ratio":
                bad.append("%s: column %s is %s" % (sc, col, header[int(col) - 1]))
    report(not bad, "plots: every history the scripts plot exists, with the column they name", bad)
    if gnuplot:
        bad = []
        for sc in scripts:
            for ext, magic in (("png", b"\x89PNG"), ("svg", b"<svg")):
                path = os.path.join(p, sc[:-3] + "." + ext)
                if not os.path.exists(path) or os.path.getsize(path) == 0:
                    bad.append("%s missing or empty" % path)
                    continue
                with open(path, "rb") as f:
                    blob = f.read(4096)
                if magic not in blob:
                    bad.append("%s: not a %s file" % (path, ext))
        report(not bad, "plots: gnuplot rendered every script to PNG and SVG (%d figures)" % len(scripts), bad)


def check_grid(d):
    head, rows = read_csv(os.path.join(d, "stability.csv"))
    want_head = ["solver", "dt", "contact.nscd.max_sweeps", "contact.newmark.beta", "class", "reason",
                 "energy_max_growth", "max_penetration", "wall_s"]
    report(head == want_head, "stability.csv: solver, dt, the varied keys, class, reason, energy_max_growth, "
           "max_penetration, wall_s", [",".join(head)])
    # a back end ignores another's options: nscd ignores newmark.beta, newmark nscd.max_sweeps,
    # levelset both; each such cell shares the run of the key's first value, one row per run
    want = [("nscd", "1", "ignored"), ("nscd", "1000", "ignored"), ("levelset", "ignored", "ignored"),
            ("newmark", "ignored", "0.4"), ("newmark", "ignored", "0.1")]
    report([tuple(r[0:1] + r[2:4]) for r in rows] == want,
           "stability.csv: the 3 x 2 x 2 grid as 5 runs, no duplicate rows (the keys a back end ignores read "
           "'ignored')", ["%s" % [tuple(r[0:1] + r[2:4]) for r in rows]])
    bad = []
    for r in rows:
        cls, why = r[4], r[5]
        if cls not in CLASSES or why == "":
            bad.append(",".join(r))
        if any(number(x) is None for x in (r[1], r[6], r[7], r[8])):
            bad.append("non-numeric: " + ",".join(r))
    report(not bad, "stability.csv: every run classified, with its reason, numbers finite", bad)
    cls = {(r[0], r[2], r[3]): (r[4], r[5]) for r in rows}
    # nscd: one sweep cannot solve the 32 coupled candidates of the landing; 1000 do (6 at most)
    report(cls[("nscd", "1", "ignored")] == ("failed", "non-convergence"),
           "nscd with max_sweeps = 1: failed, non-convergence (%s)" % (cls[("nscd", "1", "ignored")],))
    # Newmark (0.1, 0.7): 2 beta < gamma, stable only for omega h < 1 / sqrt(gamma/2 - beta) = 2.24;
    # the wall (c = 5.1e5 m/s, 5 mm elements) has omega h of about 200 at h = 1 us
    report(cls[("newmark", "ignored", "0.1")][0] == "unstable" and cls[("newmark", "ignored", "0.1")][1].startswith("energy growth"),
           "newmark with beta = 0.1 (omega h far above 2.24): unstable, energy growth (%s)"
           % (cls[("newmark", "ignored", "0.1")][1],))
    # Newmark (0.4, 0.7): the contact nodes bounce while closed (BDZ07 Fig. 9): chatter
    report(cls[("newmark", "ignored", "0.4")][0] == "chatter",
           "newmark with the case's (0.4, 0.7): chatter (%s)" % (cls[("newmark", "ignored", "0.4")][1],))
    stable = [("levelset", "ignored", "ignored"), ("nscd", "1000", "ignored")]
    report(all(cls[k][0] == "stable" for k in stable),
           "the case's settings are stable for nscd and levelset, whatever the other back ends' options (%d runs)"
           % len(stable), ["%s: %s" % (k, cls[k]) for k in stable if cls[k][0] != "stable"])
    head2, rows2 = read_csv(os.path.join(d, "compare.csv"))
    i = {n: k for k, n in enumerate(head2)}
    failed = [r for r in rows2 if r[i["status"]] == "failed"]
    report(len(failed) == 1 and all(r[0] == "nscd" and int(r[i["steps"]]) < 40 for r in failed)
           and all(int(r[i["steps"]]) == 40 for r in rows2 if r not in failed),
           "compare.csv: the failed run stops before the end (step %s of 40), the others reach it"
           % ",".join(r[i["steps"]] for r in failed))
    with open(os.path.join(d, "report.md")) as f:
        text = f.read()
    report("- `nscd-max_sweeps1` failed: " in text and "iteration limit" in text,
           "report.md names each failed run with the solver's diagnosis")
    report("7 grid cells were not run" in text and "`contact.newmark.beta` (nscd, levelset)" in text
           and "`contact.nscd.max_sweeps` (levelset, newmark)" in text,
           "report.md says which cells were not run and which back end ignores which key")
    bad = []
    code = {"stable": "0", "unstable": "1", "failed": "2", "chatter": "3"}
    for s in ("nscd", "levelset", "newmark"):
        with open(os.path.join(d, "plots", "stability-%s.csv" % s)) as f:
            data = [line.strip().split(",") for line in f if line.strip()]
        # every cell of the grid, with the class of the run it shares, marked when not run
        want = []
        for a in ("1", "1000"):
            for b in ("0.4", "0.1"):
                key = (s, a if s == "nscd" else "ignored", b if s == "newmark" else "ignored")
                # run when every key it ignores is at its first value
                run = (s == "nscd" and b == "0.4" or s == "newmark" and a == "1"
                       or s == "levelset" and (a, b) == ("1", "0.4"))
                want.append([a, b, code[cls[key][0]], "0" if run else "1"])
        if [x[:3] + x[4:5] for x in data] != want:
            bad.append("%s: %s, want %s" % (s, data, want))
    report(not bad, "plots: the stability map of each back end has every cell, the class of its run, marked "
           "when it shares another's", bad)


def check_penetration(d):
    head, rows = read_csv(os.path.join(d, "stability.csv"))
    cls = {(r[2], r[3]): (r[4], r[5], float(r[7])) for r in rows}
    # one sweep with contact.on_failure = continue leaves the 32 coupled candidates unsolved:
    # they sink (5 % of the smallest element at theta = 1, where a landing leaves nothing)
    c1 = cls[("1", "1")]
    report(c1[0] == "unstable" and c1[1].startswith("penetration") and "of the smallest element" in c1[1],
           "one unconverged sweep per step, theta = 1: unstable, penetration (%s)" % c1[1])
    c2 = cls[("1", "0.5")]
    report(c2[0] == "unstable" and "beyond the" in c2[1] and "a landing leaves" in c2[1],
           "one unconverged sweep per step, theta = 1/2: unstable, beyond what a landing leaves (%s)" % c2[1])
    # converged: theta = 1/2 at velocity level keeps (1 - theta) h |U_n| of each landing, more
    # than 1 % of the smallest element and still the consistent O(h) error, not an instability
    c3, c4 = cls[("1000", "1")], cls[("1000", "0.5")]
    h2, r2 = read_csv(os.path.join(d, "compare.csv"))
    i = {n: k for k, n in enumerate(h2)}
    hmin = [float(r[i["scene.hmin"]]) for r in r2 if (r[2], r[3]) == ("1000", "0.5")][0]
    report(c3[0] == "stable" and c4[0] == "stable" and c4[2] > 0.01 * hmin,
           "converged solves are stable, theta = 1/2 with its landing penetration %.3g (%.2f of the smallest element; "
           "%s, %s)" % (c4[2], c4[2] / hmin, c3[0], c4[0]))


def check_blowup(d):
    head, rows = read_csv(os.path.join(d, "compare.csv"))
    i = {n: k for k, n in enumerate(head)}
    r = rows[0]
    why = r[i["reason"]]
    report(r[i["status"]] == "failed" and r[i["class"]] == "unstable" and why.startswith("energy growth")
           and "stopped: NaN" in why and "not finite" in why,
           "a run that blows up and stops on NaN is unstable, with the growth and the solver's diagnosis",
           [why[:300]])
    with open(os.path.join(d, "runs", run_label("newmark", float(r[1])), "summary.json")) as f:
        summary = json.load(f)
    report(summary["status"] == "incomplete" and "NaN" in summary["reason"]
           and summary["time"]["steps_done"] == int(r[i["steps"]]),
           "its summary.json says incomplete, why, and up to which step (%d)" % summary["time"]["steps_done"])


def check_finite(d):
    """Every number of every output finite, except in runs classified unstable or failed with a
    reason (a non-finite value must come with its diagnosis)."""
    head, rows = read_csv(os.path.join(d, "compare.csv"))
    i = {n: k for k, n in enumerate(head)}
    diagnosed = {}
    runs = set(os.listdir(os.path.join(d, "runs")))
    for r in rows:
        vary = [(k, r[i[k]]) for k in head[2:i["wall_s"]]]
        # the label holds the step when --dt was given
        label = [lab for lab in (run_label(r[0], float(r[1]), vary), run_label(r[0], None, vary)) if lab in runs]
        if label:
            diagnosed[label[0]] = r[i["class"]] != "stable" and r[i["reason"]] != ""
    bad, seen = [], 0
    for label in sorted(os.listdir(os.path.join(d, "runs"))):
        run = os.path.join(d, "runs", label)
        with open(os.path.join(run, "summary.json")) as f:
            summary = json.load(f)   # Python reads NaN and Infinity tokens
        nums = {}
        flatten(summary, "", nums)
        nonfinite = [k for k, v in nums.items() if not math.isfinite(v)]
        _, hist = read_csv(os.path.join(run, "history.csv"))
        cells = sum(1 for row in hist for x in row if number(x) is None)
        seen += 1
        if (nonfinite or cells) and not diagnosed.get(label, False):
            bad.append("%s: %s, %d non-finite history cells, not diagnosed" % (label, nonfinite[:4], cells))
    for name in ("compare.csv", "stability.csv"):
        path = os.path.join(d, name)
        if os.path.exists(path):
            h, rs = read_csv(path)
            for r in rs:
                for col, x in zip(h, r):
                    if col != "reason" and x.lower() in ("nan", "-nan", "inf", "-inf"):
                        bad.append("%s: %s = %s" % (name, col, x))
    report(seen == len(rows) and not bad, "no NaN or infinity in any output (%d runs) without a diagnosis" % seen, bad)


def read_history(path):
    head, rows = read_csv(path)
    return head, [[float(x) for x in r] for r in rows]


def interp(t, ts, ys):
    """ys(ts) at t, linear (ts ascending)."""
    import bisect
    i = bisect.bisect_left(ts, t - 1e-12)
    if i < len(ts) and abs(ts[i] - t) <= 1e-12:
        return ys[i]
    i = max(1, min(i, len(ts) - 1))
    w = (t - ts[i - 1]) / (ts[i] - ts[i - 1])
    return ys[i - 1] * (1 - w) + ys[i] * w


def check_verdict(d):
    """rods-1d: newmark chatter, nscd and levelset stable; theta ignored by newmark; the verdict
    against the contact ends' velocities of history.csv."""
    head, rows = read_csv(os.path.join(d, "compare.csv"))
    i = {n: k for k, n in enumerate(head)}
    keys = [(r[0], float(r[1]), r[i["time.theta"]]) for r in rows]
    want = [(s, h, th) for s in ("nscd", "levelset") for h in (4e-6, 2e-6) for th in ("0.5", "1")] + \
           [("newmark", h, "ignored") for h in (4e-6, 2e-6)]
    report(keys == want and len(set(keys)) == len(keys),
           "compare.csv: one row per run, newmark once per step with theta 'ignored' (no duplicate rows)", [str(keys)])
    cls = {k: (r[i["class"]], r[i["reason"]]) for k, r in zip(keys, rows)}
    report(all(cls[k][0] == "chatter" for k in keys if k[0] == "newmark"),
           "newmark runs classed chatter (%s)" % [cls[k][1][:90] for k in keys if k[0] == "newmark"])
    report(all(cls[k][0] == "stable" for k in keys if k[0] != "newmark"),
           "nscd and levelset runs classed stable", ["%s: %s" % (k, cls[k]) for k in keys if cls[k][0] != "stable"])
    report(all("impact velocity 20 m/s" in cls[k][1] for k in keys),
           "every reason states the measures against the impact velocity (20 m/s, the rods' closing speed)",
           ["%s: %s" % (k, cls[k][1]) for k in keys])
    # independently: the relative velocity of the contact ends between two closed steps
    bad = []
    for k, r in zip(keys, rows):
        h, data = read_history(os.path.join(d, "runs", run_label(k[0], k[1], [("time.theta", k[2])]), "history.csv"))
        c, m, cl = h.index("cend.vx"), h.index("mend.vx"), h.index("contact.closed")
        closed = [j for j in range(1, len(data)) if data[j][cl] > 0 and data[j - 1][cl] > 0]
        jump = [data[j][m] - data[j][c] for j in closed]
        vmax = max((abs(v) for v in jump), default=0.0)
        # sign changes of [v_n] between successive closed steps, each side above 1e-3 x 20 m/s
        flips = sum(1 for q in range(1, len(closed)) if closed[q] == closed[q - 1] + 1
                    and jump[q] * jump[q - 1] < 0 and min(abs(jump[q]), abs(jump[q - 1])) > 1e-3 * 20)
        if k[0] == "newmark" and not (vmax > 0.05 * 20 or flips >= 2):
            bad.append("%s: max |[v_n]| while closed %.3g, %d sign changes: no chatter" % (k, vmax, flips))
        if k[0] != "newmark" and not vmax < 1e-8 * 20:
            bad.append("%s: max |[v_n]| while closed %.3g, not below 1e-8 x 20 m/s" % (k, vmax))
        if abs(float(r[i["contact.max_vn_in_contact"]]) - vmax) > 1e-6 * max(vmax, 1e-6):
            bad.append("%s: contact.max_vn_in_contact %s, history %.10g" % (k, r[i["contact.max_vn_in_contact"]], vmax))
    report(not bad, "history.csv: newmark's contact ends move while closed (above 5 % of 20 m/s, or 2 sign changes), "
           "nscd's and levelset's do not (below 1e-8), as max_vn_in_contact says", bad)
    with open(os.path.join(d, "report.md")) as f:
        text = f.read()
    report("`time.theta` varies alone: `time.theta_f` stays at the case's value (1)" in text,
           "report.md says that varying theta alone leaves theta_f = 1")
    report("2 grid cells were not run" in text and "`time.theta` (newmark)" in text,
           "report.md says which cells were not run and why")
    report("exact solution" not in text, "report.md does not speak of an exact solution")
    with open(os.path.join(d, "plots", "stability-newmark.csv")) as f:
        data = [line.strip().split(",") for line in f if line.strip()]
    report([x[0] for x in data] == ["0.5", "1", "0.5", "1"] and [x[2] for x in data] == ["3"] * 4
           and [x[4] for x in data] == ["0", "1", "0", "1"],
           "the stability map of newmark: every (theta, h) cell chatter, the theta = 1 cells marked", [str(data)])


def check_timings(d, n):
    head, rows = read_csv(os.path.join(d, "compare.csv"))
    i = {k: j for j, k in enumerate(head)}
    bad = []
    for r in rows:
        tmin, tmed, tmax = (number(r[i[k]]) for k in ("time_min_s", "time_median_s", "time_max_s"))
        wall, steps_s = number(r[i["wall_s"]]), number(r[i["time.steps_s"]])
        setup, out = number(r[i["time.setup_s"]]), number(r[i["time.output_s"]])
        if None in (tmin, tmed, tmax, wall, steps_s, setup, out) or r[i["repeats"]] != str(n):
            bad.append("%s %s: %s" % (r[0], r[1], [r[i[k]] for k in AFTER]))
            continue
        if not (0 < tmin <= tmed <= tmax):
            bad.append("%s %s: min %g median %g max %g" % (r[0], r[1], tmin, tmed, tmax))
        # the last run's step time is one of the repeats; with setup and output it fits in the wall
        if not (tmin * (1 - 1e-5) <= steps_s <= tmax * (1 + 1e-5)) or steps_s + setup + out > wall * (1 + 1e-5):
            bad.append("%s %s: steps %g (min %g, max %g), setup %g + output %g, wall %g"
                       % (r[0], r[1], steps_s, tmin, tmax, setup, out, wall))
    report(not bad, "compare.csv: %d repeats, 0 < min <= median <= max of the step times, setup and output "
           "apart within the wall (%d rows)" % (n, len(rows)), bad)
    bad = []
    for s in sorted(set(r[0] for r in rows)):
        with open(os.path.join(d, "plots", "work-precision-%s.csv" % s)) as f:
            data = [line.strip().split(",") for line in f if line.strip()]
        med = sorted(float(r[i["time_median_s"]]) for r in rows if r[0] == s)
        if sorted(float(x[0]) for x in data) != sorted(float("%.6g" % m) for m in med):
            bad.append("%s: %s against medians %s" % (s, [x[0] for x in data], med))
    report(not bad, "plots: the work-precision points are at the median step times", bad)


def check_orders(d, spec):
    """orders.csv against Richardson recomputed here from the runs' histories, and the finest
    order of end.ux within 0.2 of the scheme's."""
    head, rows = read_csv(os.path.join(d, "orders.csv"))
    i = {k: j for j, k in enumerate(head)}
    for item in spec.split(","):
        s, p = item.split(":")
        mine = [r for r in rows if r[0] == s and r[i["metric"]] == "end.ux"]
        if not mine:
            report(False, "orders.csv: %s end.ux" % s, [str(rows)])
            continue
        r = mine[-1]
        h = [float(r[i[k]]) for k in ("dt1", "dt2", "dt3")]
        # the independent computation: both distances on the coarsest run's rows
        ys = []
        for hk in h:
            hh, data = read_history(os.path.join(d, "runs", run_label(s, hk), "history.csv"))
            c = hh.index("end.ux")
            ys.append(([x[0] for x in data], [x[c] for x in data]))
        t1 = ys[0][0]
        y = [ys[0][1]] + [[interp(t, *ys[k]) for t in t1] for k in (1, 2)]
        d12 = math.sqrt(sum((a - b) ** 2 for a, b in zip(y[0], y[1])))
        d23 = math.sqrt(sum((a - b) ** 2 for a, b in zip(y[1], y[2])))
        q = math.log(d12 / d23) / math.log(h[0] / h[1])
        got = number(r[i["order"]])
        report(got is not None and abs(got - q) < 1e-3,
               "orders.csv: %s end.ux order %s, recomputed from the histories %.4f" % (s, r[i["order"]], q))
        report(got is not None and abs(got - float(p)) < 0.2,
               "%s: observed order of end.ux %.3f within 0.2 of %s (h = %g, %g, %g)" % (s, got or 0, p, h[0], h[1], h[2]))
    with open(os.path.join(d, "report.md")) as f:
        text = f.read()
    report("## Observed order of convergence in h (Richardson" in text, "report.md has the observed orders")


def check_reference(d, refdt):
    head, rows = read_csv(os.path.join(d, "compare.csv"))
    i = {k: j for j, k in enumerate(head)}
    dts = [float(r[1]) for r in rows]
    report(dts == [4e-4, 2e-4, float(refdt)], "compare.csv: the --reference run is a row of its own (%s)" % dts)
    ref = [number(r[i["ref.dt"]]) for r in rows]
    err = [r[i["ref.end.ux.l2_rel"]] for r in rows]
    report(ref == [float(refdt)] * 3 and err[2] == "" and 0 < float(err[1]) < float(err[0]),
           "ref.dt is the reference's step, ref.end.ux.l2_rel empty for it and shrinking with h (%s)" % err)
    # independently: the distance of the 4e-4 run's end.ux to the reference over its rows
    ha, a = read_history(os.path.join(d, "runs", run_label("nscd", 4e-4), "history.csv"))
    hb, b = read_history(os.path.join(d, "runs", run_label("nscd", float(refdt)), "history.csv"))
    ca, cb = ha.index("end.ux"), hb.index("end.ux")
    tb, yb = [x[0] for x in b], [x[cb] for x in b]
    e = math.sqrt(sum((x[ca] - interp(x[0], tb, yb)) ** 2 for x in a) / sum(interp(x[0], tb, yb) ** 2 for x in a))
    report(abs(e - float(err[0])) < 1e-6 * e, "ref.end.ux.l2_rel of h = 4e-4: %s, recomputed %.10g" % (err[0], e))
    with open(os.path.join(d, "plots", "work-precision-nscd.csv")) as f:
        data = [line.strip().split(",") for line in f if line.strip()]
    report([float(x[1]) for x in data] == [float("%.6g" % float(x)) for x in err[:2]],
           "the work-precision figure plots the error against the reference (--metric ref.end.ux.l2_rel)")
    with open(os.path.join(d, "report.md")) as f:
        text = f.read()
    report("against the case's closed form" not in text and "to the run with the smallest time step" in text,
           "report.md says the error is against the finest run, not a closed form")


def main():
    cmd, d = sys.argv[1], sys.argv[2]
    if cmd == "table":
        check_table(d, sys.argv[3].split(","), [float(x) for x in sys.argv[4].split(",")])
    elif cmd == "plots":
        check_plots(d, sys.argv[3].split(","), sys.argv[4] == "1")
    elif cmd == "grid":
        check_grid(d)
    elif cmd == "penetration":
        check_penetration(d)
    elif cmd == "blowup":
        check_blowup(d)
    elif cmd == "finite":
        check_finite(d)
    elif cmd == "verdict":
        check_verdict(d)
    elif cmd == "timings":
        check_timings(d, int(sys.argv[3]))
    elif cmd == "orders":
        check_orders(d, sys.argv[3])
    elif cmd == "reference":
        check_reference(d, sys.argv[3])


if __name__ == "__main__":
    main()
