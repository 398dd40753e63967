#!/bin/sh
# test_vtk_contact.sh: the contact data of every step for ParaView (contact_points.pvd, planes.pvd)
# and contact_history.csv, read back by VTK itself (tests/vtkread.py: Debian's python3-vtk9) and
# checked field by field against contact_history.csv, contact.csv, history.csv and summary.json
# (tests/vtk_contact_check.py): a 2D mesh against a mesh, a 3D mesh on an inclined plane with
# friction, a 1D bar against a plane, rigid disks and a block detected on a floor.
. "$MOREAU_SRCDIR/tests/tap.sh"
PY=/usr/bin/python3
if ! "$PY" -c "import vtkmodules.vtkIOXML" 2>/dev/null; then
  echo "1..0 # SKIP python3-vtk9 is not installed (the quickstart installs it)"
  exit 0
fi
vcheck() { # vcheck FOLDER LABEL [closed]: each line of vtk_contact_check.py becomes one TAP result
  "$PY" "$MOREAU_SRCDIR/tests/vtk_contact_check.py" "$@" > "$OUT/check" 2>&1 || echo "1	vtk_contact_check.py $2 crashed: $(tail -1 "$OUT/check")" >> "$OUT/check"
  while IFS= read -r line; do
    case "$line" in
      '#'*) echo "$line" ;;
      [01]'	'*) ok "${line%%	*}" "${line#*	}" ;;
      *) echo "# $line" ;;
    esac
  done < "$OUT/check"
}
every='--set output.contact_history={}'

# 2D: the cylinder landing on the stiff wall (a mesh master), frames every 3 steps to 30 us
"$MOREAU" run "$MOREAU_SRCDIR/cases/cylinder-wall" --quiet --out "$OUT/cw" --set time.end=3e-5 \
  --set output.vtk.every=3 $every
ok $? "run: cylinder-wall to 30 us, VTK every 3 steps, contact_history every step"
vcheck "$OUT/cw" "cylinder-wall"
is "$(ls "$OUT/cw"/contact_points_*.vtu | wc -l)" "11" "cylinder-wall: 11 frames of contact points (steps 0, 3, ..., 30)"
is "$("$PY" -c "import sys; sys.path.insert(0, '$MOREAU_SRCDIR/tests'); import vtkread; p, c, a = vtkread.read('$OUT/cw/contact_points_00000.vtu'); print(p, set(vtkread.tuples(a, 'U')), set(a['R'][1]))")" \
   "32 {(-500.0, 0.0)} {0.0}" "cylinder-wall at t = 0: every candidate approaches at U = (-500, 0) m/s, the initial velocity, without reaction"
# the same with the closed candidates only
"$MOREAU" run "$MOREAU_SRCDIR/cases/cylinder-wall" --quiet --out "$OUT/cwc" --set time.end=3e-5 \
  --set output.vtk.every=3 --set output.vtk.contacts=closed $every
ok $? "run: the same, output.vtk.contacts = closed"
vcheck "$OUT/cwc" "cylinder-wall, closed" closed
"$MOREAU" run "$MOREAU_SRCDIR/cases/cylinder-wall" --quiet --out "$OUT/cwn" --set time.end=3e-5 --set output.vtk.contacts=none
ok $(test ! -e "$OUT/cwn/contact_points.pvd" && test -e "$OUT/cwn/fields.pvd"; echo $?) "output.vtk.contacts = none: no contact series, the fields still"

# 3D: a soft H8 block dropped sliding on a plane tilted by 0.1 rad and moving down, mu = 0.3; it
# lands on its lower edge at 5 ms, slides on it and tips off at 11 ms
cat > "$OUT/box3d.cfg" <<'EOC'
title = "a 3D block dropped sliding on a tilted plane";
bodies = (
  { name = "block";
    mesh = { generator = "box"; origin = [-0.05, -0.05, 0.0055]; size = [0.1, 0.1, 0.05]; elements = [2, 2, 1]; };
    material = { E = 1.0e6; nu = 0.3; rho = 1000.0; };
    initial = { velocity = [1.0, 0.2, -0.2]; };
    body_force = [0.0, 0.0, -9.81]; },
  { name = "floor"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0998334166, 0.0, 0.9950041653];
    velocity = [0.0, 0.0, -0.01]; }
);
time = { scheme = "theta"; theta = 1.0; dt = 2.0e-4; steps = 100; };
contact = { solver = "nscd"; pairs = ( { name = "base"; slave = "block"; slave_set = "zmin"; master = "floor"; mu = 0.3; } ); };
output = { vtk = { every = 10; }; contact_history = { }; };
EOC
"$MOREAU" run "$OUT/box3d.cfg" --quiet --out "$OUT/b3"; ok $? "run: a 3D block on a tilted moving plane"
vcheck "$OUT/b3" "3D block"
is "$("$PY" -c "import sys; sys.path.insert(0, '$MOREAU_SRCDIR/tests'); import vtkread; p, c, a = vtkread.read('$OUT/b3/planes_00004.vtu'); print(p, c, a['types'][1])")" \
   "4 1 (9,)" "3D: the plane is one quadrilateral"
