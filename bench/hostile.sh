#!/bin/bash
# hostile.sh: the hostile campaign of issue 19 ("outputs that never lie"): inputs beyond
# tests/bad, across case files, meshes, FCLIB files and command lines, each with what an honest
# program does with it:
#   refuse  a non-zero exit below 128 (no crash), a message on stderr, and no output that lies
#           (no summary.json saying "complete", no nan or inf in history.csv), within 15 s
#   run     exit 0, and no nan or inf in history.csv or summary.json
#   fast    refuse, in under 1 s and 100 MB (/usr/bin/time)
# Prints one line per input and the counts; the number of dishonest outcomes is the figure of
# the issue's closing note.
#   bench/hostile.sh [MOREAU [FCLIB_WRITER]]
# MOREAU: the program (default build/moreau); FCLIB_WRITER: tests/test_fclib_bad, which writes
# the hostile FCLIB files into a folder (default build/tests/test_fclib_bad; without it the FCLIB
# inputs are skipped). Every command runs under a 4 GB address-space limit and a 15 s timeout.
set -u
SRC=$(cd "$(dirname "$0")/.." && pwd)
M=${1:-$SRC/build/moreau}
FW=${2:-$SRC/build/tests/test_fclib_bad}
T=$(mktemp -d "${TMPDIR:-/tmp}/hostile.XXXXXX")
trap 'rm -rf "$T"' EXIT
W=$SRC/cases/wave-bar
CW=$SRC/cases/cylinder-wall
PV=$SRC/cases/plate-vibration
BB=$SRC/cases/ball-bounce
n=0 bad=0

# t NAME CLASS OUTDIR -- COMMAND...: run it, judge it
t() {
  local name=$1 cls=$2 out=$3 rc verdict=ok why="" e s kb
  shift 4
  n=$((n + 1))
  /usr/bin/time -f "%e %M" -o "$T/time" timeout -s KILL 15 bash -c 'ulimit -v 4000000; exec "$@"' _ "$@" \
    > /dev/null 2> "$T/err"
  rc=$?
  read -r s kb < <(tail -1 "$T/time" 2> /dev/null) || true
  s=${s:-99}
  kb=${kb:-0}
  case "$s" in *[!0-9.]*) s=99 ;; esac
  case "$kb" in *[!0-9]*) kb=0 ;; esac
  e=$(grep -av '^Command' "$T/err" | head -c 300 | tr '\n' ' ')
  if [ $rc -ge 124 ]; then
    verdict=BAD why="timeout or crash (exit $rc)"
  elif [ "$cls" = run ]; then
    [ $rc -ne 0 ] && verdict=BAD why="exit $rc"
  else
    if [ $rc -eq 0 ]; then verdict=BAD why="accepted (exit 0)"
    elif [ -z "$e" ]; then verdict=BAD why="no message"
    fi
    if [ "$cls" = fast ] && [ $verdict = ok ]; then
      awk -v s="$s" -v k="$kb" 'BEGIN { exit !(s < 1 && k < 100000) }' || { verdict=BAD why="refused late (${s} s, ${kb} kB)"; }
    fi
  fi
  if [ -n "$out" ] && [ $verdict = ok ]; then
    if [ -f "$out/history.csv" ] && grep -aqiE '(^|,)-?(nan|inf)' "$out/history.csv"; then verdict=BAD why="nan/inf in history.csv"
    elif [ -f "$out/summary.json" ] && [ "$cls" != run ] && grep -q '"status": "complete"' "$out/summary.json"; then
      verdict=BAD why="summary.json says complete"
    elif [ -f "$out/summary.json" ] && grep -qiE ': -?(nan|inf)' "$out/summary.json"; then verdict=BAD why="nan in summary.json"
    fi
  fi
  [ $verdict = BAD ] && bad=$((bad + 1))
  printf '%-3d %-4s %-34s %-6s exit %-3s %5ss %7skB  %s\n' $n $verdict "$name" "$cls" $rc "$s" "$kb" "${why:-${e:0:110}}"
}


