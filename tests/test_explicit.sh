#!/bin/sh
# test_explicit.sh: the explicit scheme and theta < 1/2 from the command line: the critical time
# step and the warnings in the log and summary.json (doc/theory.md (T101)-(T102)), a blow-up
# reported (not a silent "complete"), and the explicit scheme with contact on bar-obstacle.
. "$MOREAU_SRCDIR/tests/tap.sh"

W="$MOREAU_SRCDIR/cases/wave-bar"
t=$("$MOREAU" run "$W" --set 'time.scheme="explicit"' --set time.end=2 --out "$OUT/x1" 2>&1); ok $? "wave-bar, explicit at dt = dt_crit (Courant 1) runs"
is "$(json "$OUT/x1/summary.json" "d['time']['scheme']")" "explicit" "summary.json: scheme explicit"
is "$(json "$OUT/x1/summary.json" "'%.6g' % d['time']['dt_crit']")" "0.005" "summary.json: dt_crit = L / (n c) = 0.005"
ok $(json "$OUT/x1/summary.json" "0 if d['metrics']['tip.ux']['l2_rel'] < 1e-10 else 1") \
  "central differences at Courant 1 are exact at the nodes (tip.ux L2 $(json "$OUT/x1/summary.json" "d['metrics']['tip.ux']['l2_rel']"))"
t=$("$MOREAU" run "$W" --set 'time.scheme="explicit"' --set time.dt=0.0055 --out "$OUT/x2" 2>&1); is $? 1 "at 1.1 dt_crit the run fails"
contains "$t" "exceeds the critical time step dt_crit = 0.005" "the log warns that dt > dt_crit"
contains "$t" "warning: blow-up at step" "and reports the blow-up when the energy passes 1e12 times its start"
contains "$t" "is not finite" "the first non-finite value stops the run (doc/theory.md (T104))"
is "$(json "$OUT/x2/summary.json" "d['status']")" "incomplete" "summary.json: incomplete"
contains "$(json "$OUT/x2/summary.json" "d['reason']")" "not finite" "summary.json: the reason names the non-finite unknowns"
contains "$(json "$OUT/x2/summary.json" "d['warnings'][0]")" "dt / dt_crit = 1.1" "summary.json: the warning on dt"
contains "$(json "$OUT/x2/summary.json" "d['warnings'][1]")" "blow-up at step" "summary.json: the warning on the blow-up"
t=$("$MOREAU" run "$W" --set time.theta=0.3 --set time.theta_f=1.0 --set time.end=0.1 --out "$OUT/x3" 2>&1); ok $? "theta = 0.3 is accepted"
contains "$t" "only conditionally stable, h omega_max <= 3.162" "the log warns: only conditionally stable (2 / sqrt(1 - 2 theta))"
contains "$(json "$OUT/x3/summary.json" "d['warnings'][0]")" "only conditionally stable" "summary.json: the warning"
is "$(json "$OUT/x3/summary.json" "d['time']['stability']")" "conditional" "summary.json: time.stability conditional"
t=$("$MOREAU" run "$W" --set time.theta=0.3 --set time.end=0.1 --out "$OUT/x4" 2>&1)
contains "$t" "unstable at every time step" "theta = theta_f = 0.3: unstable at every step, says the log"

# a bar at rest at t = 0 under its weight (E(0) = 0: no energy ratio): the growth is taken over the
# work given (doc/theory.md (T49a)); above dt_crit the blow-up is said and compare classes the run
# unstable (before, max_growth read 0 and the run "failed" on its NaN)
cat > "$OUT/weight.cfg" <<'CFG'
title = "bar from rest under its weight";
bodies = ( { name = "bar"; mesh = { generator = "bar"; length = 1.0; elements = 200; };
  material = { E = 1.0; rho = 1.0; area = 1.0; }; fix = ( { set = "left"; dofs = ["x"]; } ); body_force = [1.0]; } );
time = { scheme = "explicit"; dt = 0.005; end = 4.0; };
CFG
"$MOREAU" run "$OUT/weight.cfg" --out "$OUT/w1" --quiet; ok $? "bar from rest under its weight, explicit at dt_crit: runs"
ok $(json "$OUT/w1/summary.json" "0 if 0 <= d['energy']['max_growth'] < 1e-12 and d['energy']['initial'] == 0 and 'warnings' not in d else 1") \
  "no growth over the work given (max growth $(json "$OUT/w1/summary.json" "'%.2g' % d['energy']['max_growth']")), no warning"
