#!/bin/sh
# test_granular_progress.sh: a granular run on a terminal draws its progress line (issue 13: steps
# per second, the contacts and the sweeps of the last solve), and none when its standard error is
# not a terminal. The terminal is a pseudo-terminal from util-linux's script(1).
. "$MOREAU_SRCDIR/tests/tap.sh"

cat > "$OUT/pile.cfg" <<'EOF'
title = "a small pile";
bodies = (
  { name = "floor"; type = "plane"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },
  { name = "left"; type = "plane"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },
  { name = "right"; type = "plane"; point = [0.132, 0.0]; normal = [-1.0, 0.0]; },
  { name = "grains"; type = "disk"; density = 2600.0; body_force = [0.0, -9.81];
    pack = { count = 60; radius = 0.005; dispersion = 0.2; box = [0.0, 0.132, 0.0, 2.0]; seed = 3; }; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-3; end = 0.3; };
contact = {
  solver = "nscd"; on_failure = "continue";
  nscd = { stop = "sweeps"; max_sweeps = 8; };
  pairs = ( { name = "grains"; master = "grains"; slave = "grains"; mu = 0.5; },
            { name = "floor"; master = "floor"; slave = "grains"; mu = 0.5; },
            { name = "left"; master = "left"; slave = "grains"; mu = 0.5; },
            { name = "right"; master = "right"; slave = "grains"; mu = 0.5; } );
};
EOF

if ! command -v script > /dev/null 2>&1; then
  echo "ok 1 # SKIP no script(1) (util-linux) to give the run a terminal"
  echo "1..1"
  exit 0
fi
# script -q -e -c CMD FILE: the command on a pseudo-terminal, its output (stdout and stderr) in FILE
script -q -e -c "\"$MOREAU\" run \"$OUT/pile.cfg\" --out \"$OUT/tty\" > /dev/null" "$OUT/typescript" > /dev/null 2>&1
ok $? "a run with its standard error on a terminal"
last=$(tr '\r' '\n' < "$OUT/typescript" | grep 'steps/s' | tail -1)
contains "$last" "step 300/300" "the final progress line counts the steps: $last"
case "$last" in
  *" steps/s"*) r=0 ;;
  *) r=1 ;;
esac
rate=$(echo "$last" | sed -n 's/.* \([0-9][0-9]*\) steps\/s.*/\1/p')
[ "$r" -eq 0 ] && [ -n "$rate" ] && [ "$rate" -gt 0 ]
ok $? "it gives the steps per second ($rate)"
closed=$(/usr/bin/python3 -c "import csv; r = list(csv.DictReader(open('$OUT/tty/history.csv'))); print(int(float(r[-1]['contact.closed'])))")
contains "$last" " $closed contacts" "it gives the contacts of the last solve ($closed, history.csv's contact.closed)"
contains "$last" " 8 sweeps" "it gives the sweeps of the last solve (8, nscd held to 8)"
n=$(tr '\r' '\n' < "$OUT/typescript" | grep -c 'steps/s')
[ "$n" -ge 1 ]
ok $? "the line is drawn over itself ($n drawings in one run)"

"$MOREAU" run "$OUT/pile.cfg" --out "$OUT/pipe" 2> "$OUT/err" > /dev/null
ok $? "the same run with its standard error in a file"
[ ! -s "$OUT/err" ] || ! grep -q 'steps/s' "$OUT/err"
ok $? "no progress line when the standard error is not a terminal"
done_testing
