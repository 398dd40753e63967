#!/bin/sh
# test_bad_cases.sh: the corpus of malformed and hostile case files (tests/bad/NN-what.cfg): each
# is rejected by `moreau check` with exit status 2 and exactly the message in NN-what.expect
# (FILE stands for the file's path, DIR for the folder holding it, where the mesh files NN-what.msh
# of the cases that read one lie). The same files seed the fuzzer.
. "$MOREAU_SRCDIR/tests/tap.sh"
n=0
for f in "$MOREAU_SRCDIR"/tests/bad/*.cfg; do
  b=$(basename "$f" .cfg)
  n=$((n + 1))
  want=$(sed -e "s|FILE|$f|g" -e "s|DIR|$MOREAU_SRCDIR/tests/bad|g" "$MOREAU_SRCDIR/tests/bad/$b.expect")
  got=$("$MOREAU" check "$f" 2>&1)
  rc=$?
  is "$rc" "2" "$b: exit status 2"
  is "$got" "$want" "$b: message"
done
ok $([ "$n" -ge 30 ] && echo 0 || echo 1) "the corpus holds at least 30 files ($n)"
done_testing