t=$("$MOREAU" run "$OUT/weight.cfg" --set time.dt=0.0055 --out "$OUT/w2" 2>&1); is $? 1 "at 1.1 dt_crit it fails"
contains "$t" "were at rest at t = 0, and the energy they hold beyond the work given them reached" "the log says the blow-up"
ok $(json "$OUT/w2/summary.json" "0 if d['energy']['max_growth'] > 1e3 and 'blow-up at step' in d['warnings'][1] else 1") \
  "summary.json: max growth $(json "$OUT/w2/summary.json" "'%.2g' % d['energy']['max_growth']") and the warning"
"$MOREAU" compare "$OUT/weight.cfg" --vary time.dt=0.005,0.0055 --out "$OUT/cmpw" --quiet >/dev/null 2>&1
is "$(awk -F, 'NR > 1 { printf "%s:%s ", $3, $4 }' "$OUT/cmpw/stability.csv")" "0.005:stable 0.0055:unstable " \
  "compare: stable at dt_crit, unstable above it"

# the explicit map of cylinder-wall (Q4, contact, dt_crit = 9.87e-9 s): a run that overflows to an
# infinite energy before its NaN is classed unstable (max_growth kept finite in summary.json);
# below dt_crit the run is bounded but its forward-increment contact chatters (|U_n| while closed
# up to 83 m/s of the 500 m/s impact, doc/theory.md §1.7), which compare's verdict (T97) says
"$MOREAU" compare "$MOREAU_SRCDIR/cases/cylinder-wall" --solvers nscd --set time.scheme=explicit --set time.end=2.5e-5 \
  --set output.vtk.every=1000000 --vary time.dt=9e-9,2e-8 --out "$OUT/cmpc" --quiet >/dev/null 2>&1
is "$(awk -F, 'NR > 1 { printf "%s:%s ", $3, $4 }' "$OUT/cmpc/stability.csv")" "9e-9:chatter 2e-8:unstable " \
  "cylinder-wall explicit map: bounded (chatter) below dt_crit, unstable above"

# Moreau-Jean (theta_f = theta) at theta = 0.3: theta + theta_f < 1, unstable at every dt (T101)
"$MOREAU" compare "$W" --set time.end=2 --vary time.theta=0.3,0.5,1.0 --vary time.dt=0.0025,0.005,0.01 \
  --out "$OUT/cmpm" --quiet >/dev/null 2>&1
is "$(awk -F, 'NR > 1 && $5 != "stable" { printf "%s:%s ", $3, $4 }' "$OUT/cmpm/stability.csv")" \
  "0.3:0.0025 0.3:0.005 0.3:0.01 " "theta = theta_f map: every theta = 0.3 cell unstable, no other"

# plate-vibration (Q4): the guaranteed step dt_bound (T103) lies below the CFL estimate and runs stable
P="$MOREAU_SRCDIR/cases/plate-vibration"
"$MOREAU" run "$P" --set time.scheme=explicit --set time.end=5e-5 --out "$OUT/p0" --quiet
db=$(json "$OUT/p0/summary.json" "'%.6g' % d['time']['dt_bound']")
ok $(json "$OUT/p0/summary.json" "0 if 0 < d['time']['dt_bound'] < d['time']['dt_crit'] else 1") "plate: dt_bound $db < dt_crit"
"$MOREAU" run "$P" --set time.scheme=explicit --set time.dt="$db" --set time.end=0.01 --set output.vtk.every=100000 --out "$OUT/p1" --quiet
ok $? "plate, explicit at dt_bound: runs"
ok $(json "$OUT/p1/summary.json" "0 if d['energy']['max_growth'] < 1e-3 else 1") "and stays bounded (max growth $(json "$OUT/p1/summary.json" "'%.2g' % d['energy']['max_growth']"))"

