#!/bin/sh
# test_levelset_reuse.sh: levelset keeps the factors of its Newton matrix while the frozen status
# leaves it unchanged (doc/theory.md (T86); on the reduced path, the factor of W_XX, (T131)) and
# solves an open step without one (T87); counted in summary.json (contact.factorizations,
# contact.factor_reuses), never by the clock. The answers are checked against nscd's (another back
# end on the same scene). tests/test_levelset_reduced.sh compares the paths.
. "$MOREAU_SRCDIR/tests/tap.sh"

# 1. a block resting under its weight on a frictionless plane: the 21 bottom nodes stay closed,
#    one status for the whole run, so (almost) every Newton solve reuses the first factors
cat > "$OUT/rest.cfg" <<'CFG'
title = "resting block: a 20 x 10 Q4 block on a frictionless plane under its weight";
bodies = (
  { name = "block";
    mesh = { generator = "rectangle"; origin = [-0.1, 0.0]; size = [0.2, 0.1]; elements = [20, 10]; };
    material = { E = 7.0e10; nu = 0.3; rho = 2700.0; hypothesis = "plane_strain"; };
    body_force = [0.0, -9.81]; },
  { name = "floor"; type = "plane"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-5; end = 2.0e-3; };
contact = { solver = "levelset"; pairs = ( { name = "base"; slave = "block"; slave_set = "bottom"; master = "floor"; mu = 0.0; } ); };
output = { every = 10; probes = ( { name = "base"; set = "bottom"; quantities = ["uy", "cy"]; } ); };
CFG
for s in levelset nscd; do
  "$MOREAU" run "$OUT/rest.cfg" --solver $s --out "$OUT/rest-$s" --quiet 2>"$OUT/err"
  ok $? "resting block runs with $s $(head -c 200 "$OUT/err")"
done
S=$OUT/rest-levelset/summary.json
is "$(json "$S" "d['contact']['steps_with_contact']")" 200 "resting block: 200 steps with contact"
is "$(json "$S" "d['contact']['last_open']")" 0 "resting block: the 21 candidates closed at the end"
nf=$(json "$S" "d['contact'].get('factorizations', -1)")
nr=$(json "$S" "d['contact'].get('factor_reuses', -1)")
it=$(json "$S" "d['contact']['iterations_total']")
ok $(test "$nf" -ge 1 -a "$nf" -le 5; echo $?) "resting block: $nf factorizations over 200 steps (at most 5: the status settles, then one matrix)"
ok $(test "$nr" -ge 195; echo $?) "resting block: $nr Newton solves on kept factors (>= 195)"
ok $(test $((nf + nr)) -eq "$it"; echo $?) "resting block: factorizations + reuses = Newton iterations ($nf + $nr = $it)"
# the same answer as nscd's: the base's vertical reaction at every output (the nodes do not move: u_y = 0 to round-off)
/usr/bin/python3 - "$OUT/rest-levelset/history.csv" "$OUT/rest-nscd/history.csv" > "$OUT/cmp" <<'PY'
import csv, sys
a = list(csv.DictReader(open(sys.argv[1]))); b = list(csv.DictReader(open(sys.argv[2])))
assert len(a) == len(b), (len(a), len(b))
worst = 0.0
for key in ("base.cy",):
    scale = max(abs(float(r[key])) for r in b) or 1.0
    worst = max(worst, max(abs(float(x[key]) - float(y[key])) / scale for x, y in zip(a, b)))
print("%.3e" % worst)
PY
w=$(cat "$OUT/cmp")
ok $(/usr/bin/python3 -c "import sys; sys.exit(0 if float('$w') < 1e-6 else 1)"; echo $?) "resting block: levelset's base reaction is nscd's at every output to $w (< 1e-6)"

# 2. the block dropped sliding (cases/block-drop): most of the 2000 steps are open (no
#    factorization: the zero solution), and the landing's statuses repeat over Newton iterations
"$MOREAU" run "$MOREAU_SRCDIR/cases/block-drop" --solver levelset --out "$OUT/drop" --quiet 2>"$OUT/err"
ok $? "block-drop runs with levelset $(head -c 200 "$OUT/err")"
S=$OUT/drop/summary.json
nf=$(json "$S" "d['contact'].get('factorizations', -1)")
it=$(json "$S" "d['contact']['iterations_total']")
ok $(test "$nf" -ge 1 -a "$nf" -le 200; echo $?) "block-drop: $nf factorizations for $it Newton iterations over 2000 steps (at most 200)"
is "$(json "$S" "d['contact']['failed_solves']")" 0 "block-drop: no failed solve"
done_testing
