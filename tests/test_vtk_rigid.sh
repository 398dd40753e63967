#!/bin/sh
# test_vtk_rigid.sh: the VTK series of rigid bodies (particles, polygons, contact network), read
# back by VTK (tests/vtkread.py) and checked against closed forms.
. "$MOREAU_SRCDIR/tests/tap.sh"
PY=/usr/bin/python3

# two disks and a rectangle resting on a floor, a disk resting on a fixed rigid slab (a mesh)
cat > "$OUT/rest.cfg" <<'EOF'
title = "vtk-rigid: disks and a block at rest on a floor, a disk on a rigid slab";
bodies = (
  { name = "floor"; type = "plane"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },
  { name = "d1"; type = "disk"; center = [0.0, 0.1]; radius = 0.1; density = 1000.0; body_force = [0.0, -9.81]; },
  { name = "d2"; type = "disk"; center = [0.5, 0.05]; radius = 0.05; density = 2000.0; body_force = [0.0, -9.81]; },
  { name = "block"; type = "polygon"; center = [1.0, 0.1]; size = [0.4, 0.2]; density = 500.0;
    body_force = [0.0, -9.81]; },
  { name = "slab"; type = "rigid_mesh"; density = 1000.0; fixed = true;
    mesh = { generator = "rectangle"; origin = [1.5, 0.0]; size = [0.3, 0.1]; elements = [3, 1]; }; },
  { name = "d3"; type = "disk"; center = [1.65, 0.15]; radius = 0.05; density = 1000.0; body_force = [0.0, -9.81]; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-3; steps = 20; };
contact = {
  solver = "nscd";
  pairs = ( { name = "p1"; slave = "d1"; master = "floor"; mu = 0.3; },
            { name = "p2"; slave = "d2"; master = "floor"; mu = 0.3; },
            { name = "p3"; slave = "block"; master = "floor"; mu = 0.3; },
            { name = "p4"; slave = "d3"; master = "slab"; master_set = "top"; mu = 0.3; } );
};
output = { vtk = { every = 5; }; };
EOF

# the files read back by VTK (tests/vtkread.py, Debian's python3-vtk9: ParaView's reader)
if ! "$PY" -c "import vtkmodules.vtkIOXML" 2>/dev/null; then
  echo "1..0 # SKIP python3-vtk9 is not installed (the quickstart installs it)"
  exit 0
fi
py() { "$PY" -c "import sys, glob, os, math; sys.path.insert(0, '$MOREAU_SRCDIR/tests'); from vtkread import *; $1"; }

d="$OUT/r"
"$MOREAU" run "$OUT/rest.cfg" --out "$d" --quiet; ok $? "run: disks, a block and a slab at rest, output.vtk every 5 steps"
n=$(ls "$d"/particles_*.vtu "$d"/polygons_*.vtu "$d"/contacts_*.vtu 2>/dev/null | wc -l)
is "$n" "15" "5 frames (steps 0, 5, 10, 15, 20) of particles_, polygons_ and contacts_"
ok $(py "[read(f) for f in glob.glob('$d/*_0000?.vtu')]; print(0)") "every .vtu is read by VTK, its arrays appended raw"

# particles: 3 points, radii and vertex cells
is "$(py "p, c, a = read('$d/particles_00004.vtu'); print(p, c, sorted(a['radius'][1]), set(a['types'][1]))")" \
   "3 3 [0.05, 0.05, 0.1] {1}" "particles: 3 points, 3 vertex cells, the radii of the disks"
is "$(py "p, c, a = read('$d/particles_00004.vtu'); print(tuples(a, 'points')[0], a['body'][1], a['orientation'][0], a['omega'][0], a['velocity'][0])")" \
   "(0.0, 0.1, 0.0) (1, 2, 5) 1 3 3" "particles: centres, body numbers, orientation (1 component in 2D), omega and velocity (3)"
ok $(py "p, c, a = read('$d/particles_00004.vtu'); print(0 if max(abs(x) for x in a['velocity'][1]) < 1e-9 else 1)") "particles: bodies at rest have zero velocity"

# polygons: the block as a VTK_POLYGON (area a b = 0.4 x 0.2), the slab as its 3 quadrilaterals
is "$(py "p, c, a = read('$d/polygons_00004.vtu'); print(p, c, a['types'][1], a['body'][1])")" \
   "12 4 (7, 9, 9, 9) (3, 4, 4, 4)" "polygons: the polygon and the slab's 3 Q4 cells, with their bodies"
ok $(py "p, c, a = read('$d/polygons_00004.vtu'); x = tuples(a, 'points'); cs = cells(a)
A = area([x[i] for i in cs[0]]); S = sum(area([x[i] for i in k]) for k in cs[1:])
print(0 if abs(A - 0.08) < 1e-9 and abs(S - 0.03) < 1e-12 else 1)") "polygons: the block's world vertices enclose a b = 0.08, the slab's cells 0.3 x 0.1"
ok $(py "p, c, a = read('$d/polygons_00000.vtu'); x = tuples(a, 'points')
print(0 if sorted(x[:4]) == sorted([(0.8, 0.0, 0.0), (1.2, 0.0, 0.0), (1.2, 0.2, 0.0), (0.8, 0.2, 0.0)]) else 1)") \
   "polygons: the rectangle's vertices at t = 0 are centre -+ (a/2, b/2)"

# contacts: empty at t = 0, then one line per contact with rn the weight it carries
is "$(py "p, c, a = read('$d/contacts_00000.vtu'); print(p, c, sorted(a))")" \
   "0 0 ['TimeValue', 'connectivity', 'gap', 'master', 'offsets', 'point', 'points', 'rn', 'rt', 'slave', 'status', 'types']" \
   "contacts at t = 0: an empty network is a valid file with every array"
is "$(py "p, c, a = read('$d/contacts_00004.vtu'); print(p, c, set(a['types'][1]), sorted(a['slave'][1]), set(a['status'][1]) <= {1, 2})")" \
   "10 5 {3} [1, 2, 3, 3, 5] True" "contacts at the end: 5 lines (a disk each, the block's 2 corners), closed"
rn() { # rn SLAVE: the normal forces of the lines of body SLAVE, summed
  py "p, c, a = read('$d/contacts_00004.vtu'); print('%.10g' % sum(r for r, s in zip(a['rn'][1], a['slave'][1]) if s == $1))"
}
relerr() { # relerr GOT WANT TOL: 0 when |GOT / WANT - 1| < TOL, else 1 (also when GOT is not a number)
  "$PY" -c "import sys
try: print(0 if abs(float(sys.argv[1]) / float(sys.argv[2]) - 1) < float(sys.argv[3]) else 1)
except ValueError: print(1)" "$@"
}
ok $(relerr "$(rn 1)" "$("$PY" -c "import math; print(1000 * math.pi * 0.1**2 * 9.81)")" 1e-6) "rn of disk d1 = rho pi R^2 g = 308.19 N per unit thickness ($(rn 1))"
ok $(relerr "$(rn 2)" "$("$PY" -c "import math; print(2000 * math.pi * 0.05**2 * 9.81)")" 1e-6) "rn of disk d2 = rho pi R^2 g ($(rn 2))"
ok $(relerr "$(rn 3)" "392.4" 1e-6) "rn of the block's two corners = rho a b g = 392.4 N ($(rn 3))"
ok $(relerr "$(rn 5)" "$("$PY" -c "import math; print(1000 * math.pi * 0.05**2 * 9.81)")" 1e-6) "rn of disk d3 on the slab = rho pi R^2 g ($(rn 5))"
is "$(py "p, c, a = read('$d/contacts_00004.vtu'); x = tuples(a, 'points'); k = list(a['slave'][1]).index(1); print(x[2 * k], x[2 * k + 1], a['master'][1][k])")" \
   "(0.0, 0.1, 0.0) (0.0, 0.0, 0.0) 0" "a disk on the floor: its line runs from its centre to the contact point on the plane"
is "$(py "p, c, a = read('$d/contacts_00004.vtu'); x = tuples(a, 'points'); k = list(a['slave'][1]).index(5); print(x[2 * k], x[2 * k + 1], tuples(a, 'point')[k])")" \
   "(1.65, 0.15, 0.0) (1.65, 0.1, 0.0) (1.65, 0.1, 0.0)" "a disk on the slab: from its centre to the contact point on the mesh"

# the collections: every frame with its time, the files they name present
for s in particles polygons contacts; do
  ok $(py "L = pvd('$d/$s.pvd'); print(0 if [round(t, 12) for t, f in L] == [0.0, 0.005, 0.01, 0.015, 0.02] and all(os.path.exists('$d/' + f) for t, f in L) else 1)") \
     "$s.pvd lists the 5 frames with their times"
done
ok $(py "import py_compile; py_compile.compile('$d/particles.py', doraise=True); print(0)") "particles.py is valid Python"
s=$(cat "$d/particles.py")
contains "$s" "Glyph(Input=particles, GlyphType='Sphere')" "particles.py: spheres glyphed on the particles"
contains "$s" "glyph.ScaleArray = ['POINTS', 'radius']" "particles.py: scaled by the radius"
contains "$s" "Tube(Input=contacts)" "particles.py: the contact network as tubes"
contains "$s" "'CELLS', 'rn'" "particles.py: coloured by rn"

# 3D: a sphere at rest on a floor: a quaternion, rn = rho 4/3 pi R^3 g
cat > "$OUT/sphere.cfg" <<'EOF'
title = "vtk-rigid: a sphere at rest on a floor";
bodies = (
  { name = "floor"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0, 1.0, 0.0]; },
  { name = "ball"; type = "sphere"; center = [0.0, 0.1, 0.0]; radius = 0.1; density = 1000.0;
    body_force = [0.0, -9.81, 0.0]; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-3; steps = 20; };
contact = { solver = "nscd"; pairs = ( { name = "p"; slave = "ball"; master = "floor"; mu = 0.3; } ); };
output = { vtk = { every = 5; }; };
EOF
"$MOREAU" run "$OUT/sphere.cfg" --out "$OUT/s" --quiet; ok $? "run: a sphere at rest on a floor (3D)"
is "$(py "p, c, a = read('$OUT/s/particles_00004.vtu'); print(p, a['orientation'][0], a['orientation'][1])")" \
   "1 4 (1.0, 0.0, 0.0, 0.0)" "3D particles: the orientation is the quaternion (w, x, y, z)"
ok $(relerr "$(py "p, c, a = read('$OUT/s/contacts_00004.vtu'); print(sum(a['rn'][1]))")" \
            "$("$PY" -c "import math; print(1000 * 4 / 3 * math.pi * 0.1**3 * 9.81)")" 1e-6) "3D: rn of the sphere = rho 4/3 pi R^3 g"
ok $(test ! -e "$OUT/s/polygons.pvd"; echo $?) "3D: no polygons series without polygons or rigid meshes"

# a frame of more contacts than a chunk (MO_VTK_CHUNK = 512, moreau/output.h): the pile of 1000
# disks at 0.3 s (about 2000 candidates, 1500 closed), its last frame read by VTK against contact.csv
p="$OUT/pile"
"$MOREAU" run "$MOREAU_SRCDIR/cases/disk-pile" --out "$p" --quiet --set time.end=0.3 --set output.vtk.every=300
ok $? "run: the 1000-disk pile to 0.3 s, VTK at steps 0 and 300"
ok $(py "import csv
rows = list(csv.DictReader(open('$p/contact.csv')))
n, (pn, cn, a) = len(rows), read('$p/contact_points_00001.vtu')
ok = pn == n == cn > 3 * 512 and a['candidate'][1] == tuple(range(n)) and a['connectivity'][1] == tuple(range(n))
ok = ok and a['offsets'][1] == tuple(range(1, n + 1)) and set(a['types'][1]) == {1}
rel = lambda x, y: abs(x - y) <= 1e-9 * max(abs(x), abs(y)) + 1e-300
ok = ok and all(rel(a['R'][1][2 * k], float(r['RN'])) and rel(a['gap'][1][k], float(r['gap'])) and
                rel(a['U'][1][2 * k + 1], float(r['UT'])) for k, r in enumerate(rows))
print(0 if ok else 1)") "pile: contact_points has contact.csv's rows in order (candidate, cells, R_N, U_T, gap), more than 3 chunks"
ok $(py "import csv
rows = [r for r in csv.DictReader(open('$p/contact.csv')) if r['status'] != 'open' or float(r['RN']) != 0 or float(r['RT']) != 0]
n, (pn, cn, a) = len(rows), read('$p/contacts_00001.vtu')
rel = lambda x, y: abs(x - y) <= 1e-9 * max(abs(x), abs(y)) + 1e-300
ok = cn == n > 2 * 512 and pn == 2 * n and a['connectivity'][1] == tuple(range(2 * n)) and a['offsets'][1] == tuple(range(2, 2 * n + 1, 2))
ok = ok and all(rel(a['rn'][1][k], float(r['RN'])) and rel(a['rt'][1][k], abs(float(r['RT']))) and rel(a['gap'][1][k], float(r['gap']))
                for k, r in enumerate(rows))
print(0 if ok else 1)") "pile: the network has a line per closed row of contact.csv, in order (cells, rn, rt, gap), more than 2 chunks"
done_testing
