#!/bin/sh
# test_levelset_damped.sh: levelset's damped level-set loop (doc/theory.md §6.4.3, (T140)-(T142)) on
# a small frictional pile (10 disks, mu = 0.5, 0.2 s): against the undamped loop of BDZ07 Fig. 2
# and against nscd's motion; counts from summary.json, never the clock.
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
done_testing
