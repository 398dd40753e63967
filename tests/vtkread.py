"""vtkread.py: moreau's VTK series read back by VTK itself (Debian's python3-vtk9: the reader
ParaView uses), for the shell tests (test_vtk_rigid.sh, test_vtk_contact.sh).

read(path) -> (points, cells, arrays): arrays maps every name to (components, values as a flat
tuple): the point and cell data, 'points', 'connectivity', 'offsets' (the end of each cell) and
'types'. It also checks the file is what moreau promises: every data array appended raw, a
UInt64 header, its FieldData TimeValue. pvd(path) -> [(time, file)]."""
import os
import xml.etree.ElementTree as ET

from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader


def header(path):
    """The XML before the appended values, parsed: the attributes moreau writes."""
    with open(path, "rb") as f:
        raw = f.read()
    cut = raw.index(b"<AppendedData")
    head = raw[:cut].decode() + "</VTKFile>"
    assert raw[cut:].startswith(b'<AppendedData encoding="raw">\n_'), path
    assert raw.endswith(b"\n</AppendedData>\n</VTKFile>\n"), path
    return ET.fromstring(head)


def _values(a):
    if a is None:
        return 0, ()
    return a.GetNumberOfComponents(), tuple(vtk_to_numpy(a).ravel().tolist())


def read(path):
    root = header(path)
    assert root.get("type") == "UnstructuredGrid" and root.get("header_type") == "UInt64", path
    for da in root.iter("DataArray"):
        if da.get("Name") == "TimeValue":
            continue
        assert da.get("format") == "appended", (path, da.get("Name"))
    r = vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    assert r.GetErrorCode() == 0, path
    g = r.GetOutput()
    arrays = {}
    pts = g.GetPoints()
    arrays["points"] = _values(pts.GetData() if pts is not None else None)
    if arrays["points"][0] == 0:
        arrays["points"] = (3, ())
    cells = g.GetCells()
    if cells is not None and g.GetNumberOfCells():
        arrays["connectivity"] = (1, tuple(vtk_to_numpy(cells.GetConnectivityArray()).tolist()))
        arrays["offsets"] = (1, tuple(vtk_to_numpy(cells.GetOffsetsArray()).tolist()[1:]))
        arrays["types"] = (1, tuple(vtk_to_numpy(g.GetCellTypesArray()).tolist()))
    else:
        arrays["connectivity"] = arrays["offsets"] = arrays["types"] = (1, ())
    for data in (g.GetPointData(), g.GetCellData()):
        for i in range(data.GetNumberOfArrays()):
            arrays[data.GetArrayName(i)] = _values(data.GetArray(i))
    tv = g.GetFieldData().GetArray("TimeValue")
    arrays["TimeValue"] = (1, (tv.GetValue(0),)) if tv is not None else (1, ())
    return g.GetNumberOfPoints(), g.GetNumberOfCells(), arrays


def tuples(arrays, name):
    c, v = arrays[name]
    return [v[i:i + c] for i in range(0, len(v), c)]


def cells(arrays):
    off = arrays["offsets"][1]
    conn = arrays["connectivity"][1]
    return [conn[(off[k - 1] if k else 0):off[k]] for k in range(len(off))]


def area(pts):
    return 0.5 * sum(pts[i][0] * pts[i - len(pts) + 1][1] - pts[i - len(pts) + 1][0] * pts[i][1]
                     for i in range(len(pts)))


def pvd(path):
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


def frames(folder, series):
    """[(time, path)] of a series' collection, the files it names checked present."""
    out = []
    for t, f in pvd(os.path.join(folder, series + ".pvd")):
        p = os.path.join(folder, f)
        assert os.path.exists(p), p
        out.append((t, p))
    return out
