#!/bin/sh
# test_plugin.sh: contact back ends built outside moreau (doc/backends.md). moreau is installed
# into a staging folder inside the build tree; the example back end (examples/backend-jacobi) is
# built against that installation's moreau.pc and loaded by file, by name and from a plug-in
# folder; its results are checked against nscd's and the closed forms on three scenes (a wrong or
# unconverged method fails them: the same runs stopped after 3 Jacobi iterations do); moreau
# compare runs it beside nscd; plug-ins with a wrong ABI, other struct sizes, no entry, an
# incomplete type, an option outside its parameters or a taken name are refused with a message.
. "$MOREAU_SRCDIR/tests/tap.sh"
: "${MOREAU_BUILDDIR:?MOREAU_BUILDDIR must point at the build tree}"
C="$MOREAU_SRCDIR/cases"
EX="$MOREAU_SRCDIR/examples/backend-jacobi"
W="$MOREAU_BUILDDIR/tests/out/plugin.$$"   # inside the build tree (make distcheck)
trap 'rm -rf "$OUT" "$W"' EXIT
mkdir -p "$W/plugins" "$W/bad"
export MOREAU_PLUGIN_PATH=""                # no folder unless a check names one
PYCMP="$MOREAU_SRCDIR/tests/plugin_check.py"
cmp_runs() { # cmp_runs A B TOL COLUMNS... : each line of plugin_check.py is one TAP result
  /usr/bin/python3 "$PYCMP" "$@" > "$OUT/cmp" 2>&1 || echo "1	plugin_check.py crashed: $(tail -1 "$OUT/cmp")" >> "$OUT/cmp"
  while IFS= read -r line; do
    case "$line" in
      [01]'	'*) ok "${line%%	*}" "${line#*	}" ;;
      *) echo "# $line" ;;
    esac
  done < "$OUT/cmp"
}

# 1. install into a staging folder of the build tree; the example against its moreau.pc
(unset MAKEFLAGS MFLAGS MAKELEVEL; ${MAKE:-make} -C "$MOREAU_BUILDDIR" install DESTDIR="$W/dest") > "$W/install.log" 2>&1
ran $? "$W/install.log" "make install DESTDIR=<build tree>/tests/out/...: exit 0"
pc=$(find "$W/dest" -name moreau.pc | head -1)
ok $(test -n "$pc" && test -f "$(dirname "$pc")/../../include/moreau/backend.h" -o -n "$(find "$W/dest" -path '*/include/moreau/backend.h')"; echo $?) \
  "moreau.pc and moreau/backend.h are installed"
export PKG_CONFIG_PATH="$(dirname "$pc")" PKG_CONFIG_SYSROOT_DIR="$W/dest"
PKGC=${PKG_CONFIG:-pkg-config}
contains "$($PKGC --cflags --libs moreau)" "-lmoreau" "pkg-config --cflags --libs moreau from the installed moreau.pc"
contains "$($PKGC --variable=plugindir moreau)" "/moreau/plugins" "moreau.pc names the plug-in folder (plugindir)"
mkdir -p "$W/jacobi"
(cd "$W/jacobi" && unset MAKEFLAGS MFLAGS MAKELEVEL && ${MAKE:-make} -f "$EX/Makefile" SRCDIR="$EX" \
   CFLAGS="-O2 -Wall -Wextra -Werror") > "$W/jacobi.log" 2>&1
ran $? "$W/jacobi.log" "examples/backend-jacobi builds against the installed moreau.pc, warnings as errors"
J="$W/jacobi/jacobi.so"
exports=$(nm -D --defined-only "$J" 2>/dev/null | awk '$2 ~ /[DRBT]/ {print $3}' | grep -v '^_' | tr '\n' ' ')
is "$exports" "mo_plugin_backend " "the plug-in exports one object, mo_plugin_backend"
cp "$J" "$W/plugins/"
CFL=$($PKGC --cflags moreau)
LIBS=$($PKGC --libs moreau)
cc -O1 -fPIC -shared $CFL -o "$W/plugins/bad-open.so" "$MOREAU_SRCDIR/tests/plugin_bad.c" $LIBS 2> "$W/bad.log"
ran $? "$W/bad.log" "a second valid plug-in (bad-open) builds"
for v in BAD_ABI BAD_SIZES NO_ENTRY NO_SOLVE BAD_OPTION CLASH NULL_TYPE BAD_SCHEMES; do
  cc -O1 -fPIC -shared -D$v $CFL -o "$W/bad/$v.so" "$MOREAU_SRCDIR/tests/plugin_bad.c" $LIBS 2>> "$W/bad.log" || echo "# $v did not build"
done
echo "not a shared object" > "$W/bad/TEXT.so"

