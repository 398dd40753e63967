#!/usr/bin/python3
"""runout.py: the runout law of the column-collapse runs of a `moreau compare` folder.

For each run (runs/*/): L0 = the gate's abscissa (settings), the floor's top = the highest point
of the fixed floor disks (bodies.csv), H0 = rigid.ymax at the gate's opening (history.csv) minus
the floor's top, a = H0 / L0; the deposit's front = the last grain (x + r, along x) before a gap
of more than two mean diameters (grains that rolled away alone are not the deposit), runout
dL = front - L0, final height Hf = the highest grain top minus the floor's top.
Fits: dL / L0 = c1 a through the origin for a < 3; dL / L0 = c2 a^n (least squares on the logs)
for a > 3. Writes runout.csv and runout.gp (and runout.png with gnuplot) in the folder, and
prints the table and the fits.
    runout.py OUT
"""
import csv
import glob
import json
import math
import os
import shutil
import subprocess
import sys


def column(header, name):
    return header.index(name) if name in header else -1


def analyse(run):
    with open(os.path.join(run, "summary.json")) as f:
        summary = json.load(f)
    if summary.get("status") != "complete":
        return None, "incomplete: %s" % summary.get("reason", "?")
    bodies = summary["settings"]["bodies"]
    gate = next(b for b in bodies if b.get("name") == "gate")
    L0, t_open = gate["point"][0], gate["until"]
    grains, floor = [], []
    with open(os.path.join(run, "bodies.csv")) as f:
        for r in csv.DictReader(f):
            x, y, rad = float(r["x"]), float(r["y"]), float(r["radius"])
            (grains if r["group"] == "grains" else floor).append((x, y, rad))
    ytop = max(y + r for _, y, r in floor)
    with open(os.path.join(run, "history.csv")) as f:
        rows = list(csv.reader(f))
    head, data = rows[0], rows[1:]
    ct, cy, cv = column(head, "t"), column(head, "rigid.ymax"), column(head, "rigid.vmax")
    at_open = min(data, key=lambda r: abs(float(r[ct]) - t_open))
    H0 = float(at_open[cy]) - ytop
    xs = sorted(x + r for x, _, r in grains)
    dmean = 2 * sum(r for _, _, r in grains) / len(grains)
    front = xs[0]
    for a, b in zip(xs, xs[1:]):
        if b - a > 2 * dmean:
            break
        front = b
    beyond = sum(1 for x in xs if x > front)
    Hf = max(y + r for _, y, r in grains) - ytop
    return {
        "run": os.path.basename(run), "grains": len(grains), "L0": L0, "H0": H0, "a": H0 / L0,
        "front": front, "dL": front - L0, "dL_L0": (front - L0) / L0, "Hf_L0": Hf / L0,
        "beyond": beyond, "vmax_open": float(at_open[cv]), "vmax_end": float(data[-1][cv]),
    }, None


def fit_linear(pts):
    """c in y = c x, least squares."""
    sxx = sum(x * x for x, _ in pts)
    return sum(x * y for x, y in pts) / sxx if sxx > 0 else float("nan")


def fit_power(pts):
    """(c, n) in y = c x^n, least squares on the logs."""
    lx = [math.log(x) for x, _ in pts]
    ly = [math.log(y) for _, y in pts]
    n = len(pts)
    mx, my = sum(lx) / n, sum(ly) / n
    sxx = sum((a - mx) ** 2 for a in lx)
    if n < 2 or sxx == 0:
        return float("nan"), float("nan")
    slope = sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sxx
    return math.exp(my - slope * mx), slope


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: runout.py OUT (a moreau compare folder of the column-collapse case)")
    out = sys.argv[1]
    res = []
    for run in sorted(glob.glob(os.path.join(out, "runs", "*"))):
        r, why = analyse(run)
        if r is None:
            print("%s: left out (%s)" % (os.path.basename(run), why))
        else:
            res.append(r)
    if not res:
        sys.exit("runout.py: no complete run under %s/runs" % out)
    res.sort(key=lambda r: r["a"])
    keys = ["run", "grains", "L0", "H0", "a", "front", "dL", "dL_L0", "Hf_L0", "beyond", "vmax_open", "vmax_end"]
    with open(os.path.join(out, "runout.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in res:
            w.writerow(r)
    print("%8s %7s %8s %8s %8s %8s %7s %10s" % ("grains", "a", "dL/L0", "Hf/L0", "front", "beyond", "", "vmax_end"))
    for r in res:
        print("%8d %7.3f %8.3f %8.3f %8.3f %8d %7s %10.2e" % (r["grains"], r["a"], r["dL_L0"], r["Hf_L0"], r["front"],
                                                             r["beyond"], "", r["vmax_end"]))
    small = [(r["a"], r["dL_L0"]) for r in res if r["a"] < 3]
    large = [(r["a"], r["dL_L0"]) for r in res if r["a"] > 3]
    c1 = fit_linear(small) if small else float("nan")
    # a power law needs a range of a, not two runs at the same a
    spread = len(large) >= 2 and max(a for a, _ in large) > 1.5 * min(a for a, _ in large)
    c2, n = fit_power(large) if spread else (float("nan"), float("nan"))
    print("fit a < 3: dL/L0 = %.3f a   (%d runs; Lajeunesse et al. 2005: 1.2 a)" % (c1, len(small)))
    print("fit a > 3: dL/L0 = %.3f a^%.3f   (%d runs; Lajeunesse et al. 2005: 1.9 a^(2/3), "
          "Larrieu, Staron & Hinch 2006: exponent 0.65)" % (c2, n, len(large)))
    gp = os.path.join(out, "runout.gp")
    lines = ["'runout.csv' using 5:8 with points pt 7 ps 1.5 title 'moreau'",
             "[0.3:3] 1.2 * x with lines dt 2 lw 2 title 'Lajeunesse et al. 2005: 1.2 a'",
             "[3:10] 1.9 * x**(2.0/3) with lines dt 2 lw 2 title 'Lajeunesse et al. 2005: 1.9 a^{2/3}'"]
    if math.isfinite(c1):
        lines.append("[0.3:3] %.6g * x with lines lw 1 title 'fit: %.2f a'" % (c1, c1))
    if math.isfinite(c2) and math.isfinite(n):
        lines.append("[3:10] %.6g * x**%.6g with lines lw 1 title 'fit: %.2f a^{%.2f}'" % (c2, n, c2, n))
    with open(gp, "w") as f:
        f.write("# the runout of the column collapse against the aspect ratio (runout.py)\n"
                "set datafile separator ','\nset terminal pngcairo size 800,600\nset output 'runout.png'\n"
                "set logscale xy\nset grid\nset key top left\nset xlabel 'a = H0 / L0'\n"
                "set ylabel '(L - L0) / L0'\nset title 'column collapse: runout (moreau nscd, 2D disks, mu = 0.5)'\n"
                "plot " + ", \\\n  ".join(lines) + "\n")
    if shutil.which("gnuplot"):
        subprocess.run(["gnuplot", "runout.gp"], cwd=out, check=False)
        print("plot: %s" % os.path.join(out, "runout.png"))


if __name__ == "__main__":
    main()
