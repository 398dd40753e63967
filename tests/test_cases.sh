#!/bin/sh
# test_cases.sh: every shipped case passes `moreau check` and runs to completion. A case may
# hold ci.set (one KEY=VALUE per line) making its CI run small.
. "$MOREAU_SRCDIR/tests/tap.sh"
for d in "$MOREAU_SRCDIR"/cases/*/; do
  name=$(basename "$d")
  "$MOREAU" check "$d" > /dev/null 2>"$OUT/err"; ok $? "$name: check $(head -c 300 "$OUT/err")"
  ok $(test -s "$d/README.md"; echo $?) "$name: README.md present"
  set --
  if [ -f "$d/ci.set" ]; then
    while IFS= read -r kv; do
      case "$kv" in ''|'#'*) continue ;; esac
      set -- "$@" --set "$kv"
    done < "$d/ci.set"
  fi
  "$MOREAU" run "$d" --out "$OUT/$name" --quiet "$@" 2>"$OUT/err"
  ok $? "$name: runs $(head -c 300 "$OUT/err")"
  is "$(json "$OUT/$name/summary.json" "d['status']")" "complete" "$name: summary says complete"
done
done_testing