# 2. loaded by file: list-solvers shows it with its options
out=$("$MOREAU" list-solvers --plugin "$J" 2>&1)
contains "$out" "jacobi     example plug-in: projected block Jacobi" "list-solvers --plugin FILE lists the back end"
contains "$out" "contact.jacobi.omega = 0" "and its options with their defaults"

# 2b. the Python module installed next to the library, with the installed library's folder
py=$(find "$W/dest" -name __init__.py -path '*/moreau/__init__.py' | head -1)
if [ -n "$MOREAU_PYTHON" ] && [ "$MOREAU_PYTHON" != ":" ]; then
  ok $(test -n "$py" && test -f "$(dirname "$py")/_lib.py" && test -f "$(dirname "$py")/readers.py"; echo $?) \
    "make install puts the Python module under the prefix (${py#$W/dest})"
  libdir=$(sed -n 's/^LIBDIR = "\(.*\)"$/\1/p' "$(dirname "$py")/_paths.py")
  ok $(test -n "$libdir" && test -f "$W/dest$libdir/libmoreau.so.0"; echo $?) "its _paths.py names the installed library's folder ($libdir)"
  if [ -z "$MOREAU_SANITIZERS" ] && "$MOREAU_PYTHON" -c 'import numpy' 2> /dev/null; then
    out=$(PYTHONPATH="$(dirname "$(dirname "$py")")" PYTHONDONTWRITEBYTECODE=1 MOREAU_LIBRARY="$W/dest$libdir/libmoreau.so.0" \
          "$MOREAU_PYTHON" -c 'import moreau, sys; print(moreau.__file__); print(" ".join(n for n, s in moreau.solvers(plugins=[sys.argv[1]])))' "$J" 2>&1)
    contains "$out" "$(dirname "$py")" "the installed module imports from the prefix"
    contains "$out" "nscd levelset newmark jacobi" "and lists the installed library's back ends and the plug-in"
  else
    echo "ok $((tap_n + 1)) - # SKIP the installed module is imported by test_python.sh's build (sanitizers or no numpy here)"; tap_n=$((tap_n + 1))
  fi
else
  echo "ok $((tap_n + 1)) - # SKIP configure found no Python: no module installed"; tap_n=$((tap_n + 1))
fi

# 3. two scenes against nscd and the closed forms
#    newton-cradle: touching disks, Moreau's law on both contacts at once: (-1/3, 2/3, 2/3) v0
for s in nscd jacobi; do
  "$MOREAU" run "$C/newton-cradle" --plugin "$J" --solver $s --set output.draw.gif=false --out "$W/nc-$s" --quiet 2> "$W/nc-$s.err"
  ran $? "$W/nc-$s.err" "newton-cradle by $s: exit 0"
done
cmp_runs exact "$W/nc-jacobi" 1e-7 b1.vx=-0.333333333333 b2.vx=0.666666666667 b3.vx=0.666666666667
cmp_runs same "$W/nc-nscd" "$W/nc-jacobi" 1e-6 b1.x b1.vx b2.x b2.vx b3.x b3.vx energy.total
#    cylinder-wall: an elastic cylinder on a wall, 32 candidates coupled through W (the mesh)
for s in nscd jacobi; do
  # (glibc fills fresh allocations with a pattern: a back end reading memory it never wrote fails)
  MALLOC_PERTURB_=165 "$MOREAU" run "$C/cylinder-wall" --plugin "$J" --solver $s --set time.end=4e-5 --set output.vtk.every=100000 \
    --out "$W/cw-$s" --quiet 2> "$W/cw-$s.err"
  ran $? "$W/cw-$s.err" "cylinder-wall (4e-5 s) by $s: exit 0"
done
cmp_runs same "$W/cw-nscd" "$W/cw-jacobi" 1e-6 bottom.uy bottom.vy bottom.pn bottom.gn energy.total contact.force_n
#    the same comparison fails a method stopped early: Jacobi cut at 3 iterations
"$MOREAU" run "$C/cylinder-wall" --plugin "$J" --solver "jacobi[max_iter=3;contact.on_failure=continue]" \
  --set time.end=4e-5 --set output.vtk.every=100000 --out "$W/cw-cut" --quiet 2> "$W/cw-cut.err"
ran $? "$W/cw-cut.err" "cylinder-wall by jacobi cut at 3 iterations (on_failure = continue): exit 0"
cmp_runs differ "$W/cw-nscd" "$W/cw-cut" 1e-3 bottom.vy bottom.pn
cmp_runs summary "$W/cw-jacobi" jacobi 1e-9

