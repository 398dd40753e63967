#!/bin/sh
# test_levelset_damped.sh: levelset's damped level-set loop (doc/theory.md §6.4.3, (T140)-(T143)) on
# a small frictional pile (10 disks, mu = 0.5, 0.2 s), a 3D box sliding on a plane and a small
# sphere deposit: against the undamped loop of BDZ07 Fig. 2 and against nscd's motion; counts from
# summary.json, never the clock.
. "$MOREAU_SRCDIR/tests/tap.sh"
cat >"$OUT/pile10.cfg" <<'CFG'
title = "ten disks poured into a narrow box, mu = 0.5";
bodies = (
  { name = "floor"; type = "plane"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },
  { name = "left"; type = "plane"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },
  { name = "right"; type = "plane"; point = [0.03, 0.0]; normal = [-1.0, 0.0]; },
  { name = "grains"; type = "disk"; density = 2600.0; body_force = [0.0, -9.81];
    pack = { count = 10; radius = 0.005; dispersion = 0.2; box = [0.0, 0.03, 0.0, 2.0]; jitter = 0.5; seed = 1; }; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-3; end = 0.2; };
contact = {
  solver = "nscd";
  on_failure = "continue";
  nscd = { tol = 1.0e-4; stop = "quad"; max_sweeps = 1000; };
  pairs = ( { name = "grains"; master = "grains"; slave = "grains"; mu = 0.5; },
            { name = "floor"; master = "floor"; slave = "grains"; mu = 0.5; },
            { name = "left"; master = "left"; slave = "grains"; mu = 0.5; },
            { name = "right"; master = "right"; slave = "grains"; mu = 0.5; } );
};
output = { every = 10; };
CFG

run() { # run NAME ARGS...: the run's outputs in $OUT/NAME
  name=$1
  shift
  "$MOREAU" run "$OUT/pile10.cfg" --out "$OUT/$name" --quiet "$@" 2>"$OUT/$name.err"
  ok $? "$name runs $(head -c 300 "$OUT/$name.err")"
}
sum() { json "$OUT/$1/summary.json" "d['contact'].get('$2', -1)"; }
# the largest distance between the grains' final centres of two runs, in radii
moved() {
  /usr/bin/python3 - "$OUT/$1/bodies.csv" "$OUT/$2/bodies.csv" <<'PY'
import csv, sys
a = {r['name']: r for r in csv.DictReader(open(sys.argv[1]))}
b = {r['name']: r for r in csv.DictReader(open(sys.argv[2]))}
print("%.3e" % max(((float(a[k]['x']) - float(b[k]['x'])) ** 2 + (float(a[k]['y']) - float(b[k]['y'])) ** 2) ** 0.5
                   / float(b[k]['radius']) for k in b if b[k]['group'] == 'grains'))
PY
}
below() { /usr/bin/python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) <= float(sys.argv[2]) else 1)" "$1" "$2"; echo $?; }

run nscd --solver nscd
run none --solver levelset --set 'contact.levelset.globalization="none"'
run damped --solver levelset --set 'contact.levelset.globalization="line_search"'
steps=$(sum damped steps_with_contact)
fn=$(sum none failed_solves) fd=$(sum damped failed_solves)
# measured: the undamped loop fails 5 of 182 contact steps (status cycling, levelset_max) and ends
# 1.16 radii from nscd's pile; the damped loop converges at every step (236 Newton solves, at most
# 9 in a step) and ends within 0.01 radius of it
ok $([ "$fn" -ge 3 ] && echo 0 || echo 1) "the undamped loop fails on this pile ($fn of $steps contact steps; 5 measured)"
ok $([ "$fd" -eq 0 ] && echo 0 || echo 1) "the damped loop converges at every one of the $steps contact steps ($fd failed)"
w=$(moved damped nscd)
ok $(below "$w" 0.03) "the damped loop's final pile = nscd's to $w radius (<= 0.03)"
w=$(moved none nscd)
ok $(below 0.3 "$w") "the undamped loop's final pile is $w radii from nscd's (>= 0.3: it went its own way on its failed steps)"
it=$(sum damped iterations_total) im=$(sum damped iterations_max)
ok $([ "$it" -le 300 ] && [ "$im" -le 20 ] && echo 0 || echo 1) "the damped loop: $it Newton solves over the run (<= 300; 236 measured), at most $im in a step (<= 20)"

