#!/bin/sh
# test_peer_getfem.sh: `moreau compare --peer` (rows of another program in the figure and the
# report, never in compare.csv), and the GetFEM peer on bar-obstacle (bench/getfem_bar_obstacle.py)
# at small size: its CSV, its closed form and metrics against moreau's, and GetFEM's Newmark with
# Lagrange multipliers against moreau's newmark back end, the same scheme. The GetFEM checks are
# skipped when /usr/bin/python3 cannot import getfem (Debian package python3-getfem).
. "$MOREAU_SRCDIR/tests/tap.sh"

skip() { # skip DESCRIPTION REASON
  tap_n=$((tap_n + 1))
  echo "ok $tap_n - $1 # SKIP $2"
}
PY=${PYTHON_GETFEM:-/usr/bin/python3}   # Debian's interpreter: the one that sees python3-getfem
SCRIPT="$MOREAU_SRCDIR/bench/getfem_bar_obstacle.py"
CASE="$MOREAU_SRCDIR/cases/bar-obstacle"
SMALL="--set bodies.[0].mesh.elements=20 --set time.end=3"

# --- compare --peer on a hand-written peer file ---------------------------------------------------
cat > "$OUT/peer.csv" <<'EOF'
solver,dt,wall_s,steps,status,reason,field.u_l2l2_rel,energy.final,energy.max_growth,contact.max_penetration,scene.hmin,cpu_s,peer
other-code,0.05,0.5,60,complete,,0.125,0.12,0,0,0.05,0.45,other 1.0
other-code,0.025,1.5,120,complete,,0.0625,0.12,0,0,0.05,1.4,other 1.0
"other-code",0.0125,,,failed,"diverged, at ""step"" 7",,,,,,,other 1.0
EOF
"$MOREAU" compare "$CASE" --solvers nscd --dt 0.05,0.025 $SMALL --peer "$OUT/peer.csv" --out "$OUT/c1" -q
ok $? "compare --peer runs"
r=$(cat "$OUT/c1/report.md")
contains "$r" "| other-code-dt0.05 (external) | other-code | 0.05 | 0.500 (peer's wall) | 60 | stable: energy growth 0 % (<= 1 %) | 0.125 |" "report.md: a peer row, marked external, its own clock, with its metric"
contains "$r" "| other-code-dt0.025 (external) | other-code | 0.025 | 1.500 (peer's wall) | 120 | stable: energy growth 0 % (<= 1 %) | 0.0625 |" "report.md: the second peer row"
contains "$r" "other-code-dt0.0125 (external)\` failed: diverged, at \"step\" 7" "report.md: a failed peer row with its reason (RFC 4180 quotes read)"
contains "$r" "2 runs: " "report.md counts moreau's own runs only"
contains "$r" "Rows marked (external) are 3 rows of \`$OUT/peer.csv\`" "report.md says where the external rows come from"
is "$(cat "$OUT/c1/plots/work-precision-peer-other-code.csv")" "$(printf '0.5,0.125,0.05\n1.5,0.0625,0.025')" \
  "plot data: the peer's complete rows, wall time and error"
contains "$(cat "$OUT/c1/plots/work-precision.gp")" "'work-precision-peer-other-code.csv' using 1:2 with linespoints lw 2 dt 2 pt 6 title 'other-code (peer)'" \
  "work-precision script: the peer's own dashed line"
is "$(cut -d, -f1 "$OUT/c1/compare.csv" | sort -u | tr '\n' ' ')" "nscd solver " "compare.csv holds moreau's runs only"
ok $(grep -c cpu_s "$OUT/c1/compare.csv") "compare.csv gets no peer-only column"

