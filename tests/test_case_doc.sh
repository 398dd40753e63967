#!/bin/sh
# test_case_doc.sh: doc/case-format.md documents every key the schema accepts.
. "$MOREAU_SRCDIR/tests/tap.sh"
doc="$MOREAU_SRCDIR/doc/case-format.md"
missing=""
n=0
for k in $("$MOREAU" keys | awk '{print $1}'); do
  n=$((n + 1))
  grep -qF "\`$k\`" "$doc" || missing="$missing $k"
done
ok $([ "$n" -gt 0 ] && echo 0 || echo 1) "the schema has keys ($n)"
is "$missing" "" "every key appears in doc/case-format.md as \`key\`"
done_testing
