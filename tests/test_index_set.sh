#!/bin/sh
# test_index_set.sh: the velocity-level index set (doc/theory.md §5) is predicted from the free
# motion; a candidate the impulses of its neighbours push into the obstacle within the step joins
# it and the step is solved again. cylinder-wall at h = 5e-7 s: two nodes beside the flattened
# bottom entered the wall by 6.2e-5 m in one step (0.042 of the smallest element) before.
. "$MOREAU_SRCDIR/tests/tap.sh"
CW="$MOREAU_SRCDIR/cases/cylinder-wall"
for solver in nscd levelset; do
  "$MOREAU" run "$CW" --solver "$solver" --set time.dt=5e-7 --set time.end=3e-5 --out "$OUT/$solver" --quiet
  ok $? "cylinder-wall, $solver, h = 5e-7: runs"
  pen=$(json "$OUT/$solver/summary.json" "d['metrics']['contact']['max_penetration']")
  add=$(json "$OUT/$solver/summary.json" "d['contact']['index_set_additions']")
  ok $(awk -v p="$pen" 'BEGIN { exit !(p < 1e-9) }'; echo $?) "$solver: no candidate ends inside the wall (max penetration $pen m < 1e-9)"
  ok $([ "$add" -gt 0 ] && echo 0 || echo 1) "$solver: the index set took the missed candidates ($add added)"
done
en=$(json "$OUT/nscd/summary.json" "d['energy']['ratio']")
el=$(json "$OUT/levelset/summary.json" "d['energy']['ratio']")
ok $(awk -v a="$en" -v b="$el" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d < 1e-7 * b) }'; echo $?) \
  "nscd and levelset end with the same energy to 1e-7 (one discrete problem; nscd's tol 1e-8): $en, $el"
# where the prediction is right, nothing is added: h = 1e-6 over the whole impact
"$MOREAU" run "$CW" --set time.dt=1e-6 --out "$OUT/coarse" --quiet
is "$(json "$OUT/coarse/summary.json" "d['contact']['index_set_additions']")" "0" "h = 1e-6: the predicted index set holds every contact"
done_testing
