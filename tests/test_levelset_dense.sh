#!/bin/sh
# test_levelset_dense.sh: on the reduced path's sparse algebra (T137) the frozen status's matrix is
# assembled dense when its fill is high and factored by the dense reduced path's kept factor
# (T137a): the same solution as CHOLMOD's (sparse) and as the dense reduced path's on sets small
# enough for it (T131), to 1e-12. The sparse path is forced on a small set with
# MOREAU_LEVELSET_DENSE_MAX=0, the factorization with MOREAU_LEVELSET_DENSE_FILL (0: the dense
# factor, 2: CHOLMOD).
. "$MOREAU_SRCDIR/tests/tap.sh"

# an H8 block pressed on a frictionless plane: 5 x 5 candidates, W_XX dense (every node of the
# base couples to every other through the block)
cat > "$OUT/box.cfg" <<'CFG'
title = "levelset dense path: a 4 x 4 x 2 H8 block pressed on a frictionless plane";
bodies = (
  { name = "box";
    mesh = { generator = "box"; size = [0.1, 0.1, 0.05]; elements = [4, 4, 2]; };
    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; };
    loads = ( { type = "pressure"; set = "zmax"; value = 1.0e6; } ); },
  { name = "ground"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; }
);
time = { scheme = "theta"; theta = 1.0; dt = 1.0e-5; steps = 20; };
contact = { solver = "levelset";
  pairs = ( { name = "base"; slave = "box"; slave_set = "zmin"; master = "ground"; mu = 0.0; } ); };
output = { precision = 17; energy = false; };
CFG
run() { # LABEL ENV...: one run into $OUT/LABEL
  label=$1
  shift
  env "$@" "$MOREAU" run "$OUT/box.cfg" --out "$OUT/$label" --quiet 2>"$OUT/err"
  ok $? "box runs ($label) $(head -c 200 "$OUT/err")"
}
run lapack MOREAU_LEVELSET_DENSE_MAX=0 MOREAU_LEVELSET_DENSE_FILL=0
run cholmod MOREAU_LEVELSET_DENSE_MAX=0 MOREAU_LEVELSET_DENSE_FILL=2
run reduced MOREAU_LEVELSET_DENSE_MAX=400
for r in lapack cholmod reduced; do
  is "$(json "$OUT/$r/summary.json" "d['contact']['failed_solves']")" 0 "$r: no failed solve"
done
is "$(json "$OUT/lapack/summary.json" "d['contact']['last_open']")" 0 "lapack: the 25 candidates closed at the end"
# the reactions and in-plane displacements of every candidate at the end, each relative to its
# largest (the gaps and normal velocities of the closed candidates are round-off, 1e-21 and 1e-17;
# the slip velocities, 1e-7 m/s, differences of displacements 1e-8 m over dt, carry 1e-16 m/s of it)
cmp() {
  /usr/bin/python3 - "$OUT/$1/contact.csv" "$OUT/$2/contact.csv" <<'PY'
import csv, sys
a = list(csv.DictReader(open(sys.argv[1]))); b = list(csv.DictReader(open(sys.argv[2])))
assert len(a) == len(b) == 25, (len(a), len(b))
worst = 0.0
for key in ("RN", "D1", "D2"):
    scale = max(abs(float(r[key])) for r in b) or 1.0
    worst = max(worst, max(abs(float(x[key]) - float(y[key])) / scale for x, y in zip(a, b)))
print("%.3e" % worst)
PY
}
for pair in "lapack cholmod" "lapack reduced"; do
  set -- $pair
  w=$(cmp "$1" "$2")
  ok $(/usr/bin/python3 -c "import sys; sys.exit(0 if float('$w') < 1e-12 else 1)"; echo $?) \
    "$1 = $2: reactions and displacements to $w (< 1e-12)"
done

# Without friction levelset's velocities read W's normal entries alone (doc/theory.md (T175),
# (T176)); the KKT path forms no W product (U' = q + H^T dv) and is the reference: the same
# reactions and displacements to 1e-12, concentrated and weighted reactions; with mu = 0.3 the
# reduced path reads the whole blocks (friction) and is compared the same way
runp() { # LABEL ARGS...: one run into $OUT/LABEL with --set ARGS
  label=$1
  shift
  "$MOREAU" run "$OUT/box.cfg" --out "$OUT/$label" --quiet "$@" 2>"$OUT/err"
  ok $? "box runs ($label) $(head -c 200 "$OUT/err")"
}
cmpall() {
  /usr/bin/python3 - "$OUT/$1/contact.csv" "$OUT/$2/contact.csv" <<'PY'
import csv, sys
a = list(csv.DictReader(open(sys.argv[1]))); b = list(csv.DictReader(open(sys.argv[2])))
assert len(a) == len(b) == 25, (len(a), len(b))
worst = 0.0
for key in ("RN", "RT", "RS", "D1", "D2"):
    scale = max(abs(float(r[key])) for r in b) or 1.0
    worst = max(worst, max(abs(float(x[key]) - float(y[key])) / scale for x, y in zip(a, b)))
print("%.3e" % worst)
PY
}
for re in concentrated weighted; do
  for mu in 0.0 0.3; do
    runp "n-$re-$mu" --set contact.reactions=$re --set contact.pairs.base.mu=$mu
    runp "k-$re-$mu" --set contact.reactions=$re --set contact.pairs.base.mu=$mu --set 'contact.levelset.path="kkt"'
    is "$(json "$OUT/n-$re-$mu/summary.json" "d['contact']['failed_solves']")" 0 "$re, mu = $mu: no failed solve"
    w=$(cmpall "n-$re-$mu" "k-$re-$mu")
    ok $(/usr/bin/python3 -c "import sys; sys.exit(0 if float('$w') < 1e-12 else 1)"; echo $?) \
      "$re reactions, mu = $mu: the reduced path ($([ $mu = 0.0 ] && echo "W's normal column" || echo "W's whole blocks")) = the KKT path: reactions and displacements to $w (< 1e-12)"
  done
done
done_testing
