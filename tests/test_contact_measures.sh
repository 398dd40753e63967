#!/bin/sh
# test_contact_measures.sh: the oscillation index of a contact that slides or rests without normal
# motion is not its own round-off over itself (doc/theory.md (T50)): incline-block, a block sliding
# down a 20 degree slope (mu = 0.2) or held on it (mu = 0.5), by each back end; an oscillation
# that exists is still measured (newmark on rods-1d).
. "$MOREAU_SRCDIR/tests/tap.sh"
IB="$MOREAU_SRCDIR/cases/incline-block"
nodraw="--set output.draw.gif=false --set output.draw.frames=1"   # the drawings are not measured here
m() { json "$1/summary.json" "d['metrics']['contact']['$2']"; }
lt() { /usr/bin/python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) < float(sys.argv[2]) else 1)" "$1" "$2"; echo $?; }
for s in nscd levelset newmark; do
  "$MOREAU" run "$IB" --solver $s --set contact.pairs.base.mu=0.2 --set reference.mu=0.2 $nodraw --quiet --out "$OUT/slide-$s"
  ok $? "incline-block, mu = 0.2 (slides), $s"
  o=$(m "$OUT/slide-$s" oscillation_index); v=$(m "$OUT/slide-$s" oscillation_scale)
  ok $(lt "$o" 1e-2) "sliding, $s: oscillation index $o below 1e-2 (497 under levelset, 26.6 under newmark before the scale)"
  ok $(/usr/bin/python3 -c "import sys; sys.exit(0 if abs(float(sys.argv[1]) / 1.51154068 - 1) < 1e-6 else 1)" "$v"; echo $?) \
     "sliding, $s: its scale $v m/s is the block's speed at 1 s, g (sin 20 - 0.2 cos 20) t = 1.51154 m/s"
done
"$MOREAU" run "$IB" --solver levelset $nodraw --quiet --out "$OUT/rest"; ok $? "incline-block, mu = 0.5 (held), levelset"
o=$(m "$OUT/rest" oscillation_index); v=$(m "$OUT/rest" oscillation_scale)
ok $(lt "$o" 1e-3) "held: oscillation index $o below 1e-3"
ok $(/usr/bin/python3 -c "import sys; sys.exit(0 if abs(float(sys.argv[1]) / 7.0710678e-8 - 1) < 1e-6 else 1)" "$v"; echo $?) \
   "held: its scale $v m/s is the round-off speed 1e-9 L / h (L = 0.0707 m, the block's bounding radius; h = 1e-3 s)"
"$MOREAU" run "$MOREAU_SRCDIR/cases/rods-1d" --solver newmark --quiet --out "$OUT/nm"; ok $? "rods-1d, newmark"
o=$(m "$OUT/nm" oscillation_index)
ok $(lt 1 "$o") "newmark's contact end still oscillates: index $o above 1"
done_testing