# contact: bar-obstacle (Doyen-Ern-Piperno 1) at dt = dt_crit / 2: the end follows the closed form,
# the energy does not grow
B="$MOREAU_SRCDIR/cases/bar-obstacle"
for sig in position velocity; do
  "$MOREAU" run "$B" --set 'time.scheme="explicit"' --set time.dt=0.005 --set "contact.signorini=\"$sig\"" --out "$OUT/b$sig" --quiet
  ok $? "bar-obstacle, explicit, signorini $sig runs"
  ok $(json "$OUT/b$sig/summary.json" "0 if d['metrics']['end.ux']['l2_rel'] < 0.04 else 1") \
    "end displacement against the closed form: L2 $(json "$OUT/b$sig/summary.json" "'%.3g' % d['metrics']['end.ux']['l2_rel']") < 4 %"
  ok $(json "$OUT/b$sig/summary.json" "0 if d['energy']['max_growth'] < 1e-3 and 0.95 < d['energy']['ratio'] <= 1 else 1") \
    "energy does not grow (max growth $(json "$OUT/b$sig/summary.json" "'%.2g' % d['energy']['max_growth']"), final ratio $(json "$OUT/b$sig/summary.json" "'%.4f' % d['energy']['ratio']"))"
done
# the end leaves the obstacle with the closed form's velocity +1/2 (t = 2.4, between contacts)
v=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "end.vx") c = i } $1 == "2.4" { print $c }' "$OUT/bposition/history.csv")
ok $(/usr/bin/python3 -c "import sys; sys.exit(0 if abs(float(sys.argv[1]) - 0.5) < 0.05 else 1)" "$v"; echo $?) "end velocity after the impact $v (closed form 0.5)"

# rods-1d: two elastic rods, node-on-node contact between deformable bodies, at 0.5 dt_crit
"$MOREAU" run "$MOREAU_SRCDIR/cases/rods-1d" --set time.scheme=explicit --set time.dt=1e-7 --out "$OUT/r1" --quiet
ok $? "rods-1d, explicit at dt = 1e-7 (dt_crit = 1.97e-7) runs"
ok $(json "$OUT/r1/summary.json" "0 if abs(d['metrics']['contact']['release_time'] / d['metrics']['contact']['release_time_exact'] - 1) < 2e-3 else 1") \
  "release time $(json "$OUT/r1/summary.json" "d['metrics']['contact']['release_time']") (closed form $(json "$OUT/r1/summary.json" "'%.6g' % d['metrics']['contact']['release_time_exact']"))"
ok $(json "$OUT/r1/summary.json" "0 if d['metrics']['cend.ux']['l2_rel'] < 0.01 and d['metrics']['cend.pn']['l2_rel'] < 0.05 else 1") \
  "contact end displacement and pressure against the closed form (L2 $(json "$OUT/r1/summary.json" "'%.2g, %.2g' % (d['metrics']['cend.ux']['l2_rel'], d['metrics']['cend.pn']['l2_rel'])"))"
ok $(json "$OUT/r1/summary.json" "0 if d['energy']['max_growth'] < 1e-6 and d['energy']['ratio'] > 0.999 else 1") \
  "energy does not grow (final ratio $(json "$OUT/r1/summary.json" "'%.5f' % d['energy']['ratio']"))"

# stability maps that can fail: the explicit scheme over dt across dt_crit = 0.005 (unstable cells
# exactly above it, the line on the map), and theta in {0.3, 0.5, 1} at theta_f = 1 over dt across
# the theta = 0.3 limit 2 / (omega_max sqrt(0.4)) = 0.00456 (omega_max = 2 sqrt(3) 200 c / L with the
# consistent mass of wave-bar, (T101))
"$MOREAU" compare "$W" --set 'time.scheme="explicit"' --set time.end=1 --vary time.dt=0.004,0.0045,0.005,0.0055,0.006 \
  --out "$OUT/cmpx" --quiet >/dev/null 2>&1
is "$(awk -F, 'NR > 1 { printf "%s:%s ", $3, $4 }' "$OUT/cmpx/stability.csv")" \
  "0.004:stable 0.0045:stable 0.005:stable 0.0055:unstable 0.006:unstable " "explicit map: unstable exactly above dt_crit"
contains "$(cat "$OUT/cmpx/plots/stability-case.gp")" "set arrow from 0.005, graph 0 to 0.005, graph 1 nohead" "the map draws dt_crit"
"$MOREAU" compare "$W" --set time.end=2 --set time.theta_f=1.0 --vary time.theta=0.3,0.5,1.0 --vary time.dt=0.004,0.0045,0.0047,0.005 \
  --out "$OUT/cmpt" --quiet >/dev/null 2>&1
is "$(awk -F, 'NR > 1 && $5 != "stable" { printf "%s:%s:%s ", $3, $4, $5 }' "$OUT/cmpt/stability.csv")" \
  "0.3:0.0047:unstable 0.3:0.005:unstable " "theta map: unstable cells only at theta = 0.3 above its limit"
done_testing
