#!/bin/sh
# test_compare_verdict.sh: `moreau compare` tells the methods apart (issue 14, items 2, 4, 5):
# chatter verdicts from the contact variables (doc/theory.md (T97)), no duplicate rows for a
# key a back end ignores, step times over repeats (T99), and Richardson's observed orders
# against the finest run where no closed form is used (T98). The checks are in
# tests/compare_check.py.
. "$MOREAU_SRCDIR/tests/tap.sh"
C="$MOREAU_SRCDIR/cases"

# 1. rods-1d to 200 us (the contact from 50 us on): newmark's contact ends bounce while closed
#    (BDZ07 Fig. 4), nscd and levelset hold [v_n] = 0; theta varies, newmark ignores it
"$MOREAU" compare "$C/rods-1d" --solvers nscd,levelset,newmark --set time.end=2e-4 --dt 4e-6,2e-6 \
  --vary time.theta=0.5,1 --repeat 2 --out "$OUT/rods" > "$OUT/rods.out" 2> "$OUT/rods.err"
ran $? "$OUT/rods.err" "compare rods-1d, 3 back ends x 2 steps x theta in {0.5, 1}: exit 0"
contains "$(cat "$OUT/rods.out")" "10 runs (8 stable, 2 chatter, 0 unstable, 0 failed)" "10 runs: 8 stable, 2 chatter"
contains "$(cat "$OUT/rods.out")" "2 grid cells not run" "newmark's theta = 1 cells are not run"
check verdict "$OUT/rods"
check timings "$OUT/rods" 2

# 2. bar-obstacle before the first contact (t < 1: the semi-discrete solution is a linear ODE's,
#    smooth in time), 10 elements: theta = theta_f = 1/2 is of order 2, Newmark (0.3025, 0.6)
#    of order 1 (gamma != 1/2)
"$MOREAU" compare "$C/bar-obstacle" --solvers nscd,newmark --dt 0.01,0.005,0.0025 --set bodies.bar.mesh.elements=10 \
  --set time.end=0.8 --set time.theta=0.5 --set time.theta_f=0.5 --repeat 1 --out "$OUT/rich2" > "$OUT/rich2.out" 2> "$OUT/rich2.err"
ran $? "$OUT/rich2.err" "compare bar-obstacle to t = 0.8, theta = 1/2, h = 0.01, 0.005, 0.0025: exit 0"
check orders "$OUT/rich2" nscd:2,newmark:1
# 3. theta = theta_f = 1 (implicit Euler, order 1) with --reference: the third step is the
#    reference run; its steps must resolve the mesh's highest frequency (omega h < 0.02)
"$MOREAU" compare "$C/bar-obstacle" --solvers nscd --dt 4e-4,2e-4 --reference 1e-4 --set bodies.bar.mesh.elements=10 \
  --set time.end=0.8 --set time.theta=1 --set time.theta_f=1 --repeat 1 --metric ref.end.ux.l2_rel \
  --out "$OUT/rich1" > "$OUT/rich1.out" 2> "$OUT/rich1.err"
ran $? "$OUT/rich1.err" "compare bar-obstacle, theta = 1, --dt 4e-4,2e-4 --reference 1e-4: exit 0"
check orders "$OUT/rich1" nscd:1
check reference "$OUT/rich1" 0.0001

# bad command lines
"$MOREAU" compare "$C/bar-obstacle" --repeat 0 --out "$OUT/bad" > /dev/null 2> "$OUT/bad.err"
is "$?" "2" "--repeat 0: exit status 2"
contains "$(cat "$OUT/bad.err")" "--repeat N: 1 to 20 runs per cell" "and why"
"$MOREAU" compare "$C/bar-obstacle" --dt 0.01 --reference 0.02 --out "$OUT/bad" > /dev/null 2> "$OUT/bad.err"
is "$?" "2" "--reference larger than a step of --dt: exit status 2"
contains "$(cat "$OUT/bad.err")" "--reference 0.02 is not smaller than the step 0.01" "and why"
done_testing
