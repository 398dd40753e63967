"""compare_check.py: checks of the outputs of `moreau compare` for tests/test_compare.sh.

Each check prints one line "0<TAB>description" (pass) or "1<TAB>description" (fail, followed
by "#"-lines of detail); the shell test turns them into TAP results.

    compare_check.py table DIR SOLVERS DTS   compare.csv against the runs' summary.json, report.md
    compare_check.py plots DIR SOLVERS GNUPLOT   plot data and scripts (PNG and SVG if GNUPLOT=1)
    compare_check.py grid DIR                stability.csv of the cylinder-wall grid
    compare_check.py penetration DIR         nscd on cylinder-wall with unconverged solves kept
    compare_check.py blowup DIR              a run that blows up and stops on NaN
    compare_check.py finite DIR              non-finite values only in diagnosed runs
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


if __name__ == "__main__":
    main()
