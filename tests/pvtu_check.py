#!/usr/bin/python3
"""pvtu_check.py SERIAL_DIR PARALLEL_DIR TOL: every frame of fields.pvd of a parallel run (pieces
joined by .pvtu files) holds the same mesh and arrays as the serial run's .vtu, read by VTK's own
XML readers. Points are matched by coordinates (a piece numbers its nodes its own way), cells by
their centroids. Prints 'STATUS<TAB>description' lines (0 pass, 1 fail) for tests/tap.sh."""
import sys
import xml.etree.ElementTree as ET
try:
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    import numpy as np
except ImportError as e:
    print("1\tVTK and numpy for Python (python3-vtk9, python3-numpy): %s" % e)
    sys.exit(0)


def frames(d):
    root = ET.parse(d + "/fields.pvd").getroot()
    return [(float(x.get("timestep")), x.get("file")) for x in root.iter("DataSet")]


def read(path):
    r = vtk.vtkXMLPUnstructuredGridReader() if path.endswith(".pvtu") else vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def table(g):
    """points -> point arrays, cell centroids -> cell arrays, as dicts keyed by rounded coordinates"""
    X = vtk_to_numpy(g.GetPoints().GetData())
    pd = {g.GetPointData().GetArrayName(i): vtk_to_numpy(g.GetPointData().GetArray(i))
          for i in range(g.GetPointData().GetNumberOfArrays())}
    cd = {g.GetCellData().GetArrayName(i): vtk_to_numpy(g.GetCellData().GetArray(i))
          for i in range(g.GetCellData().GetNumberOfArrays())}
    cent = []
    for c in range(g.GetNumberOfCells()):
        ids = g.GetCell(c).GetPointIds()
        cent.append(np.mean([X[ids.GetId(k)] for k in range(ids.GetNumberOfIds())], axis=0))
    return X, pd, np.array(cent), cd


def keyed(X, arrays, scale):
    out = {}
    for i, x in enumerate(X):
        k = tuple(np.round(x / scale, 6))
        out[k] = {n: a[i] for n, a in arrays.items()}
    return out


def main():
    sdir, pdir, tol = sys.argv[1], sys.argv[2], float(sys.argv[3])
    fs, fp = frames(sdir), frames(pdir)
    print("%d\tfields.pvd: %d frames in both, at the same times; the parallel one lists .pvtu files" % (
        0 if len(fs) == len(fp) and fs and all(a[0] == b[0] for a, b in zip(fs, fp))
        and all(b[1].endswith(".pvtu") for b in fp) else 1, len(fp)))
    worst, counts = 0.0, True
    for (t, fa), (_, fb) in zip(fs, fp):
        ga, gb = read(sdir + "/" + fa), read(pdir + "/" + fb)
        counts = counts and ga.GetNumberOfCells() == gb.GetNumberOfCells()
        Xa, pa, Ca, ca = table(ga)
        Xb, pb, Cb, cb = table(gb)
        scale = np.max(np.abs(Xa)) or 1.0
        for A, B, da, db in ((Xa, Xb, pa, pb), (Ca, Cb, ca, cb)):
            ka, kb = keyed(A, da, scale), keyed(B, db, scale)
            if set(ka) != set(kb) or set(da) != set(db):
                counts = False
                continue
            for n in da:
                ref = np.max(np.abs(da[n])) or 1.0
                d = max(np.max(np.abs(np.asarray(ka[k][n]) - np.asarray(kb[k][n]))) for k in ka) / ref
                worst = max(worst, d)
    print("%d\tthe pieces join into the serial mesh (the same points and cells) at every frame" % (0 if counts else 1))
    print("%d\tevery point and cell array equal to %.0e of its largest value (worst %.2e)" % (
        0 if counts and worst <= tol else 1, tol, worst))


main()
