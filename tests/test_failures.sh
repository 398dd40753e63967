#!/bin/sh
# test_failures.sh: failure semantics: an interrupt, an injected NaN and a forced
# non-convergence each end the run with the documented exit status, a diagnosis, and outputs
# that are complete up to the last good step and marked incomplete.
. "$MOREAU_SRCDIR/tests/tap.sh"
W="$MOREAU_SRCDIR/cases/wave-bar"

csv_complete() { # every row has as many fields as the header
  awk -F, 'NR == 1 { n = NF } NF != n { bad = 1 } END { exit bad }' "$1"
}

# SIGINT during a long run
"$MOREAU" run "$W" --out "$OUT/int" --quiet --set time.end=1.0e6 2> "$OUT/int.err" &
pid=$!
i=0
while [ ! -s "$OUT/int/history.csv" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
sleep 0.5
kill -INT $pid
wait $pid
is "$?" "1" "SIGINT: exit status 1"
ok $(csv_complete "$OUT/int/history.csv"; echo $?) "SIGINT: history.csv holds complete rows only ($(wc -l < "$OUT/int/history.csv") lines)"
is "$(json "$OUT/int/summary.json" "d['status']")" "incomplete" "SIGINT: summary.json says incomplete"
contains "$(json "$OUT/int/summary.json" "d['reason']")" "interrupted at step" "SIGINT: the reason names the step"
ok $(ls "$OUT/int" | grep -q tmp; [ $? -ne 0 ]; echo $?) "SIGINT: no temporary file left behind"

# SIGTERM too
"$MOREAU" run "$W" --out "$OUT/term" --quiet --set time.end=1.0e6 2> /dev/null &
pid=$!
i=0
while [ ! -s "$OUT/term/history.csv" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
kill -TERM $pid
wait $pid
is "$?" "1" "SIGTERM: exit status 1"
is "$(json "$OUT/term/summary.json" "d['status']")" "incomplete" "SIGTERM: summary.json says incomplete"

# an injected NaN: a load amplitude that is not finite after t = 0.5
e=$("$MOREAU" run "$W" --out "$OUT/nan" --quiet \
  --set 'bodies.bar.loads=({ type = "nodal"; set = "right"; value = [1.0e-3]; amplitude = "t < 0.5 ? 1 : log(-1)"; })' 2>&1)
is "$?" "1" "NaN: exit status 1"
contains "$e" "step 100 (t = 0.5)" "NaN: the diagnosis names the step and time"
contains "$e" "the amplitude of load 0 (\"t < 0.5 ? 1 : log(-1)\") is not finite" "NaN: and its cause"
is "$(json "$OUT/nan/summary.json" "d['status']")" "incomplete" "NaN: summary.json says incomplete"
is "$(json "$OUT/nan/summary.json" "d['time']['steps_done']")" "99" "NaN: outputs complete up to the last good step"
is "$(tail -1 "$OUT/nan/history.csv" | cut -d, -f1)" "0.495" "NaN: history.csv ends at the last good step"
ok $(csv_complete "$OUT/nan/history.csv"; echo $?) "NaN: history.csv rows complete"

# a forced non-convergence: one Newton iteration for an impact
R="$MOREAU_SRCDIR/cases/cylinder-wall"
e=$("$MOREAU" run "$R" --out "$OUT/nc" --quiet --solver newmark --set contact.pairs.wall.mu=0.5 --set contact.newmark.max_iter=1 2>&1)
is "$?" "1" "non-convergence: exit status 1"
contains "$e" "contact solve stopped on iteration limit" "non-convergence: the diagnosis says why"
contains "$e" "Remedies:" "non-convergence: and suggests remedies"
is "$(json "$OUT/nc/summary.json" "d['status']")" "incomplete" "non-convergence: summary.json says incomplete"

# a nonlinear step that inverts elements: the Taylor bar at 30 km/s on a coarse mesh
T="$MOREAU_SRCDIR/cases/taylor-axisymmetric"
e=$("$MOREAU" run "$T" --out "$OUT/inv" --quiet --set 'bodies.bar.mesh.elements=[2, 20]' \
  --set 'bodies.bar.initial.velocity=[0.0, -3.0e4]' --set output.vtk.every=1000 2>&1)
is "$?" "1" "inverted element: exit status 1"
contains "$e" "step 1 (t = 2e-07): Newton did not converge" "inverted element: the diagnosis names the step and the time"
contains "$e" "were not admissible, the last: 2 elements inverted (det F <= 0): 'bar' element 0, 'bar' element 1" "inverted element: and the elements"
contains "$e" "relative residuals " "inverted element: and the residual history"
is "$(json "$OUT/inv/summary.json" "d['status']")" "incomplete" "inverted element: summary.json says incomplete"
ok $(csv_complete "$OUT/inv/history.csv"; echo $?) "inverted element: history.csv rows complete"

# a Newton iteration limit: one iteration is not enough once the bar deforms plastically
e=$("$MOREAU" run "$T" --out "$OUT/newton" --quiet --set 'bodies.bar.mesh.elements=[2, 20]' \
  --set time.newton.max_iter=1 --set output.vtk.every=1000 2>&1)
is "$?" "1" "Newton limit: exit status 1"
contains "$e" "Newton did not converge in 1 iterations (time.newton.max_iter = 1" "Newton limit: the diagnosis says why"
contains "$e" "relative residuals 9.99e-01, 4.13e-02, tolerance 1e-08 (time.newton.tol)" "Newton limit: with the residual history and the tolerance"
is "$(json "$OUT/newton/summary.json" "d['status']")" "incomplete" "Newton limit: summary.json says incomplete"
is "$(json "$OUT/newton/summary.json" "'%g' % d['time']['t_reached']")" "$(tail -1 "$OUT/newton/history.csv" | cut -d, -f1)" \
  "Newton limit: history.csv ends at the last good step"

# a result file is never replaced by a partial one: write-protect the output folder
mkdir -p "$OUT/ro"
"$MOREAU" run "$W" --out "$OUT/ro" --quiet --set time.end=0.1 > /dev/null
before=$(md5sum < "$OUT/ro/summary.json")
chmod a-w "$OUT/ro"
if [ "$(id -u)" -ne 0 ]; then
  "$MOREAU" run "$W" --out "$OUT/ro" --quiet --set time.end=0.2 > /dev/null 2>&1
  ok $([ $? -ne 0 ] && echo 0 || echo 1) "read-only output folder: the run fails"
else
  ok 0 "# SKIP as root the folder stays writable"
fi
chmod u+w "$OUT/ro"
is "$(md5sum < "$OUT/ro/summary.json")" "$before" "the earlier summary.json is intact"
done_testing
