#!/bin/sh
# test_cli.sh: the command line: help, version, check, run outputs, error messages, exit codes.
. "$MOREAU_SRCDIR/tests/tap.sh"

v=$("$MOREAU" --version); ok $? "--version exits 0"
contains "$v" "moreau " "--version prints the name and version"
h=$("$MOREAU" --help); contains "$h" "run CASE [--solver S]" "--help shows run"
"$MOREAU" frobnicate >/dev/null 2>&1; is $? 2 "unknown command: exit 2"
"$MOREAU" run >/dev/null 2>&1; is $? 2 "run without a case: exit 2"

c=$("$MOREAU" check "$MOREAU_SRCDIR/cases/wave-bar"); ok $? "check accepts wave-bar"
contains "$c" "ok" "check says ok"

# a misspelt key: FILE:LINE: unknown key
sed '0,/length = 1.0;/s//lenght = 1.0;/' "$MOREAU_SRCDIR/cases/wave-bar/case.cfg" > "$OUT/typo.cfg"
e=$("$MOREAU" check "$OUT/typo.cfg" 2>&1); is $? 2 "misspelt key: exit 2"
line=$(grep -n lenght "$OUT/typo.cfg" | cut -d: -f1)
is "$e" "$OUT/typo.cfg:$line: unknown key 'lenght' in 'bodies.[0].mesh' (did you mean 'length'?)" "misspelt key: FILE:LINE: unknown key"

e=$("$MOREAU" check "$MOREAU_SRCDIR/cases/wave-bar" --set time.dt=-1 2>&1); is $? 2 "bad --set: exit 2"
contains "$e" "--set time.dt=-1: key 'time.dt': value -1 is out of range" "bad --set named in the message"
e=$("$MOREAU" check "$OUT/missing" 2>&1); is $? 2 "missing case: exit 2"
contains "$e" "no such case file or folder" "missing case explained"

# run: outputs and their contents
r=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --out "$OUT/w" --set time.end=1.0); ok $? "run wave-bar"
contains "$r" "$OUT/w/history.csv" "run says where the outputs are"
ok $(test -s "$OUT/w/history.csv"; echo $?) "history.csv written"
is "$(head -1 "$OUT/w/history.csv")" "t,tip.ux,tip.vx,tip.fx,mid.ux,mid.vx,clamp.fx,tip.ux.exact,tip.vx.exact,mid.ux.exact,mid.vx.exact,energy.kinetic,energy.elastic,energy.total,energy.external_work,energy.support_work,energy.contact_work,energy.ratio" "history.csv header: t then probe.quantity columns"
is "$(wc -l < "$OUT/w/history.csv")" "202" "one row per step (200 steps) plus t = 0 and the header"
is "$(json "$OUT/w/summary.json" "d['status']")" "complete" "summary.json: status complete"
is "$(json "$OUT/w/summary.json" "d['settings']['time']['end']")" "1.0" "summary.json: settings after overrides"
is "$(json "$OUT/w/summary.json" "d['linear_solver']['factorizations']")" "1" "summary.json: one factorization for a linear scene"
ok $(json "$OUT/w/summary.json" "0 if d['metrics']['tip.ux']['l2_rel'] < 0.01 else 1") "summary.json: tip.ux error against d'Alembert below 1%"
ok $(json "$OUT/w/summary.json" "0 if d['timings']['solve'] > 0 and d['timings']['calls']['solve'] == 400 else 1") "summary.json: per-phase timings and calls"
l=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --out "$OUT/w2" --set time.end=0.1 --log --quiet 2>&1)
contains "$l" "work this scene did not need:" "--log prints the skipped work"
contains "$l" "factor" "--log prints the timing table"
q=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --out "$OUT/w3" --set time.end=0.1 --quiet 2>&1)
is "$q" "" "--quiet prints nothing"

