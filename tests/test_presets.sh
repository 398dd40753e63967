#!/bin/sh
# test_presets.sh: formulations, not only solvers (src/preset.c, doc/theory.md §10.2): the papers'
# presets set what their papers say, the bracket makes any --set a labelled entry of its own, and
# the formulations differ where theory says they must.
. "$MOREAU_SRCDIR/tests/tap.sh"
cw="$MOREAU_SRCDIR/cases/cylinder-wall"

l=$("$MOREAU" list-solvers)
for p in levelset:bdz07 nscd:jean88 nscd:jean88-weighted newmark:bdz07; do contains "$l" "$p" "list-solvers names $p"; done

# what each preset sets, read back from summary.json's settings (the case after every override)
run() { # run LABEL SPEC [--set ...]
  lab=$1; spec=$2; shift 2
  "$MOREAU" run "$cw" --solver "$spec" --set time.dt=4e-6 --set time.end=8e-5 --out "$OUT/$lab" --quiet "$@"
}
run jean "nscd:jean88"; ok $? "cylinder-wall runs with nscd:jean88"
run bdz "levelset:bdz07"; ok $? "cylinder-wall runs with levelset:bdz07"
run nmk "newmark:bdz07"; ok $? "cylinder-wall runs with newmark:bdz07"
run weighted "nscd:jean88-weighted"; ok $? "cylinder-wall runs with nscd:jean88-weighted"
s() { json "$OUT/$1/summary.json" "$2"; }
is "$(s jean "d['settings']['contact']['signorini'], d['settings']['time']['theta'], d['settings']['contact']['solver']")" "position 1.0 nscd" "nscd:jean88: J88 (3.2)_1 at the position level, theta = 1"
is "$(s weighted "d['settings']['contact']['reactions']")" "weighted" "nscd:jean88-weighted: P-weighted reactions"
is "$(s bdz "d['settings']['contact']['signorini'], d['settings']['time']['theta_f'], d['settings']['contact']['levelset']['k_n']")" "velocity 1.0 0.0" "levelset:bdz07: Signorini-Moreau, theta_f = 1, k_n = 0"
is "$(s nmk "d['settings']['contact']['newmark']['beta'], d['settings']['contact']['newmark']['gamma']")" "0.4 0.7" "newmark:bdz07 on the cylinder: BDZ07 Fig. 5's (0.4, 0.7), from the case's presets entry"

# the formulations differ where theory says: the velocity-level law holds [v_n] = 0 on the closed
# candidates to round-off; the position-level one holds the gap and lets a node arrive with
# U_n = -g/h; the Newmark baseline's contact node bounces (its spurious oscillations)
ok $(s bdz "0 if d['metrics']['contact']['max_vn_in_contact'] < 1e-9 else 1") "levelset:bdz07: |[v_n]| while closed below 1e-9 m/s ($(s bdz "'%.2g' % d['metrics']['contact']['max_vn_in_contact']"))"
ok $(s jean "0 if 1e-6 < d['metrics']['contact']['max_vn_in_contact'] < 1 and d['metrics']['contact']['max_penetration'] < 1e-8 else 1") "nscd:jean88: |[v_n]| while closed 1e-6..1 m/s, penetration below 1e-8 m ($(s jean "'%.2g, %.2g' % (d['metrics']['contact']['max_vn_in_contact'], d['metrics']['contact']['max_penetration'])"))"
ok $(s nmk "0 if d['metrics']['contact']['max_vn_in_contact'] > 10 else 1") "newmark:bdz07: the contact node bounces at more than 10 m/s ($(s nmk "'%.3g' % d['metrics']['contact']['max_vn_in_contact']"))"
ok $(json "$OUT/jean/summary.json" "0 if abs(d['energy']['ratio'] - $(s bdz "d['energy']['ratio']")) > 1e-3 else 1") "nscd:jean88 and levelset:bdz07 end with different energies ($(s jean "'%.4f' % d['energy']['ratio']") against $(s bdz "'%.4f' % d['energy']['ratio']"))"

# the bracket: any --set makes an entry, and it wins over the preset and over --set
run br "levelset:bdz07[theta=0.5;theta_f=0.5]" --set time.theta=0.7; ok $? "levelset:bdz07[theta=0.5;theta_f=0.5] runs"
is "$(s br "d['settings']['time']['theta'], d['settings']['time']['theta_f']")" "0.5 0.5" "the bracket wins over the preset and --set"
run br2 "nscd[tol=1e-10,max_sweeps=50]"; ok $? "nscd[tol=1e-10,max_sweeps=50]: bare back-end keys"
is "$(s br2 "d['settings']['contact']['nscd']['tol'], d['settings']['contact']['nscd']['max_sweeps']")" "1e-10 50" "bare keys resolve to contact.nscd.*"

# compare: each spec is its own labelled row and folder
"$MOREAU" compare "$cw" --solvers 'nscd,nscd[theta=0.5],nscd:jean88' --dt 4e-6 --set time.end=4e-5 --out "$OUT/cmp" --quiet 2>/dev/null
ok $? "compare --solvers nscd,nscd[theta=0.5],nscd:jean88"
is "$(cut -d, -f1 "$OUT/cmp/compare.csv" | tail -n +2 | tr '\n' ' ')" "nscd nscd[theta=0.5] nscd:jean88 " "compare.csv: one row per spec, labelled by it"
ok $(test -d "$OUT/cmp/runs/nscd_theta_0.5-dt4e-06" && test -d "$OUT/cmp/runs/nscd-jean88-dt4e-06"; echo $?) "run folders without ':' or brackets"

# errors name the spec
e=$("$MOREAU" check "$cw" --solver nscd:foo 2>&1); is $? 2 "unknown preset: exit 2"
contains "$e" "--solver nscd:foo: no preset 'nscd:foo'" "unknown preset named"
e=$("$MOREAU" check "$cw" --solver 'nscd[thta=0.5]' 2>&1); is $? 2 "unknown bracket key: exit 2"
contains "$e" "unknown key 'thta'" "unknown bracket key named"
e=$("$MOREAU" check "$MOREAU_SRCDIR/cases/bar-obstacle" --solver newmark:bdz07 2>&1); is $? 2 "newmark:bdz07 on a case without the paper's values: exit 2"
contains "$e" "the case gives no parameters for 'newmark:bdz07'" "newmark:bdz07 asks for the case's values"
e=$("$MOREAU" check "$cw" --solver 'nscd[theta=2]' 2>&1); is $? 2 "out-of-range bracket value: exit 2"
contains "$e" "--solver nscd[theta=2]:" "out-of-range bracket value names the spec"
done_testing
