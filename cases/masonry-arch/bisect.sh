#!/bin/sh
# bisect.sh: the limit thickness of the 36-voussoir arch by bisection (doc/architecture.md §11): each run lasts
# T = 1.5 s; the arch collapsed when a voussoir still moves faster than 1 mm/s at T (a standing
# arch creeps at 1e-8 m/s, a collapsing one at metres per second). Starts from the bracket
# [0.09, 0.13] of the case's README and halves it until it is narrower than TOL (default 0.0025).
#   cases/masonry-arch/bisect.sh [MOREAU] [TOL] [SOLVER]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
moreau=${1:-$here/../../build/moreau}
tol=${2:-0.0025}
solver=${3:-nscd}
out=${TMPDIR:-/tmp}/moreau-arch-bisect.$$
lo=0.09; hi=0.13
collapses() {
  # a collapse goes through steps the solver may not converge on: counted, and the run goes on
  "$moreau" run "$here" --solver "$solver" --set "bodies.arch.arch.thickness=$1" --set time.end=1.5 \
    --set contact.on_failure=continue --out "$out/t$1" --quiet > /dev/null
  v=$(tail -1 "$out/t$1/history.csv" | awk -F, -v c="$(head -1 "$out/t$1/history.csv" | tr ',' '\n' | grep -n '^rigid.vmax$' | cut -d: -f1)" '{print $c}')
  f=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['contact']['failed_solves'])" "$out/t$1/summary.json")
  echo "t/R = $1: vmax at 1.5 s = $v m/s ($f solves not converged)" >&2
  awk -v v="$v" 'BEGIN { exit !(v > 1e-3) }'
}
collapses $lo || { echo "bisect: t/R = $lo does not collapse" >&2; exit 1; }
if collapses $hi; then echo "bisect: t/R = $hi collapses" >&2; exit 1; fi
while awk -v a="$lo" -v b="$hi" -v t="$tol" 'BEGIN { exit !(b - a > t) }'; do
  mid=$(awk -v a="$lo" -v b="$hi" 'BEGIN { printf "%.5f", (a + b) / 2 }')
  if collapses "$mid"; then lo=$mid; else hi=$mid; fi
done
rm -rf "$out"
echo "limit thickness: $lo < t/R < $hi (collapses at $lo, stands at $hi)"