printf 'solver,dt\nx,0.1\n' > "$OUT/bad1.csv"
e=$("$MOREAU" compare "$CASE" --solvers nscd --dt 0.05 $SMALL --peer "$OUT/bad1.csv" --out "$OUT/c2" -q 2>&1)
is $? 2 "a peer file without wall_s: exit 2"
contains "$e" "peer $OUT/bad1.csv: no column 'wall_s' in the header" "the missing column is named"
ok $(test ! -e "$OUT/c2"; echo $?) "a bad peer file stops the comparison before any run"
printf 'solver,dt,wall_s\nnscd,0.1,1\n' > "$OUT/bad2.csv"
e=$("$MOREAU" compare "$CASE" --solvers nscd --dt 0.05 $SMALL --peer "$OUT/bad2.csv" --out "$OUT/c3" -q 2>&1)
is $? 2 "a peer row named after a back end of the comparison: exit 2"
contains "$e" "peer $OUT/bad2.csv:2: solver 'nscd' is a back end of this comparison" "the clash is explained"
printf 'solver,dt,wall_s\nx,0.1\n' > "$OUT/bad3.csv"
e=$("$MOREAU" compare "$CASE" --solvers nscd --dt 0.05 $SMALL --peer "$OUT/bad3.csv" --out "$OUT/c4" -q 2>&1)
contains "$e" "peer $OUT/bad3.csv:2: 2 fields, the header has 3" "a short row: file, line and counts"
printf 'solver,dt,wall_s\n"x,0.1,1\n' > "$OUT/bad4.csv"
e=$("$MOREAU" compare "$CASE" --solvers nscd --dt 0.05 $SMALL --peer "$OUT/bad4.csv" --out "$OUT/c4" -q 2>&1)
contains "$e" "peer $OUT/bad4.csv:2: a quote out of place" "an unterminated quote: file and line"
e=$("$MOREAU" compare "$CASE" --solvers nscd --dt 0.05 $SMALL --peer "$OUT/none.csv" --out "$OUT/c5" -q 2>&1)
contains "$e" "peer $OUT/none.csv: No such file or directory" "a missing peer file is named"

# --- the GetFEM script ------------------------------------------------------------------------------
mkdir -p "$OUT/fake"
echo 'raise ImportError("no GetFEM here")' > "$OUT/fake/getfem.py"
e=$(PYTHONPATH="$OUT/fake" $PY "$SCRIPT" --out "$OUT/x.csv" 2>&1)
is $? 3 "script: exit 3 when GetFEM cannot be imported"
contains "$e" "apt-get install python3-getfem" "script: the message names the Debian package"

if ! $PY -c "import getfem" >/dev/null 2>&1; then
  reason="python3-getfem is not installed ($PY cannot import getfem)"
  for d in "GetFEM runs" "GetFEM CSV columns" "GetFEM errors" "closed form and metrics against moreau's" \
           "GetFEM Newmark-multipliers = moreau newmark" "compare --peer with GetFEM's rows"; do
    skip "$d" "$reason"
  done
  done_testing
  exit $?
fi

G="$OUT/getfem.csv"
$PY "$SCRIPT" --nx 20 --dt 0.05,0.025 --end 3 --quiet \
  --schemes newmark-nitsche,newmark-multipliers:beta=0.3025:gamma=0.6,massred-multipliers --out "$G"
