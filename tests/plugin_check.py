"""plugin_check.py: the checks of tests/test_plugin.sh on moreau's outputs, one line per check:
"0<TAB>description" when it holds, "1<TAB>description" when it does not (comments start with #).

  exact DIR TOL COL=VALUE...     the last row of DIR/history.csv: |COL - VALUE| <= TOL
  same A B TOL COL...            histories of runs A and B: max |a - b| <= TOL max |a|, per column
  differ A B TOL COL...          the same measure above TOL (a method that must not agree)
  summary DIR SOLVER TOL         summary.json: back end SOLVER, no failed solve, residual <= TOL
  compare CSV SOLVERS TOL COL... compare.csv: every SOLVER at every dt, complete, classed as the
                                 first SOLVER at that dt, and the error COL.linf_rel against
                                 the closed form <= TOL
"""
import csv
import json
import sys


def history(d):
    with open(d + "/history.csv") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    return {c: [float(r[j]) for r in rows[1:]] for j, c in enumerate(head)}


def say(good, text):
    print("%d\t%s" % (0 if good else 1, text))


def rel_diff(a, b, col):
    x, y = a[col], b[col]
    if len(x) != len(y):
        return float("inf")
    scale = max(abs(v) for v in x) or 1.0
    return max(abs(u - v) for u, v in zip(x, y)) / scale


def main(argv):
    mode = argv[0]
    if mode == "exact":
        h, tol = history(argv[1]), float(argv[2])
        for item in argv[3:]:
            col, val = item.split("=")
            got = h[col][-1]
            say(abs(got - float(val)) <= tol, "%s: %s = %.12g at the end, closed form %s (tol %g)"
                % (argv[1].rsplit("/", 1)[-1], col, got, val, tol))
    elif mode in ("same", "differ"):
        a, b, tol = history(argv[1]), history(argv[2]), float(argv[3])
        na, nb = argv[1].rsplit("/", 1)[-1], argv[2].rsplit("/", 1)[-1]
        say(a["t"] == b["t"], "%s and %s: the same %d output times" % (na, nb, len(a["t"])))
        for col in argv[4:]:
            d = rel_diff(a, b, col)
            if mode == "same":
                say(d <= tol, "%s against %s: %s within %.3g of its largest value (tol %g)" % (nb, na, col, d, tol))
            else:
                say(d > tol, "%s against %s: %s off by %.3g of its largest value (> %g: the check would fail it)"
                    % (nb, na, col, d, tol))
    elif mode == "summary":
        with open(argv[1] + "/summary.json") as f:
            s = json.load(f)
        c, tol = s["contact"], float(argv[3])
        say(s["status"] == "complete", "summary.json: status %s" % s["status"])
        say(c["solver"] == argv[2], "summary.json: contact.solver %s" % c["solver"])
        say(c["failed_solves"] == 0 and c["steps_with_contact"] > 0,
            "summary.json: %d steps with contact, %d failed solves" % (c["steps_with_contact"], c["failed_solves"]))
        say(c["residual_max"] <= tol, "summary.json: the core's residual (T10) at most %.3g (tol %g)"
            % (c["residual_max"], tol))
    elif mode == "compare":
        with open(argv[1]) as f:
            rows = list(csv.DictReader(f))
        tol = float(argv[3])
        first = {r["dt"]: r["class"] for r in rows if r["solver"] == argv[2].split(",")[0]}
        for solver in argv[2].split(","):
            mine = [r for r in rows if r["solver"] == solver]
            say(len(mine) == 2 and all(r["status"] == "complete" for r in mine),
                "compare.csv: %d complete rows of %s" % (len(mine), solver))
            say(all(first.get(r["dt"]) == r["class"] for r in mine),
                "compare.csv: %s's runs classed as %s's (%s)" % (solver, argv[2].split(",")[0],
                                                                ", ".join(r["class"] for r in mine)))
            for col in argv[4:]:
                errs = [float(r[col + ".linf_rel"]) for r in mine]
                say(errs and max(errs) <= tol, "compare.csv: %s's %s.linf_rel against the closed form at most %.3g"
                    % (solver, col, max(errs) if errs else float("nan")))
    else:
        raise SystemExit("plugin_check.py: unknown mode " + mode)


if __name__ == "__main__":
    main(sys.argv[1:])
