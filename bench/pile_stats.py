#!/usr/bin/python3
"""pile_stats.py: the state of a deposit from a moreau run folder (bodies.csv, contact.csv).

  packing fraction: the solid fraction of a window in the bulk, away from the walls and the floor
    by 3 mean diameters and from the free surface by 3 (the surface taken as the mean top of
    the highest grains over the window), measured on a grid of sample points (2D: 800 x 800,
    3D: 120^3), each tested against the grains of its cell;
  coordination z: twice the contacts between grains carrying a normal force, plus the contacts
    with walls, per grain; z*: the same without the rattlers (grains with fewer than 2 force-
    bearing contacts in 2D, 3 in 3D, removed until none is left), and their fraction;
  overlap: the deepest and the mean overlap of the force-bearing contacts, per mean radius.
    pile_stats.py OUT [GROUP]     (GROUP: the grains' group, default "grains")
"""
import csv
import math
import os
import sys


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: pile_stats.py OUT [GROUP]")
    out, group = sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "grains"
    with open(os.path.join(out, "bodies.csv")) as f:
        rows = list(csv.DictReader(f))
    dim = 3 if "z" in rows[0] else 2
    axes = "xyz"[:dim]
    grains = [(tuple(float(r[a]) for a in axes), float(r["radius"]), r["name"]) for r in rows if r["group"] == group]
    n = len(grains)
    rmean = sum(g[1] for g in grains) / n
    d = 2 * rmean
    lo = [min(g[0][k] - g[1] for g in grains) for k in range(dim)]
    hi = [max(g[0][k] + g[1] for g in grains) for k in range(dim)]
    # the free surface: the mean top of the highest grain of each column of width d
    cols = {}
    for c, r, _ in grains:
        key = tuple(int((c[k] - lo[k]) // d) for k in range(dim) if k != 1)
        cols[key] = max(cols.get(key, -math.inf), c[1] + r)
    surface = sum(cols.values()) / len(cols)
    wlo = [lo[k] + 3 * d for k in range(dim)]
    whi = [hi[k] - 3 * d for k in range(dim)]
    whi[1] = surface - 3 * d
    phi = float("nan")
    if all(whi[k] > wlo[k] for k in range(dim)):
        # cells of size d: the grains touching each cell
        cell = {}
        for c, r, _ in grains:
            a = [int(math.floor((c[k] - r - lo[k]) / d)) for k in range(dim)]
            b = [int(math.floor((c[k] + r - lo[k]) / d)) for k in range(dim)]
            idx = [()]
            for k in range(dim):
                idx = [t + (j,) for t in idx for j in range(a[k], b[k] + 1)]
            for t in idx:
                cell.setdefault(t, []).append((c, r))
        m = 800 if dim == 2 else 120
        inside = total = 0
        steps = [(whi[k] - wlo[k]) / m for k in range(dim)]
        pts = [()]
        for k in range(dim):
            pts = [p + (wlo[k] + (i + 0.5) * steps[k],) for p in pts for i in range(m)]
        for p in pts:
            key = tuple(int(math.floor((p[k] - lo[k]) / d)) for k in range(dim))
            total += 1
            for c, r in cell.get(key, ()):
                if sum((p[k] - c[k]) ** 2 for k in range(dim)) <= r * r:
                    inside += 1
                    break
        phi = inside / total
    # contacts carrying a normal force
    names = {g[2] for g in grains}
    deg = {g[2]: 0 for g in grains}
    links = []
    overlaps = []
    with open(os.path.join(out, "contact.csv")) as f:
        for r in csv.DictReader(f):
            if float(r["RN"]) <= 0:
                continue
            s, m_ = r.get("slave", ""), r.get("master", "")
            if s not in names:
                continue
            overlaps.append(max(0.0, -float(r["gap"])))
            deg[s] += 1
            if m_ in names:
                deg[m_] += 1
                links.append((s, m_))
            else:
                links.append((s, None))
    ncontact = sum(deg.values())
    z = ncontact / n
    # rattlers, removed until every remaining grain has dim contacts or more
    alive = set(names)
    while True:
        dd = {g: 0 for g in alive}
        for a, b in links:
            if a in alive and (b is None or b in alive):
                dd[a] += 1
                if b is not None:
                    dd[b] += 1
        drop = {g for g in alive if dd[g] < dim}
        if not drop:
            break
        alive -= drop
    zs = sum(dd[g] for g in alive) / len(alive) if alive else float("nan")
    print("grains %d (%dD), mean radius %.4g m" % (n, dim, rmean))
    print("pile top %.4f m (mean surface %.4f m)" % (hi[1], surface))
    print("packing fraction %.4f (window x %.3f..%.3f, y %.3f..%.3f)" % (phi, wlo[0], whi[0], wlo[1], whi[1]))
    print("coordination z = %.3f, without rattlers z* = %.3f (rattlers %.1f %%)" % (z, zs, 100 * (1 - len(alive) / n)))
    if overlaps:
        print("overlap of the loaded contacts: deepest %.3g R, mean %.3g R" % (max(overlaps) / rmean,
                                                                           sum(overlaps) / len(overlaps) / rmean))


if __name__ == "__main__":
    main()