# fields
"$MOREAU" run "$MOREAU_SRCDIR/cases/plate-vibration" --out "$OUT/p" --quiet --set time.end=0.005; ok $? "run plate-vibration"
n=$(grep -c "<DataSet" "$OUT/p/fields.pvd"); is "$n" "3" "fields.pvd lists frames 0, 50 and the last step"
ok $(grep -q 'Name="von_mises"' "$OUT/p/fields_plate_00001.vtu"; echo $?) "vtu holds the von Mises field"
if /usr/bin/python3 -c "import vtkmodules.vtkIOXML" 2>/dev/null; then
  /usr/bin/python3 -c "import sys; sys.path.insert(0, sys.argv[2]); import vtkread; p, c, a = vtkread.read(sys.argv[1]); sys.exit(0 if (p, c) == (205, 160) and a['von_mises'][0] == 1 else 1)" \
    "$OUT/p/fields_plate_00002.vtu" "$MOREAU_SRCDIR/tests"
  ok $? "the vtu is read by VTK: 205 nodes, 160 cells (40 x 4 Q4), von Mises"
else
  ok 0 "# SKIP python3-vtk9 is not installed: the vtu is not read back"
fi

k=$("$MOREAU" keys | wc -l); ok $([ "$k" -gt 50 ] && echo 0 || echo 1) "keys lists the schema ($k keys)"
s=$("$MOREAU" list-solvers); ok $? "list-solvers exits 0"

# every command's --help: exit 0, its usage, and every option it lists in the man page
man=$(sed 's/\\-/-/g; s/\\f[BIRP]//g' "$MOREAU_SRCDIR/doc/moreau.1")
for c in run check compare bench-local list-solvers keys; do
  h=$("$MOREAU" $c --help); ok $? "$c --help exits 0"
  is "$(printf '%s\n' "$h" | head -1 | cut -d' ' -f1-3)" "usage: moreau $c" "$c --help: its usage first"
  missing=""
  for o in $(printf '%s\n' "$h" | grep -o -- '--[a-z][a-z-]*' | sort -u); do
    case "$man" in *"$o"*) ;; *) missing="$missing $o" ;; esac
  done
  is "$missing" "" "$c --help: every option it lists is in moreau(1)"
  is "$("$MOREAU" help $c)" "$h" "moreau help $c is $c --help"
done
contains "$man" ".BI --dump-fclib \" DIR\"" "moreau(1) documents --dump-fclib DIR"
contains "$("$MOREAU" run --help)" "--dump-fclib DIR" "run --help explains --dump-fclib"
contains "$("$MOREAU" compare --help)" "--penetration-tol F" "compare --help explains --penetration-tol"
"$MOREAU" check --help --nosuch > /dev/null 2>&1; is $? 0 "--help wins over what follows"

# --opt=value and --opt value, options before and after the case, short options: one run
"$MOREAU" run --quiet --set=time.end=0.1 --out="$OUT/eq" "$MOREAU_SRCDIR/cases/wave-bar"; ok $? "run --opt=value, options before the case"
"$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" -s time.end=0.1 -o "$OUT/sp" -q; ok $? "run -s VALUE -o DIR -q after the case"
ok $(cmp -s "$OUT/eq/history.csv" "$OUT/sp/history.csv"; echo $?) "the same history either way"
"$MOREAU" run --qu --out "$OUT/pre" --set time.end=0.1 -- "$MOREAU_SRCDIR/cases/wave-bar"; ok $? "a unique prefix of a long option (--qu), -- before the case"
"$MOREAU" compare "$MOREAU_SRCDIR/cases/bar-obstacle" --solvers=nscd --dt=0.01 --set=time.end=0.1 --repeat=1 --out="$OUT/cmp" -q
ok $? "compare --solvers=nscd --dt=0.01 --repeat=1 --out=DIR"
is "$(grep -c '^nscd,' "$OUT/cmp/compare.csv")" "1" "compare ran the one cell asked"