echo "# hostile campaign: $M"
# --- case files: non-finite values reached through the data (run) -------------------------------------
t load-1e300            refuse "$T/o1"  -- "$M" run "$W" -q --out "$T/o1" --set 'bodies.bar.loads=({ type = "nodal"; set = "right"; value = [1.0e300]; })'
t load-1e200            refuse "$T/o2"  -- "$M" run "$W" -q --out "$T/o2" --set 'bodies.bar.loads=({ type = "nodal"; set = "right"; value = [1.0e200]; })'
t body-force-1e308      refuse "$T/o3"  -- "$M" run "$W" -q --out "$T/o3" --set 'bodies.bar.body_force=[1.0e308]'
t body-force-1e160-2d   refuse "$T/o4"  -- "$M" run "$PV" -q --out "$T/o4" --set 'bodies.plate.body_force=[0.0, 1.0e160]'
t amplitude-exp1000t    refuse "$T/o5"  -- "$M" run "$W" -q --out "$T/o5" --set 'bodies.bar.loads=({ type = "nodal"; set = "right"; value = [1.0]; amplitude = "exp(1000*t)"; })'
t amplitude-exp200t     refuse "$T/o6"  -- "$M" run "$W" -q --out "$T/o6" --set 'bodies.bar.loads=({ type = "nodal"; set = "right"; value = [1.0]; amplitude = "exp(200*t)"; })'
t amplitude-pole        refuse "$T/o7"  -- "$M" run "$W" -q --out "$T/o7" --set 'bodies.bar.loads=({ type = "nodal"; set = "right"; value = [1.0]; amplitude = "1/(t-0.5)^200"; })'
t velocity-1e300        refuse "$T/o8"  -- "$M" run "$W" -q --out "$T/o8" --set 'bodies.bar.initial.velocity=["1e300"]'
t velocity-1e200        refuse "$T/o9"  -- "$M" run "$W" -q --out "$T/o9" --set 'bodies.bar.initial.velocity=["1e200"]'
t displacement-1e200    refuse "$T/o10" -- "$M" run "$W" -q --out "$T/o10" --set 'bodies.bar.initial.displacement=["1e200 * x"]'
t contact-velocity-1e200 refuse "$T/o11" -- "$M" run "$CW" -q --out "$T/o11" --set time.end=2e-5 --set 'bodies.cylinder.initial.velocity=[0.0, -1.0e200]'
t rigid-force-1e308     refuse "$T/o12" -- "$M" run "$BB" -q --out "$T/o12" --set 'bodies.ball.body_force=[0.0, -1.0e308]'
t rigid-velocity-1e200  refuse "$T/o13" -- "$M" run "$BB" -q --out "$T/o13" --set 'bodies.ball.velocity=[0.0, -1.0e200]'
t energy-zero           run    "$T/o14" -- "$M" run "$W" -q --out "$T/o14" --set 'bodies.bar.initial.displacement=["0"]' --set time.end=0.5
t energy-zero-plate     run    "$T/o15" -- "$M" run "$PV" -q --out "$T/o15" --set 'bodies.plate.initial.velocity=["0", "0"]' --set time.end=0.001
# --- case files: constants and time steps ---------------------------------------------------------------
t E-1e300-finite        run    "$T/o16" -- "$M" run "$W" -q --out "$T/o16" --set bodies.bar.material.E=1e300
t rho-subnormal         refuse "$T/o17" -- "$M" run "$W" -q --out "$T/o17" --set bodies.bar.material.rho=1e-310
t E-subnormal           refuse ""       -- "$M" check "$W" --set bodies.bar.material.E=1e-320
t area-subnormal        refuse ""       -- "$M" check "$W" --set bodies.bar.material.area=5e-324
t dt-1e300              refuse "$T/o18" -- "$M" run "$W" -q --out "$T/o18" --set time.dt=1e300
t dt-1e300-check        refuse ""       -- "$M" check "$W" --set time.dt=1e300
t dt-20-end-8           refuse ""       -- "$M" check "$W" --set time.dt=20.0
t dt-subnormal          refuse ""       -- "$M" check "$W" --set time.dt=1e-320
t cylinder-E-1e30       refuse "$T/o19" -- "$M" run "$CW" -q --out "$T/o19" --set time.end=1e-5 --set bodies.cylinder.material.E=1e30
t cylinder-rho-1e-300   refuse "$T/o20" -- "$M" run "$CW" -q --out "$T/o20" --set time.end=1e-5 --set bodies.cylinder.material.rho=1e-300
t pair-set-itself       refuse ""       -- "$M" check "$CW" --set 'contact.pairs.wall.master="cylinder"' --set 'contact.pairs.wall.master_set="boundary"'
printf 'title = "r\xe9sultat";\n' > "$T/latin1.cfg"; sed 1,2d "$W/case.cfg" >> "$T/latin1.cfg"
t title-latin1          refuse ""       -- "$M" check "$T/latin1.cfg"
printf 'title = "\xf4\x90\x80\x80";\n' > "$T/cp.cfg"; sed 1,2d "$W/case.cfg" >> "$T/cp.cfg"
t title-past-U+10FFFF   refuse ""       -- "$M" check "$T/cp.cfg"
t probe-name-latin1     refuse ""       -- "$M" check "$W" --set "output.probes.tip.name=\"t$(printf '\xe9')te\""
python3 -c "import sys; open(sys.argv[1], 'w').write('title = \"' + 'x' * 4000000 + '\";\n')" "$T/huge.cfg"
t case-4MB-string       fast   ""       -- "$M" check "$T/huge.cfg"
python3 -c "import sys; open(sys.argv[1], 'w').write('# ' + 'y' * 3000000 + '\n')" "$T/comment.cfg"
t case-3MB-comment      fast   ""       -- "$M" check "$T/comment.cfg"
t case-dev-zero         fast   ""       -- "$M" check /dev/zero
mkfifo "$T/fifo.cfg"
t case-fifo             fast   ""       -- "$M" check "$T/fifo.cfg"
# --- sizes -----------------------------------------------------------------------------------------------
cat > "$T/disk.cfg" << 'EOF'
bodies = ( { name = "d"; mesh = { generator = "disk"; radius = 1.0; core = 10000; rings = 10000; }; material = { E = 1.0; nu = 0.3; rho = 1.0; hypothesis = "plane_strain"; }; } );
time = { scheme = "theta"; theta = 0.5; dt = 0.01; end = 0.1; };
EOF
t disk-10^4x10^4        fast   ""       -- "$M" check "$T/disk.cfg"
t disk-10^4x10^4-run    fast   "$T/o21" -- "$M" run "$T/disk.cfg" -q --out "$T/o21"
t disk-core-10^4        fast   ""       -- "$M" check "$T/disk.cfg" --set bodies.d.mesh.rings=1
t rectangle-10^7        fast   ""       -- "$M" check "$PV" --set 'bodies.plate.mesh.elements=[10000, 1000]'
t rectangle-9e6-4GB     fast   ""       -- "$M" check "$PV" --set 'bodies.plate.mesh.elements=[3000, 3000]'
t rectangle-T3-2e7      fast   ""       -- "$M" check "$PV" --set 'bodies.plate.mesh.elements=[3200, 3200]' --set 'bodies.plate.mesh.element="T3"'
t box-9e6               fast   ""       -- "$M" check "$SRC/cases/rods-3d" --set 'bodies.left.mesh.elements=[300, 300, 100]'
t box-two-bodies        fast   ""       -- "$M" check "$SRC/cases/rods-3d" --set 'bodies.left.mesh.elements=[200, 100, 100]' --set 'bodies.right.mesh.elements=[200, 100, 100]'
t rectangle-4500x2300-run fast  "$T/o22" -- "$M" run "$PV" -q --out "$T/o22" --set 'bodies.plate.mesh.elements=[4500, 2300]'
# --- meshes ------------------------------------------------------------------------------------------------
G=$SRC/tests/meshes/plate-q4-v22.msh
mcase() { # mcase MSH [KEY=VALUE]: a case reading MSH
  printf 'bodies = ( { name = "plate"; mesh = { file = "%s"; %s }; material = { E = 1.0; nu = 0.3; rho = 1.0; hypothesis = "plane_strain"; }; fix = ( { set = "bottom"; } ); } );\ntime = { scheme = "theta"; theta = 0.5; dt = 0.01; end = 0.1; };\n' "$1" "${2:-}"
}
sed 's/^1 3 "top"/1 3 "bottom"/' "$G" > "$T/same.msh"; mcase same.msh > "$T/same.cfg"
t msh-two-groups-one-name refuse ""     -- "$M" check "$T/same.cfg"
sed 's/^1 4 "left"/1 4 "right"/' "$G" > "$T/same2.msh"; mcase same2.msh > "$T/same2.cfg"
t msh-left-named-right  refuse ""       -- "$M" check "$T/same2.cfg"
sed 's/"origin"/"plate"/' "$G" > "$T/same3.msh"; mcase same3.msh > "$T/same3.cfg"
t msh-point-and-surface-ok run  ""      -- "$M" check "$T/same3.cfg"
cp "$G" "$T/g.msh"; mcase g.msh 'scale = 1.0e300;' > "$T/scale.cfg"
t msh-scale-1e300       refuse ""       -- "$M" check "$T/scale.cfg"
mcase g.msh 'scale = 1.0e200;' > "$T/scale2.cfg"
t msh-scale-1e200       refuse ""       -- "$M" check "$T/scale2.cfg"
mcase g.msh 'translate = [1.0e300, 0.0];' > "$T/tr.cfg"
t msh-translate-1e300   refuse ""       -- "$M" check "$T/tr.cfg"
awk 'NR == 16 { $2 = "1e308" } { print }' "$G" > "$T/big.msh"; mcase big.msh > "$T/big.cfg"
t msh-coordinate-1e308  refuse ""       -- "$M" check "$T/big.cfg"
truncate -s 2G "$T/sparse.msh"; mcase sparse.msh > "$T/sparse.cfg"
t msh-2GB-file          fast   ""       -- "$M" check "$T/sparse.cfg"
mkdir "$T/dir.msh"; mcase dir.msh > "$T/dirmsh.cfg"
t msh-a-folder          refuse ""       -- "$M" check "$T/dirmsh.cfg"
mkfifo "$T/fifo.msh"; mcase fifo.msh > "$T/fifomsh.cfg"
t msh-fifo              fast   ""       -- "$M" check "$T/fifomsh.cfg"
# --- FCLIB files ----------------------------------------------------------------------------------------------
if [ -x "$FW" ]; then
  mkdir "$T/fclib" && "$FW" "$T/fclib" 2> /dev/null
  for f in "$T"/fclib/*.hdf5; do
    t "fclib-$(basename "$f" .hdf5)" refuse "" -- "$M" bench-local "$f" --min-time 0.01
  done
fi
printf 'not hdf5\n' > "$T/x.hdf5"
t fclib-not-hdf5        refuse ""       -- "$M" bench-local "$T/x.hdf5"
# --- command lines ---------------------------------------------------------------------------------------------
t compare-metric-nosuch refuse ""       -- "$M" compare "$W" -q --metric nosuch --dt 0.01 --set time.end=0.1 --out "$T/c1"
t compare-solvers-commas refuse ""      -- "$M" compare "$W" -q --solvers ,,, --out "$T/c2"
t compare-solvers-17    refuse ""       -- "$M" compare "$W" -q --solvers nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd,nscd --out "$T/c3"
t out-path-6000-chars   refuse ""       -- "$M" run "$W" -q --out "$(printf 'a/%.0s' $(seq 3000))"
t out-name-300-chars    refuse ""       -- "$M" run "$W" -q --out "$T/$(printf 'b%.0s' $(seq 300))"
t out-is-a-file         refuse ""       -- "$M" run "$W" -q --out "$T/latin1.cfg"
t set-dt-nan            refuse ""       -- "$M" check "$W" --set time.dt=nan
t set-title-latin1      refuse ""       -- "$M" check "$W" --set "title=\"$(printf '\xff')\""
# two runs on one folder at once
"$M" run "$W" -q --out "$T/two" --set time.end=1.0e6 2> /dev/null &
pid=$!
for i in $(seq 100); do [ -s "$T/two/history.csv" ] && break; sleep 0.05; done
t second-run-same-out   refuse ""       -- "$M" run "$W" -q --out "$T/two"
kill -INT $pid 2> /dev/null; wait $pid 2> /dev/null
# kill -9 into a complete folder: the old summary must not stay "complete"
"$M" run "$W" -q --out "$T/k9" > /dev/null 2>&1
"$M" run "$W" -q --out "$T/k9" --set time.dt=2.0e-5 --set 'output.vtk={every=5;}' 2> /dev/null &
pid=$!
for i in $(seq 100); do [ "$(wc -l < "$T/k9/history.csv")" -gt 3 ] && break; sleep 0.05; done
sleep 0.3; kill -9 $pid; wait $pid 2> /dev/null
n=$((n + 1))
if grep -q '"status": "complete"' "$T/k9/summary.json" 2> /dev/null || ls -a "$T/k9" | grep -q '\.tmp\.'; then
  bad=$((bad + 1)); printf '%-3d BAD  %-34s old "complete" summary or temporaries beside partial files\n' $n kill-9-into-complete
else printf '%-3d ok   %-34s\n' $n kill-9-into-complete; fi
# a full disk: a 400 kB tmpfs in a user namespace
cat > "$T/full.sh" << EOF
mkdir -p "$T/mnt" && mount -t tmpfs -o size=400k none "$T/mnt" || exit 77
"$M" run "$W" -q --out "$T/mnt/o" > /dev/null 2>&1
"$M" run "$W" -q --out "$T/mnt/o" --set time.dt=2.5e-4 --set 'output.vtk={}' > /dev/null 2>&1
echo \$? > "$T/full.rc"
grep -c '"status": "complete"' "$T/mnt/o/summary.json" > "$T/full.st" 2> /dev/null
ls -a "$T/mnt/o" | grep -c '\.tmp\.' > "$T/full.tmp"
exit 0
EOF
if unshare -r -m bash "$T/full.sh" 2> /dev/null; then
  n=$((n + 1))
  if [ "$(cat "$T/full.rc")" != 1 ] || [ "$(cat "$T/full.st" 2> /dev/null || echo 0)" != 0 ] || [ "$(cat "$T/full.tmp")" != 0 ]; then
    bad=$((bad + 1)); printf '%-3d BAD  %-34s exit %s, complete summaries %s, temporaries %s\n' $n disk-full "$(cat "$T/full.rc")" "$(cat "$T/full.st")" "$(cat "$T/full.tmp")"
  else printf '%-3d ok   %-34s exit 1, no complete summary, no temporary\n' $n disk-full; fi
fi
# SIGINT while building a large mesh
"$M" run "$W" -q --out "$T/int" --set bodies.bar.mesh.elements=4000000 2> "$T/int.err" &
pid=$!
sleep 1; kill -INT $pid; s0=$(date +%s.%N); wait $pid; rc=$?; s1=$(date +%s.%N)
n=$((n + 1))
if [ $rc -eq 0 ] || ! grep -q interrupted "$T/int.err" || awk -v a="$s0" -v b="$s1" 'BEGIN { exit !(b - a > 2) }'; then
  bad=$((bad + 1)); printf '%-3d BAD  %-34s exit %s after %.1f s: %s\n' $n sigint-while-building $rc "$(echo "$s1 - $s0" | bc)" "$(head -c 100 "$T/int.err")"
else printf '%-3d ok   %-34s exit %s after %.1f s\n' $n sigint-while-building $rc "$(echo "$s1 - $s0" | bc)"; fi

echo "# $n inputs, $bad dishonest outcomes (accepted nonsense, nan/inf or 'complete' written, late refusals, crashes), $((n - bad)) honest"
