#!/bin/sh
# levelset_cost.sh: the contact phase of every shipped scene that runs a contact back end, by
# nscd and by levelset (issue 15 item 4: levelset within 2x of nscd). One table: the scene, the
# end time run (shortened where the full run is long: marked *), the contact-phase seconds of
# each back end (summary.json timings.contact, the run's own clock), their ratio, and the
# levelset run's outcome. A scene levelset refuses or fails shows the reason instead of a ratio.
#
#   bench/levelset_cost.sh [CASE...]       (MOREAU=path/to/moreau, default build/moreau)
#   LEVELSET_ARGS='--set contact.levelset.globalization="hybrid"' bench/levelset_cost.sh CASE...
#                                          (options added to the levelset runs only; no spaces
#                                          inside one option)
#
# The phase timers count the thread's CPU time (MOREAU_CLOCK=cpu), not the wall clock that a
# loaded machine inflates; each scene still runs REPEAT times per back end (alternating) and the
# table keeps the least contact time of each. The small scenes' figures (tens of microseconds
# over a whole run) stay noisy.
here=$(cd "$(dirname "$0")/.." && pwd)
MOREAU_CLOCK=${MOREAU_CLOCK:-cpu}   # the phase timers count CPU time (moreau(1), ENVIRONMENT)
export MOREAU_CLOCK
MOREAU=${MOREAU:-$here/build/moreau}
REPEAT=${REPEAT:-3}  # runs of each scene and back end; the table shows the least contact time
LIMIT=${LIMIT:-120}   # seconds a run may take; a levelset run past it is reported as such
OUT=${OUT:-$(mktemp -d /tmp/levelset_cost.XXXXXX)}
mkdir -p "$OUT"
[ -x "$MOREAU" ] || { echo "levelset_cost.sh: no moreau at $MOREAU (set MOREAU=...)" >&2; exit 2; }

# end times for the scenes whose full run is long (seconds of simulated time)
short_end() {
  case "$1" in
    ball-bounce) echo 1.0 ;;
    bouncing-bar) echo 5.34 ;;
    column-collapse) echo 0.2 ;;
    disk-pile) echo 0.2 ;;
    sphere-deposit) echo 0.2 ;;
    rocking-block) echo 0.5 ;;
    taylor-axisymmetric|taylor-plane-strain) echo 2.0e-5 ;;
    *) echo "" ;;
  esac
}

# what a summary says: contact seconds, status, last reason
field() {
  python3 - "$1" <<'PY'
import json, sys
try:
    d = json.load(open(sys.argv[1]))
except Exception:
    print("- missing -"); sys.exit()
c = d.get("contact", {})
t = d.get("time", {})
why = c.get("last_reason", "?").replace(" ", "_")
if c.get("failed_solves", 0):
    why = "failed_solves=%d_of_%d" % (c["failed_solves"], c.get("steps_with_contact", 0))
if d.get("status") != "complete":
    why += ",t_reached=%g" % t.get("t_reached", float("nan"))
print("%.6f %s %s" % (d.get("timings", {}).get("contact", float("nan")), d.get("status", "?"), why))
PY
}

# the smaller of two figures ('-' for none): the least disturbed of the repeated runs
least() {
  python3 -c "import sys
v = [float(x) for x in sys.argv[1:] if x not in ('-', 'nan')]
print('%.6f' % min(v) if v else '-')" "$1" "$2"
}

if [ $# -eq 0 ]; then
  set --
  for d in "$here"/cases/*/; do
    grep -q '^contact' "$d/case.cfg" 2>/dev/null && set -- "$@" "$(basename "$d")"
  done
fi

printf '%-20s %-10s %12s %12s %8s  %s\n' scene end nscd_s levelset_s ratio note
set -f   # the run arguments below hold brackets: no file-name expansion
for name in "$@"; do
  d=$here/cases/$name
  end=$(short_end "$name")
  args=--quiet
  grep -q 'vtk' "$d/case.cfg" && args="$args --set output.vtk.every=1000000"
  mark=""
  if [ -n "$end" ]; then args="$args --set time.end=$end"; mark="*"; fi
  [ "$name" = taylor-axisymmetric ] && args="$args --set bodies.bar.mesh.elements=[4,40]"
  tn=- tl=- stl=- why=
  for k in $(seq "$REPEAT"); do
    for s in nscd levelset; do
      rm -rf "$OUT/$name-$s"
      extra=""
      [ $s = levelset ] && extra=${LEVELSET_ARGS:-}
      # shellcheck disable=SC2086
      timeout -k 5 "$LIMIT" "$MOREAU" run "$d" --solver $s --out "$OUT/$name-$s" $args $extra >"$OUT/$name-$s.log" 2>&1
    done
    set -- $(field "$OUT/$name-nscd/summary.json")
    tn=$(least "$tn" "$1")
    set -- $(field "$OUT/$name-levelset/summary.json")
    tl=$(least "$tl" "$1") stl=$2 why=$3
    [ "$stl" = complete ] || break   # a levelset run that fails or times out is not repeated
  done
  shown=${end:-full}
  ratio=$(python3 -c "a,b='$tn','$tl'
try: print('%.2f' % (float(b)/float(a)))
except Exception: print('-')")
  note="$stl $why"
  if [ "$stl" = missing ]; then
    note="levelset: killed after LIMIT = $LIMIT s (no summary)"
    ratio=-
  elif [ "$stl" = incomplete ] && ! grep -qiE 'error|cannot|stopped on' "$OUT/$name-levelset.log"; then
    note="levelset: stopped at LIMIT = $LIMIT s ($why)"
    ratio=-
  elif [ "$stl" = complete ] && [ "${why#failed_solves}" != "$why" ]; then
    note="levelset: $why contact steps failed (no ratio for a run that did not solve)"
    ratio=-
  elif [ "$stl" != complete ]; then
    note="levelset: $(grep -m1 -iE 'error|refuse|cannot|redundan|fail' "$OUT/$name-levelset.log" | cut -c1-90)"
    ratio=-
  fi
  printf '%-20s %-10s %12s %12s %8s  %s\n' "$name" "$shown$mark" "$tn" "$tl" "$ratio" "$note"
done
echo "(* end time shortened from the case's; outputs in $OUT)"