# at 8 ms the lower edge slides: Coulomb's law in the points' own R and U
ok $("$PY" -c "import sys, math; sys.path.insert(0, '$MOREAU_SRCDIR/tests'); import vtkread
p, c, a = vtkread.read('$OUT/b3/contact_points_00004.vtu')
R, U, s = vtkread.tuples(a, 'R'), vtkread.tuples(a, 'U'), a['status'][1]
slide = [i for i in range(p) if s[i] == 2]
good = p == 9 and len(R[0]) == 3 and len(slide) == 3 and all(R[i] == (0.0, 0.0, 0.0) for i in range(p) if s[i] == 0)
for i in slide:
    rt, ut = math.hypot(R[i][1], R[i][2]), math.hypot(U[i][1], U[i][2])
    good &= abs(rt - 0.3 * R[i][0]) < 1e-12 * R[i][0] and abs(R[i][1] * ut + rt * U[i][1]) < 1e-9 * rt * ut and abs(R[i][2] * ut + rt * U[i][2]) < 1e-9 * rt * ut
print(0 if good else 1)") "3D at 8 ms: 9 candidates, the 3 of the lower edge sliding with R_t = -mu R_N U_t / |U_t|, the others open and free"

# 1D: the bar released against its obstacle, in contact from t = 1 (stress 1/2)
"$MOREAU" run "$MOREAU_SRCDIR/cases/bar-obstacle" --quiet --out "$OUT/bo" --set time.end=1.5 \
  --set 'output.vtk={every=5;}' $every
ok $? "run: bar-obstacle to t = 1.5"
vcheck "$OUT/bo" "bar-obstacle (1D)"
ok $("$PY" -c "import sys; sys.path.insert(0, '$MOREAU_SRCDIR/tests'); import vtkread
p, c, a = vtkread.read(sorted(__import__('glob').glob('$OUT/bo/contact_points_*.vtu'))[-1])
print(0 if p == 1 and a['R'][0] == 1 and abs(a['R'][1][0] - 0.5) < 0.02 else 1)") "1D: one point, R with one component, the contact force 1/2 of the closed form"

# rigid bodies: two disks and a block resting on a floor (candidates found by the detection)
cat > "$OUT/rest.cfg" <<'EOC'
title = "disks and a block at rest on a floor";
bodies = (
  { name = "floor"; type = "plane"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },
  { name = "d1"; type = "disk"; center = [0.0, 0.1]; radius = 0.1; density = 1000.0; body_force = [0.0, -9.81]; },
  { name = "d2"; type = "disk"; center = [0.5, 0.05]; radius = 0.05; density = 2000.0; body_force = [0.0, -9.81];
    initial = { velocity = [0.3, 0.0]; }; },
  { name = "block"; type = "polygon"; center = [1.0, 0.1]; size = [0.4, 0.2]; density = 500.0;
    body_force = [0.0, -9.81]; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-3; steps = 20; };
contact = {
  solver = "nscd";
  pairs = ( { name = "p1"; slave = "d1"; master = "floor"; mu = 0.3; },
            { name = "p2"; slave = "d2"; master = "floor"; mu = 0.3; },
            { name = "p3"; slave = "block"; master = "floor"; mu = 0.3; } );
};
output = { vtk = { every = 5; }; contact_history = { }; };
EOC
"$MOREAU" run "$OUT/rest.cfg" --quiet --out "$OUT/r"; ok $? "run: disks and a block on a floor"
vcheck "$OUT/r" "rigid bodies"
# the weight each body puts on the floor, from the force vectors of the contact points
ok $("$PY" -c "import sys, math; sys.path.insert(0, '$MOREAU_SRCDIR/tests'); import vtkread
p, c, a = vtkread.read('$OUT/r/contact_points_00004.vtu')
fy = {}
for s, f in zip(a['slave'][1], vtkread.tuples(a, 'force')): fy[s] = fy.get(s, 0) + f[1]
w = {1: 1000 * math.pi * 0.01 * 9.81, 2: 2000 * math.pi * 0.0025 * 9.81, 3: 500 * 0.08 * 9.81}
print(0 if all(abs(fy[b] / w[b] - 1) < 1e-6 for b in w) else 1)") "rigid bodies: the forces on each body sum to its weight"
done_testing
