#!/bin/sh
# levelset_load_steps.sh: Jean's GRECO block with mu = 1 (cases/greco-jean-mu1) in N = 1 .. 10
# quasi-static load steps, by levelset and nscd, with concentrated and weighted reactions, under
# three load histories a(t) on both loads: 1 (the case as shipped: every step at the full load),
# t (a proportional ramp) and min(1, 2 t) (a ramp over half the steps, then held). Prints, per
# back end, history and reactions, the N whose run fails and the residual each failure reports
# (issue 15, item 7: the status decisions of levelset at round-off, doc/theory.md (T88), (T89)).
#   bench/levelset_load_steps.sh [MOREAU]   default: build/moreau
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
moreau=${1:-$root/build/moreau}
[ -x "$moreau" ] || { echo "levelset_load_steps.sh: no moreau binary at $moreau" >&2; exit 2; }
tmp=$(mktemp -d /tmp/levelset_load_steps.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
src="$root/cases/greco-jean-mu1/case.cfg"
# the case with amplitude A on both loads (none: the case as shipped)
variant() {
  if [ "$1" = none ]; then cp "$src" "$tmp/case.cfg"; return; fi
  sed -e "s/value = 5.0e7; }/value = 5.0e7; amplitude = \"$1\"; }/" \
      -e "s/6.0e5\]; }/6.0e5]; amplitude = \"$1\"; }/" "$src" > "$tmp/case.cfg"
  [ "$(grep -c amplitude "$tmp/case.cfg")" = 2 ] || { echo "levelset_load_steps.sh: $src changed" >&2; exit 2; }
}
printf '%-8s %-12s %-12s %-16s %s\n' solver reactions "a(t)" "failing N" "residuals reported"
for amp in none t "min(1,2*t)"; do
  variant "$amp"
  for solver in levelset nscd; do
    for reactions in concentrated weighted; do
      fails=""; res=""
      for n in 1 2 3 4 5 6 7 8 9 10; do
        if ! "$moreau" run "$tmp/case.cfg" --solver "$solver" --set "time.steps=$n" \
             --set "contact.reactions=$reactions" --out "$tmp/out" --quiet > "$tmp/log" 2>&1; then
          fails="$fails $n"
          res="$res $(grep -o 'residual [0-9.e+-]*' "$tmp/log" | head -1 | cut -d' ' -f2)"
        fi
      done
      printf '%-8s %-12s %-12s %-16s %s\n' "$solver" "$reactions" "$([ "$amp" = none ] && echo 1 || echo "$amp")" \
        "${fails:- none}" "${res:- -}"
    done
  done
done
