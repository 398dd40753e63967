# tap.sh: TAP helpers for the shell tests (sourced).
tap_n=0
tap_failed=0
ok() { # ok STATUS DESCRIPTION
  tap_n=$((tap_n + 1))
  if [ "$1" -eq 0 ]; then echo "ok $tap_n - $2"; else echo "not ok $tap_n - $2"; tap_failed=$((tap_failed + 1)); fi
}
is() { # is GOT WANT DESCRIPTION
  if [ "$1" = "$2" ]; then ok 0 "$3"; else ok 1 "$3"; printf '#   got:  %s\n#   want: %s\n' "$1" "$2"; fi
}
contains() { # contains HAYSTACK NEEDLE DESCRIPTION
  case "$1" in *"$2"*) ok 0 "$3" ;; *) ok 1 "$3"; printf '#   %s\n#   does not contain: %s\n' "$1" "$2" ;; esac
}
done_testing() { echo "1..$tap_n"; [ "$tap_failed" -eq 0 ]; }
: "${MOREAU:?MOREAU must point at the moreau program}"
: "${MOREAU_SRCDIR:?MOREAU_SRCDIR must point at the source tree}"
OUT=${TMPDIR:-/tmp}/moreau-test.$$
mkdir -p "$OUT"
trap 'rm -rf "$OUT"' EXIT
# a JSON field: json FILE EXPR (python3 from Debian, always present with the toolchain)
json() { /usr/bin/python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print($2)" "$1"; }
# the comparison tests (test_compare.sh, test_compare_verdict.sh):
ran() { # ran STATUS ERRFILE DESCRIPTION: the command's standard error only when it failed
  ok "$1" "$3"
  [ "$1" -eq 0 ] || sed 's/^/#   /' "$2" | head -20
}
check() { # check ARGS...: each line of compare_check.py becomes one TAP result
  /usr/bin/python3 "$MOREAU_SRCDIR/tests/compare_check.py" "$@" > "$OUT/check" 2>&1 || echo "1	compare_check.py $1 crashed: $(tail -1 "$OUT/check")" >> "$OUT/check"
  while IFS= read -r line; do
    case "$line" in
      '#'*) echo "$line" ;;
      [01]'	'*) ok "${line%%	*}" "${line#*	}" ;;
      *) echo "# $line" ;;
    esac
  done < "$OUT/check"
}