# 4. moreau compare with nscd, the plug-in found by name in MOREAU_PLUGIN_PATH: the sliding block
MOREAU_PLUGIN_PATH="$W/plugins" "$MOREAU" compare "$C/incline-block" --solvers nscd,jacobi --dt 2e-3,1e-3 \
  --set contact.pairs.[0].mu=0.2 --set reference.mu=0.2 --repeat 1 --out "$W/cmp" > "$W/cmp.out" 2> "$W/cmp.err"
ran $? "$W/cmp.err" "moreau compare incline-block --solvers nscd,jacobi (MOREAU_PLUGIN_PATH): exit 0"
contains "$(cat "$W/cmp.out")" "4 runs (" "compare: 4 runs"
cmp_runs compare "$W/cmp/compare.csv" nscd,jacobi 1e-9 block.x block.vx

# 5. loaded by name from a folder; a folder with refused plug-ins beside good ones
out=$(MOREAU_PLUGIN_PATH="/nonexistent:$W/plugins" "$MOREAU" list-solvers 2>&1)
contains "$out" "bad-open" "every plug-in of a MOREAU_PLUGIN_PATH folder is loaded (missing folders skipped)"
"$MOREAU" check "$C/ball-bounce" --plugin jacobi --solver jacobi > /dev/null 2> "$W/name.err"
is $? 2 "--plugin NAME without a folder holding NAME.so: exit 2"
contains "$(cat "$W/name.err")" "no jacobi.so in the plug-in folders" "and the message says where it looked"
MOREAU_PLUGIN_PATH="$W/bad" "$MOREAU" check "$C/ball-bounce" --plugin "$J" --solver jacobi --quiet 2> "$W/scan.err"
is $? 0 "a folder of refused plug-ins does not stop a run that needs none of them"
contains "$(cat "$W/scan.err")" "(skipped)" "each refused file is named on stderr"
MOREAU_PLUGIN_PATH="$W/bad" "$MOREAU" run "$C/ball-bounce" --solver bad-open --out "$W/x" 2> "$W/scan2.err"
is $? 2 "--solver naming a back end no plug-in provides: exit 2"
contains "$(cat "$W/scan2.err")" "plug-ins refused:" "and the message repeats why the folder's plug-ins were refused"
"$MOREAU" check "$C/ball-bounce" --plugin "$J" --set contact.jacobi.omeg=1 2> "$W/key.err"
contains "$(cat "$W/key.err")" "unknown key 'omeg' in 'contact.jacobi' (did you mean 'omega'?)" "a plug-in's options are validated like the shipped ones', with suggestions"
"$MOREAU" check "$C/ball-bounce" --plugin "$J" --solver "jacobi[omega=3]" 2> "$W/key.err"
contains "$(cat "$W/key.err")" "value 3 is out of range [0, 2]" "and their ranges (omega = 3 refused)"
contains "$("$MOREAU" keys --plugin "$J")" "contact.jacobi.max_iter" "moreau keys --plugin lists the plug-in's keys"

# 6. refused plug-ins, each with its reason
refused() { # refused FILE WORDS DESCRIPTION
  "$MOREAU" check "$C/ball-bounce" --plugin "$1" > /dev/null 2> "$W/err"
  st=$?
  is "$st" 2 "$3: exit 2"
  contains "$(cat "$W/err")" "$2" "$3: the message"
}
refused "$W/bad/BAD_ABI.so" "was built for version 2 of the back-end contract; this moreau has version 1" "another contract version"
refused "$W/bad/BAD_SIZES.so" "its mo_contact_problem has" "other struct sizes"
refused "$W/bad/NO_ENTRY.so" "exports no mo_plugin_backend" "no entry"
refused "$W/bad/NULL_TYPE.so" "names no back end" "an entry without a type"
refused "$W/bad/NO_SOLVE.so" "back end 'bad-open' has no solve" "a type without solve"
refused "$W/bad/BAD_OPTION.so" "option 'x' is stored at offset 8, outside its parameter struct of 8 bytes" "an option past the parameters"
refused "$W/bad/CLASH.so" "back end 'nscd' exists already (from this build)" "the name of a shipped back end"
refused "$W/bad/BAD_SCHEMES.so" "declares the schemes 0x0" "no time scheme"
refused "$W/bad/TEXT.so" "does not load" "a file that is no shared object"
refused "$W/nope.so" "no such file" "a missing file"
"$MOREAU" check "$C/ball-bounce" --plugin "$J" --plugin "$W/plugins/jacobi.so" 2> "$W/err"
contains "$(cat "$W/err")" "back end 'jacobi' exists already (from $J)" "two files with one back end name: the second is refused"
"$MOREAU" check "$C/ball-bounce" --plugin "$J" --plugin "$J" --quiet 2> "$W/err"
is $? 0 "the same file twice is loaded once"
done_testing