# errors: exit 2 and a message naming the option
e=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --solver 2>&1); is $? 2 "a missing value: exit 2"
contains "$e" "moreau run: --solver needs S: contact back end" "a missing value: the option and what it takes"
e=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --log=yes 2>&1); is $? 2 "a value given to a flag: exit 2"
contains "$e" "--log takes no value ('--log=yes')" "a value given to a flag: said"
contains "$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --quiet=1 2>&1)" "--quiet takes no value ('--quiet=1')" "the same for a flag with a short letter"
e=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --bogus 2>&1); is $? 2 "an unknown option: exit 2"
contains "$e" "unknown option '--bogus' (moreau run --help lists the options)" "an unknown option: named, and where to look"
e=$("$MOREAU" compare "$MOREAU_SRCDIR/cases/wave-bar" --s nscd 2>&1); is $? 2 "an ambiguous prefix: exit 2"
contains "$e" "'--s' is ambiguous: --solvers, --set" "an ambiguous prefix: the options it could be"
e=$("$MOREAU" compare "$MOREAU_SRCDIR/cases/wave-bar" --dt 0.01,-1 2>&1); is $? 2 "compare --dt with a negative step: exit 2"
contains "$e" "--dt: '-1' is not a positive time step" "compare --dt: the bad value named"
e=$("$MOREAU" check "$MOREAU_SRCDIR/cases/wave-bar" --out "$OUT/x" 2>&1); is $? 2 "check takes no --out"
e=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" "$MOREAU_SRCDIR/cases/rods-1d" 2>&1); is $? 2 "two cases: exit 2"
contains "$e" "one case at a time" "two cases: said"
e=$("$MOREAU" help nosuch 2>&1); is $? 2 "help on an unknown command: exit 2"

# a missing set: the error lists the sets the body has
cw="$MOREAU_SRCDIR/cases/cylinder-wall"
e=$("$MOREAU" check "$cw" --set 'contact.pairs.wall.slave_set="botom"' 2>&1); is $? 2 "a missing slave set: exit 2"
contains "$e" "body 'cylinder' has no node or facet set 'botom' (its node sets: boundary, right_point, top_point, left_point, bottom_point, all)" \
  "a missing slave set: the sets the body has"
e=$("$MOREAU" check "$cw" --set 'contact.pairs.wall.master_set="tp"' 2>&1); is $? 2 "a missing master set: exit 2"
contains "$e" "body 'wall' has no facet set 'tp' (its facet sets: xmin, left, xmax, right, ymin, bottom, ymax, top)" \
  "a missing master set: the facet sets the body has"
e=$("$MOREAU" check "$cw" --set 'output.probes.bottom.set="botom"' 2>&1)
contains "$e" "no node set 'botom' in this mesh (sets: boundary," "a probe's missing set: the sets"

# the end of a run names the files written, fields.pvd and contact.csv among them
r=$("$MOREAU" run "$cw" --set time.end=3e-5 --set 'output.contact_history={}' --out "$OUT/cw"); ok $? "run cylinder-wall to 30 us"
for f in history.csv summary.json contact.csv contact_history.csv fields.pvd contact_points.pvd planes.pvd; do
  contains "$r" "$OUT/cw/$f" "the end of the run names $f"
  ok $(test -s "$OUT/cw/$f"; echo $?) "$f is there"
done
contains "$r" "ParaView: 4 frames (paraview $OUT/cw/fields.pvd)" "the end of the run says how to open the series"
r=$("$MOREAU" run "$MOREAU_SRCDIR/cases/wave-bar" --set time.end=0.1 --out "$OUT/wb")
contains "$r" "outputs: $OUT/wb/history.csv, $OUT/wb/summary.json" "a run without contact or fields names history.csv and summary.json"
case "$r" in *contact.csv*|*fields.pvd*) ok 1 "and no file it did not write" ;; *) ok 0 "and no file it did not write" ;; esac

# make install puts the documentation under share/doc/moreau and the man page under man1
b=$(dirname "$MOREAU")
if [ -f "$b/Makefile" ]; then
  make -s -C "$b" install-dist_docDATA install-dist_teachingDATA install-man DESTDIR="$OUT/inst" > "$OUT/inst.log" 2>&1
  ok $? "make install of the documentation (DESTDIR)"
  for f in README.md architecture.md case-format.md theory.md teaching.md teaching/ball-bounce.png; do
    n=$(find "$OUT/inst" -path "*/share/doc/moreau/$f" | wc -l); is "$n" "1" "installed: share/doc/moreau/$f"
  done
  is "$(find "$OUT/inst" -path '*/man1/moreau.1' | wc -l)" "1" "installed: man1/moreau.1"
else
  ok 0 "# SKIP no build folder beside $MOREAU: make install not tried"
fi
done_testing