# 3D: the coupled threshold with the sliding directions frozen at the iterate (T143). A box sliding
# on a plane (the scene of tests/test_levelset_reduced.sh, mu = 0.3, 200 steps)
run3() { # run3 NAME CFG ARGS... (CFG: a path)
  name=$1 cfg=$2
  shift 2
  "$MOREAU" run "$cfg" --out "$OUT/$name" --quiet "$@" 2>"$OUT/$name.err"
  ok $? "$name runs $(head -c 300 "$OUT/$name.err")"
}
run3 box-damped "$MOREAU_SRCDIR/tests/scenes/slide3d.cfg" --set 'contact.levelset.globalization="line_search"'
run3 box-nscd "$MOREAU_SRCDIR/tests/scenes/slide3d.cfg" --solver nscd
# the largest difference of the base's probes between two runs, over the second's largest magnitude
hdiff() {
  /usr/bin/python3 - "$OUT/$1/history.csv" "$OUT/$2/history.csv" <<'PY'
import csv, sys
a = list(csv.DictReader(open(sys.argv[1]))); b = list(csv.DictReader(open(sys.argv[2])))
assert len(a) == len(b)
worst = 0.0
for key in ("base.ux", "base.uy", "base.vx", "base.vy", "base.cz", "base.cx", "base.cy"):
    scale = max(abs(float(r[key])) for r in b) or 1.0
    worst = max(worst, max(abs(float(x[key]) - float(y[key])) / scale for x, y in zip(a, b)))
print("%.3e" % worst)
PY
}
run3 box-none "$MOREAU_SRCDIR/tests/scenes/slide3d.cfg" --set 'contact.levelset.globalization="none"'
w=$(hdiff box-damped box-none)
ok $(below "$w" 1e-9) "3D sliding box: the damped loop's histories = the undamped threshold loop's to $w (<= 1e-9)"
w=$(hdiff box-damped box-nscd)
ok $(below "$w" 1e-6) "3D sliding box: the damped loop's histories = nscd's to $w (<= 1e-6; nscd's own tolerance: the undamped loop is as far)"
ok $([ "$(sum box-damped failed_solves)" -eq 0 ] && echo 0 || echo 1) "3D sliding box, damped loop: no failed solve"
it=$(sum box-damped iterations_total)
ok $([ "$it" -le 130 ] && echo 0 || echo 1) "3D sliding box, damped loop: $it Newton solves over 200 steps (<= 130; 116 measured; the undamped threshold loop: 249)"

# a deposit of 8 spheres (mu = 0.5, 0.2 s): measured, the undamped threshold loop fails 22 of 182
# contact steps, the damped loop 15 (doc/theory.md §6.4.3: its traps)
cat >"$OUT/spheres8.cfg" <<'CFG'
bodies = (
  { name = "floor"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0, 1.0, 0.0]; },
  { name = "x0"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [1.0, 0.0, 0.0]; },
  { name = "x1"; type = "plane"; point = [0.025, 0.0, 0.0]; normal = [-1.0, 0.0, 0.0]; },
  { name = "z0"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; },
  { name = "z1"; type = "plane"; point = [0.0, 0.0, 0.025]; normal = [0.0, 0.0, -1.0]; },
  { name = "grains"; type = "sphere"; density = 2600.0; body_force = [0.0, -9.81, 0.0];
    pack = { count = 8; radius = 0.005; dispersion = 0.2; box = [0.0, 0.025, 0.0, 2.0, 0.0, 0.025]; jitter = 0.5; seed = 1; }; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-3; end = 0.2; };
contact = {
  solver = "levelset";
  on_failure = "continue";
  pairs = ( { name = "grains"; master = "grains"; slave = "grains"; mu = 0.5; },
            { name = "floor"; master = "floor"; slave = "grains"; mu = 0.5; },
            { name = "x0"; master = "x0"; slave = "grains"; mu = 0.5; },
            { name = "x1"; master = "x1"; slave = "grains"; mu = 0.5; },
            { name = "z0"; master = "z0"; slave = "grains"; mu = 0.5; },
            { name = "z1"; master = "z1"; slave = "grains"; mu = 0.5; } );
};
output = { every = 10; };
CFG
run3 sph-none "$OUT/spheres8.cfg"
run3 sph-damped "$OUT/spheres8.cfg" --set 'contact.levelset.globalization="line_search"'
fn=$(sum sph-none failed_solves) fd=$(sum sph-damped failed_solves)
ok $([ "$fd" -lt "$fn" ] && echo 0 || echo 1) "8 spheres: the damped loop fails fewer contact steps ($fd) than the undamped threshold loop ($fn) (15 and 22 measured)"
done_testing
