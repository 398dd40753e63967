#!/usr/bin/python3
"""compare_runs.py A B TOL [grains]: two run folders of the same case agree (history.csv column by
column, relative to each column's largest magnitude; summary.json's energies and contact totals). Prints
TAP-style lines 'STATUS<TAB>description' (0 pass, 1 fail) for tests/tap.sh's check().

With `grains`: a pile, whose reactions are not unique (more contacts than the grains' dofs: serial
runs in natural and shuffled orders differ by 1e-2 in them at a natural-map tolerance of 1e-11) while
the motion is: bodies.csv (positions, velocities) and every history column but the sweep count and
the reactions' sums, contact.csv's gaps and relative velocities; statuses and reactions are not
compared."""
import csv, json, sys

# columns that measure round-off themselves: compared in absolute terms
ABSOLUTE = ("contact.residual",)


def load(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], [[float(x) for x in r] for r in rows[1:]]


def reaction(name):
    """a history or contact.csv column that sums, holds or counts reactions (not unique in a pile)"""
    last = name.split(".")[-1]
    return (name in ("contact.iterations", "contact.closed", "contact.force_n", "rigid.coordination", "lambda",
                     "status") or name[0] == "R"
            or last in ("fx", "fy", "fz", "mx", "my", "mz", "moment"))


def bodies(a, b, tol):
    with open(a + "/bodies.csv") as f:
        ba = list(csv.reader(f))
    with open(b + "/bodies.csv") as f:
        bb = list(csv.reader(f))
    same = ba[0] == bb[0] and len(ba) == len(bb) and [r[0] for r in ba] == [r[0] for r in bb]
    worst, where = 0.0, "none"
    if same:
        for j, name in enumerate(ba[0]):
            try:
                xa = [float(r[j]) for r in ba[1:]]
                xb = [float(r[j]) for r in bb[1:]]
            except ValueError:
                continue
            scale = max(abs(x) for x in xa) or 1.0
            d = max(abs(x - y) for x, y in zip(xa, xb)) / scale
            if d > worst:
                worst, where = d, name
    print("%d\tbodies.csv: %d bodies, every column equal to %.1e of its largest value (worst %.2e in %s)" % (
        0 if same and worst <= tol else 1, len(ba) - 1, tol, worst, where))


def main():
    a, b, tol = sys.argv[1], sys.argv[2], float(sys.argv[3])
    grains = len(sys.argv) > 4 and sys.argv[4] == "grains"
    skip = reaction if grains else (lambda name: False)
    if grains:
        bodies(a, b, tol)
    ha, ra = load(a + "/history.csv")
    hb, rb = load(b + "/history.csv")
    print("%d\thistory.csv: the same columns (%d) and rows (%d, %d)" % (
        0 if ha == hb and len(ra) == len(rb) and ra else 1, len(ha), len(ra), len(rb)))
    if ha != hb or len(ra) != len(rb):
        return
    worst, where = 0.0, "none"
    for j, name in enumerate(ha):
        if skip(name):
            continue
        scale = 1.0 if name.endswith(ABSOLUTE) else max(abs(r[j]) for r in ra) or 1.0
        d = max(abs(x[j] - y[j]) for x, y in zip(ra, rb)) / scale
        if d > worst:
            worst, where = d, name
    print("%d\thistory.csv: every column equal to %.1e of its largest value (worst %.2e in %s)" % (
        0 if worst <= tol else 1, tol, worst, where))
    # contact.csv: the last step's candidates, every numeric column (gaps and velocities at
    # round-off of the run's own scale compared against that scale)
    try:
        with open(a + "/contact.csv") as f:
            ca = list(csv.reader(f))
        with open(b + "/contact.csv") as f:
            cb = list(csv.reader(f))
    except FileNotFoundError:
        ca = cb = None
    if ca is not None:
        same = ca[0] == cb[0] and len(ca) == len(cb)
        worst, where = 0.0, "none"
        # a column's scale is its group's: displacements and gaps, velocities, reactions
        def group(n):
            return "D" if n[0] == "D" or n == "gap" else "U" if n[0] == "U" else "R" if n[0] == "R" else n
        gmax = {}
        if same:
            for j, name in enumerate(ca[0]):
                try:
                    m = max(abs(float(r[j])) for r in ca[1:])
                except ValueError:
                    continue
                gmax[group(name)] = max(gmax.get(group(name), 0.0), m)
            for j, name in enumerate(ca[0]):
                if skip(name):
                    continue
                try:
                    xa = [float(r[j]) for r in ca[1:]]
                    xb = [float(r[j]) for r in cb[1:]]
                except ValueError:
                    same = same and all(r[j] == q[j] for r, q in zip(ca[1:], cb[1:]))
                    continue
                scale = gmax.get(group(name)) or 1.0
                d = max(abs(x - y) for x, y in zip(xa, xb)) / scale
                if d > worst:
                    worst, where = d, name
        print("%d\tcontact.csv: %d candidates, %s equal to %.1e of its largest value "
              "(worst %.2e in %s)" % (0 if same and worst <= tol else 1, len(ca) - 1,
                                      "gaps and velocities" if grains else "statuses equal, every column", tol,
                                      worst, where))
    sa = json.load(open(a + "/summary.json"))
    sb = json.load(open(b + "/summary.json"))
    print("%d\tsummary.json: both complete (%s, %s)" % (
        0 if sa.get("status") == sb.get("status") == "complete" else 1, sa.get("status"), sb.get("status")))


main()
