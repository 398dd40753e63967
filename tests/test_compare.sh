#!/bin/sh
# test_compare.sh: `moreau compare` at small size (issue 6): compare.csv against the runs'
# summaries, report.md and the figures (rendered when gnuplot is present); a stability grid
# on cylinder-wall with settings that must fail (one nscd sweep) and must be unstable (Newmark
# beta = 0.1 far beyond its stability limit); runs left with unconverged reactions, which
# sink; a run that blows up until a NaN stops it. The checks are in tests/compare_check.py.
. "$MOREAU_SRCDIR/tests/tap.sh"
C="$MOREAU_SRCDIR/cases"

# 1. three back ends, two steps, bar-obstacle on 25 elements over one period
"$MOREAU" compare "$C/bar-obstacle" --solvers nscd,levelset,newmark --dt 0.04,0.02 \
  --set bodies.bar.mesh.elements=25 --set time.end=3 --out "$OUT/cmp" > "$OUT/cmp.out" 2> "$OUT/cmp.err"
ran $? "$OUT/cmp.err" "compare bar-obstacle, 3 back ends x 2 steps: exit 0"
contains "$(cat "$OUT/cmp.out")" "6 runs" "compare prints the number of runs"
check table "$OUT/cmp" nscd,levelset,newmark 0.04,0.02
if command -v gnuplot > /dev/null 2>&1; then
  figures=$(sed -n 's/.*(\([0-9]*\) figures, \([0-9]*\) rendered).*/\1 \2/p' "$OUT/cmp.out")
  set -- $figures
  ok $(test -n "$1" && test "$1" = "$2"; echo $?) "gnuplot present: every figure rendered ($figures)"
  check plots "$OUT/cmp" nscd,levelset,newmark 1
else
  echo "ok $((tap_n + 1)) - # SKIP gnuplot not installed: figures scripted, not rendered"; tap_n=$((tap_n + 1))
  check plots "$OUT/cmp" nscd,levelset,newmark 0
fi
check finite "$OUT/cmp"

# 2. a stability grid: cylinder-wall at CI size, 2 x 2 options for each of the 3 back ends
"$MOREAU" compare "$C/cylinder-wall" --solvers nscd,levelset,newmark \
  --set time.end=4e-5 --set output.vtk.every=100000 \
  --vary contact.nscd.max_sweeps=1,1000 --vary contact.newmark.beta=0.4,0.1 --out "$OUT/grid" > "$OUT/grid.out" 2> "$OUT/grid.err"
ran $? "$OUT/grid.err" "compare cylinder-wall over a 2 x 2 grid: exit 0 although runs fail"
contains "$(cat "$OUT/grid.out")" "5 runs (2 stable, 1 chatter, 1 unstable, 1 failed)" "the grid's counts: 5 runs"
contains "$(cat "$OUT/grid.out")" "7 grid cells not run" "and 7 cells marked, not run (a back end ignores the key)"
check grid "$OUT/grid"
check finite "$OUT/grid"

# 3. penetration: nscd limited to one sweep and told to go on (unconverged reactions let the
#    cylinder sink), theta = 1 and 1/2 at velocity level, against converged runs
"$MOREAU" compare "$C/cylinder-wall" --solvers nscd --set time.end=4e-5 --set output.vtk.every=100000 \
  --set contact.on_failure=continue --vary contact.nscd.max_sweeps=1,1000 --vary time.theta=1,0.5 \
  --out "$OUT/pen" > "$OUT/pen.out" 2> "$OUT/pen.err"
ran $? "$OUT/pen.err" "compare cylinder-wall with unconverged solves kept: exit 0"
check penetration "$OUT/pen"
check finite "$OUT/pen"

# 4. Newmark beta = 0.1 on cylinder-wall for 200 us: the energy grows by 1e296 and the contact
#    Newton meets a NaN at step 170
"$MOREAU" compare "$C/cylinder-wall" --solvers newmark --set contact.newmark.beta=0.1 \
  --set time.end=2e-4 --set output.vtk.every=100000 --dt 1e-6 --out "$OUT/blow" > "$OUT/blow.out" 2> "$OUT/blow.err"
ran $? "$OUT/blow.err" "compare with a run that blows up: exit 0"
check blowup "$OUT/blow"
check finite "$OUT/blow"

# a case that does not load stops the comparison with its error and a non-zero exit, after
# writing the row that says why
"$MOREAU" compare "$OUT/no-such-case" --solvers nscd,levelset --out "$OUT/noload" > "$OUT/noload.out" 2> "$OUT/noload.err"
is "$?" "2" "compare of a case that does not load: exit status 2"
contains "$(cat "$OUT/noload.err")" "moreau compare: $OUT/no-such-case: no such case file or folder" "and the reason on standard error"
is "$(awk -F, 'NR > 1' "$OUT/noload/compare.csv" | wc -l)" "1" "it stopped after the first run (one row in compare.csv)"
done_testing
