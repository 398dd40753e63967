#!/bin/sh
# test_nscd.sh: the nscd back end from the command line: Jean's table and contact.csv of the GRECO
# cases, the short form contact.reactions, summary.json's iteration counts, bench-local.
. "$MOREAU_SRCDIR/tests/tap.sh"

contains "$("$MOREAU" list-solvers)" "nscd" "list-solvers names nscd"

t=$("$MOREAU" run "$MOREAU_SRCDIR/cases/greco-jean-mu1" --out "$OUT/g1"); ok $? "greco-jean-mu1 runs"
contains "$t" "pair base (concentrated reactions)" "the table names the representation"
contains "$t" "node            D1            D2            RT            RN  status" "Jean's columns: node, D1, D2, RT, RN, status"
contains "$t" "equiv. weighted (P^-1 r)" "with the other representation's columns"
contains "$t" "(Rx, Ry: sum of the concentrated reactions)" "and the resultants"
contains "$t" "iterations = " "and the iterations (nscd: sweeps)"
row=$(echo "$t" | awk '$1 == "13" { print $6 }'); is "$row" "stick" "node 13 sticks"
row=$(echo "$t" | awk '$1 == "6" { print $6 }'); is "$row" "slide" "node 6 slides"
h=$(head -1 "$OUT/g1/contact.csv")
ok $(/usr/bin/python3 -c "import sys; h=sys.argv[1].split(','); sys.exit(0 if all(k in h for k in 'node x D1 D2 RT RN status'.split()) and h.index('UN') < h.index('UT') < h.index('RN') < h.index('RT') and h.index('RN_other') < h.index('RT_other') else 1)" "$h"; echo $?) \
  "contact.csv header holds node, x, D1, D2, UN, UT, RN, RT, status, normal first as U ($h)"
is "$(grep -c ',stick,' "$OUT/g1/contact.csv")" "4" "contact.csv: 4 sticking candidates"
is "$(json "$OUT/g1/summary.json" "d['contact']['solver']")" "nscd" "summary.json: solver nscd"
ok $(json "$OUT/g1/summary.json" "0 if d['contact']['iterations_total'] > 10 and d['contact']['iterations_max'] == d['contact']['iterations_total'] else 1") \
  "summary.json: sweeps of the one step ($(json "$OUT/g1/summary.json" "d['contact']['iterations_total']"))"

w=$("$MOREAU" run "$MOREAU_SRCDIR/cases/greco-jean-mu1" --out "$OUT/g1w" --set contact.reactions=weighted); ok $? "--set contact.reactions=weighted"
contains "$w" "pair base (weighted reactions)" "the short form turns the pair to weighted reactions"
contains "$w" "equiv. concentrated (P rho)" "a weighted table gives the P images"
is "$(/usr/bin/python3 -c "import csv, sys; print(next(csv.DictReader(open(sys.argv[1])))['representation'])" "$OUT/g1w/contact.csv")" "weighted" "contact.csv says which representation"
r=$("$MOREAU" run "$MOREAU_SRCDIR/cases/greco-jean-mu01" --out "$OUT/g01" --set nscd.stop=sweeps --set nscd.max_sweeps=42 --quiet); ok $? "Jean's run replayed (--set nscd.stop=sweeps --set nscd.max_sweeps=42)"
is "$(json "$OUT/g01/summary.json" "d['contact']['iterations_total']")" "42" "exactly 42 sweeps"
e=$("$MOREAU" check "$MOREAU_SRCDIR/cases/greco-jean-mu1" --set nscd.order=random 2>&1); is $? 2 "a bad option value: exit 2"
contains "$e" "nscd.order" "the message names the option"

# bench-local
"$MOREAU" bench-local > /dev/null 2>&1; is $? 2 "bench-local without files: exit 2"
f="$MOREAU_SHARED/data/fclib/Box_Stacks-i0122-82-5.hdf5"
b=$("$MOREAU" bench-local "$f" --min-time 0.01 2>&1); rc=$?
if [ $rc -eq 2 ] && echo "$b" | grep -q "reads no FCLIB"; then
  ok 0 "# SKIP this build reads no FCLIB files"
elif [ ! -r "$f" ]; then
  ok 0 "# SKIP no shared data ($f)"
else
  ok $rc "bench-local on Box_Stacks"
  contains "$b" "problem                                   nc  solver    sweeps   residual     t(1e-4)     t(1e-8)  us/update" "bench-local header"
  res=$(echo "$b" | awk '$3 == "nscd" { print $5 }')
  ok $(/usr/bin/python3 -c "import sys; sys.exit(0 if 0 < float(sys.argv[1]) <= 1e-8 else 1)" "$res"; echo $?) "nscd reaches 1e-8 ($res)"
  s=$("$MOREAU" bench-local "$f" --min-time 0.01 --vs-siconos 2>&1); rc=$?
  if [ $rc -eq 2 ]; then
    contains "$s" "no Siconos" "--vs-siconos without Siconos explains itself"
  else
    ok $rc "bench-local --vs-siconos"
    contains "$s" "(Siconos / nscd)" "side by side with Siconos and the ratios"
  fi
fi
done_testing
