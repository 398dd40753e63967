#!/bin/sh
# test_bad_cases.sh: the corpus of malformed and hostile case files (tests/bad/NN-what.cfg): each
# is rejected by `moreau check` with exit status 2 and exactly the message in NN-what.expect
# (FILE stands for the file's path). The same files seed the case-reader fuzzer.
. "$MOREAU_SRCDIR/tests/tap.sh"
n=0
for f in "$MOREAU_SRCDIR"/tests/bad/*.cfg; do
  b=$(basename "$f" .cfg)
  n=$((n + 1))
  want=$(sed "s|FILE|$f|g" "$MOREAU_SRCDIR/tests/bad/$b.expect")
  got=$("$MOREAU" check "$f" 2>&1)
  rc=$?
  is "$rc" "2" "$b: exit status 2"
  is "$got" "$want" "$b: message"
done
ok $([ "$n" -ge 30 ] && echo 0 || echo 1) "the corpus holds at least 30 files ($n)"
done_testing
