#!/bin/sh
# test_vtk_elements.sh: the VTK cells of the tetrahedra and quadratic triangles (VTK_TETRA 10,
# VTK_QUADRATIC_TETRA 24, VTK_QUADRATIC_TRIANGLE 22), read back by VTK (tests/vtkread.py,
# python3-vtk9): the cell types and sizes, every middle node at the middle
# of the edge VTK's node order gives it, and the displacement field of a uniform stress (the closed
# form) at every point.
. "$MOREAU_SRCDIR/tests/tap.sh"
PY=/usr/bin/python3

cat > "$OUT/vtu.py" <<'EOF'
import os, sys
sys.path.insert(0, os.path.join(os.environ["MOREAU_SRCDIR"], "tests"))
from vtkread import read, tuples, cells  # VTK's own reader (python3-vtk9): appended raw arrays
# VTK's edges of the quadratic cells, in the order of their middle nodes
EDGES = {24: [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)], 22: [(0, 1), (1, 2), (2, 0)]}
def middles(path):
    """the largest distance of a middle node from the middle of its VTK edge"""
    p, c, a = read(path)
    x = tuples(a, 'points'); worst = 0.0
    for k, t in zip(cells(a), a['types'][1]):
        nv = {24: 4, 22: 3}[t]
        for m, (i, j) in enumerate(EDGES[t]):
            worst = max(worst, max(abs(x[k[nv + m]][d] - 0.5 * (x[k[i]][d] + x[k[j]][d])) for d in range(3)))
    return worst
EOF
py() { "$PY" -c "import sys; sys.path.insert(0, '$OUT'); from vtu import *; $1"; }

# the box of cases/box-on-plane in T4 and T10: uniform uniaxial stress, u = (nu p x, nu p y, -p z) / E
for el in T4 T10; do
  d="$OUT/box-$el"
  "$MOREAU" run "$MOREAU_SRCDIR/cases/box-on-plane" --set "bodies.box.mesh.element=\"$el\"" \
    --set 'bodies.box.mesh.elements=[4, 4, 2]' --set 'output.vtk={}' --out "$d" --quiet
  ok $? "box-on-plane in $el with VTK fields: runs"
  f="$d/fields_box_00001.vtu"
  t=$([ $el = T4 ] && echo 10 || echo 24)
  n=$([ $el = T4 ] && echo 4 || echo 10)
  is "$(py "p, c, a = read('$f'); o = a['offsets'][1]; print(p, c, set(a['types'][1]), o[0], len(set(o[i + 1] - o[i] for i in range(c - 1))))")" \
     "$([ $el = T4 ] && echo 75 || echo 405) 192 {$t} $n 1" \
     "$el: $([ $el = T4 ] && echo 75 || echo 405) points, 192 cells of VTK type $t, $n nodes each"
  ok $(py "p, c, a = read('$f'); x = tuples(a, 'points'); u = tuples(a, 'displacement')
E, nu, p = 2.1e11, 0.3, 1e6
e = max(abs(u[i][d] - w) for i in range(len(x)) for d, w in enumerate((nu * p * x[i][0] / E, nu * p * x[i][1] / E, -p * x[i][2] / E)))
print(0 if e < 1e-9 * p * 0.05 / E else 1)") "$el: the displacement at every point is the uniform stress's, nu p x / E, nu p y / E, -p z / E"
done
ok $(py "print(0 if middles('$OUT/box-T10/fields_box_00001.vtu') < 1e-15 else 1)") \
   "T10: every middle node lies at the middle of its edge in VTK_QUADRATIC_TETRA's order (01, 12, 20, 03, 13, 23)"

# a T6 plate in plane stress pulled by a traction t: u = (t x, -nu t y) / E
cat > "$OUT/plate.cfg" <<'EOF'
title = "a T6 plate pulled on its right side (quasi-static)";
bodies = ( { name = "plate";
  mesh = { generator = "rectangle"; size = [2.0, 1.0]; elements = [4, 2]; element = "T6"; diagonal = "alternate"; };
  material = { E = 1.0e9; nu = 0.25; rho = 1000.0; hypothesis = "plane_stress"; thickness = 0.1; };
  fix = ( { set = "left"; dofs = ["x"]; }, { set = "bottom"; dofs = ["y"]; } );
  loads = ( { type = "traction"; set = "right"; value = ["2.0e6", "0.0"]; } ); } );
time = { scheme = "quasistatic"; steps = 1; };
output = { vtk = {}; };
EOF
"$MOREAU" run "$OUT/plate.cfg" --out "$OUT/plate" --quiet
ok $? "T6 plate with VTK fields: runs"
f="$OUT/plate/fields_plate_00001.vtu"
is "$(py "p, c, a = read('$f'); o = a['offsets'][1]; print(p, c, set(a['types'][1]), o[0])")" "45 16 {22} 6" \
   "T6: 45 points, 16 cells of VTK type 22 (VTK_QUADRATIC_TRIANGLE), 6 nodes each"
ok $(py "print(0 if middles('$f') < 1e-15 else 1)") "T6: every middle node at the middle of its edge in VTK's order (01, 12, 20)"
ok $(py "p, c, a = read('$f'); x = tuples(a, 'points'); u = tuples(a, 'displacement')
e = max(max(abs(u[i][0] - 2e6 * x[i][0] / 1e9), abs(u[i][1] + 0.25 * 2e6 * x[i][1] / 1e9)) for i in range(len(x)))
print(0 if e < 1e-12 else 1)") "T6: the displacement at every point is the uniform tension's, (t x, -nu t y) / E"
done_testing