ok $? "GetFEM runs: 3 schemes, 2 time steps, 20 elements, one period"
# columns present and numeric, every run complete
ok $($PY - "$G" <<'EOF'
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
need = ["solver", "dt", "wall_s", "steps", "cpu_s", "field.u_l2l2_rel", "field.v_l2l2_rel",
        "field.u_linfl2_rel", "field.v_linfl2_rel", "field.u_l2h1_rel", "end.ux.l2_rel",
        "end.vx.l2_rel", "end.pn.l2_rel", "energy.ratio", "contact.impulse", "contact.status_flips"]
bad = [c for c in need if c not in rows[0]]
for r in rows:
    if r["status"] != "complete": bad.append(r["solver"] + " " + r["status"])
    for c in need[1:]:
        v = float(r[c])
        if not math.isfinite(v): bad.append(c)
print(0 if len(rows) == 6 and not bad else 1)
EOF
) "GetFEM CSV: 6 complete rows, the columns present and numeric"
# errors against the closed form: below what the schemes reach at this size (and not zero)
ok $($PY - "$G" <<'EOF'
import csv, sys
ok = True
for r in csv.DictReader(open(sys.argv[1])):
    u, v, e = float(r["field.u_l2l2_rel"]), float(r["field.v_l2l2_rel"]), float(r["energy.ratio"])
    ok &= 1e-3 < u < 0.15 and 1e-2 < v < 0.5 and 0.5 < e < 1.05
    if "massred" in r["solver"]:
        ok &= 0.9 < e <= 1.0 and float(r["contact.max_penetration"]) < 1e-12
print(0 if ok else 1)
EOF
) "GetFEM errors: u L2(L2) below 15 %, v below 50 %, energy ratio sensible; mass redistribution holds the end out of the obstacle"

# the script's closed form and metric code against moreau's (fields written at every step)
"$MOREAU" run "$CASE" $SMALL --set time.dt=0.05 --set output.vtk.every=1 --out "$OUT/nscd" --quiet
v=$($PY "$SCRIPT" --verify "$OUT/nscd"); ok $? "closed form and metrics against moreau's (nscd run): all agree"
contains "$v" "closed form end.ux: max |this - moreau|" "verify compared the closed form"
contains "$v" "metric field.u_l2h1_rel" "verify compared the field metrics"
echo "$v" | sed 's/^/# /'

# GetFEM's Newmark (0.3025, 0.6) with Lagrange multipliers is moreau's newmark back end: the same
# discrete problem, solved by another program
"$MOREAU" run "$CASE" $SMALL --set time.dt=0.05 --solver newmark --out "$OUT/nm" --quiet
res=$($PY - "$G" "$OUT/nm/summary.json" <<'EOF'
import csv, json, sys
row = [r for r in csv.DictReader(open(sys.argv[1]))
       if r["solver"] == "getfem-newmark-multipliers-beta=0.3025-gamma=0.6" and float(r["dt"]) == 0.05][0]
s = json.load(open(sys.argv[2]))
pairs = [(row["field.u_l2l2_rel"], s["metrics"]["field"]["u_l2l2_rel"]),
         (row["field.v_l2l2_rel"], s["metrics"]["field"]["v_l2l2_rel"]),
         (row["field.u_l2h1_rel"], s["metrics"]["field"]["u_l2h1_rel"]),
         (row["energy.ratio"], s["energy"]["ratio"]),
         (row["contact.impulse"], s["metrics"]["contact"]["impulse"])]
worst = max(abs(float(a) - b) / abs(b) for a, b in pairs)
same = int(row["contact.status_flips"]) == s["metrics"]["contact"]["status_flips"]
print(0 if worst < 1e-6 and same else 1)
print("# worst relative difference %.2g; status flips %s and %d" % (worst, row["contact.status_flips"],
      s["metrics"]["contact"]["status_flips"]))
EOF
)
ok "$(echo "$res" | head -1)" "GetFEM Newmark-multipliers (0.3025, 0.6) = moreau newmark: field errors, energy, impulse to 1e-6"
echo "$res" | tail -n +2

"$MOREAU" compare "$CASE" --solvers nscd,newmark --dt 0.05,0.025 $SMALL --peer "$G" --out "$OUT/c6" -q
ok $? "compare --peer with GetFEM's rows"
r=$(cat "$OUT/c6/report.md")
contains "$r" "| getfem-massred-multipliers-dt0.025 (external) | getfem-massred-multipliers | 0.025 |" "report.md lists GetFEM's rows as external"
is "$(wc -l < "$OUT/c6/plots/work-precision-peer-getfem-newmark-nitsche.csv")" "2" "plot data: both time steps of a GetFEM scheme"
is "$(wc -l < "$OUT/c6/compare.csv")" "5" "compare.csv: moreau's four runs and its header"
done_testing
