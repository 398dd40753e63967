#!/bin/sh
# granular_scaling.sh: the deposition scene (cases/disk-pile) at N = 10^3, 10^4, 10^5 grains
# (boxes 33 sqrt(N / 1000) lattice columns wide): moreau's time per step with nscd held to
# Box2D's 8 sweeps, the broad phase's share of it, Box2D's time per step on the same scene, and
# moreau's memory. One line per N, then the table. Memory: the peak resident size of a run of one
# step (the grains, their few contacts) and of the full run (the pile's contacts), less that of
# a scene of one grain: per grain = (start - empty) / N, per contact = (end - start) / contacts
# at the end (the candidates of the last geometry), and the same over the most candidates a step
# had (summary.json contact.candidates_max: the peak holds them); and what the contact set and the
# driver hold per candidate at the end (summary.json contact.memory); and the issue's target as
# one figure: the full run's peak less that of the scene of one grain run as long (the code and
# buffers a run of that length touches, about 330 kB, whatever N), over 1 000 bytes a grain plus
# 200 a candidate at the end (vs_target <= 1: within it); and that figure on the anonymous resident
# size (anon_vs_target: the largest RssAnon sampled every 2 ms by bench/anon_peak.py, which leaves
# out the program's and libraries' pages, whose count follows the page cache's state and moves by
# about 1 MB from run to run, the whole target of 10^3 grains; the anonymous peak repeats to 10 kB).
# Times are the thread's CPU time
# (MOREAU_CLOCK=cpu for moreau, cpu_per_step_ms for Box2D): the steps alone, and the broad phase's
# share of them, with the builds of its pair list.
#   bench/granular_scaling.sh [STEPS [MOREAU [COUNTS]]]   defaults: 1000, build/moreau, "1000 10000 100000"
#   BOX2D=0 bench/granular_scaling.sh ...                  moreau alone
set -eu
MOREAU_CLOCK=cpu
export MOREAU_CLOCK
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
steps=${1:-1000}
moreau=${2:-$root/build/moreau}
counts=${3:-1000 10000 100000}
[ -x "$moreau" ] || { echo "granular_scaling.sh: no moreau binary at $moreau" >&2; exit 2; }
tmp=$(mktemp -d /tmp/granular_scaling.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
have_box2d=0
# BOX2D=0: moreau alone (Box2D's run of 10^5 grains over 1000 steps takes more than half an hour)
if [ "${BOX2D:-1}" != 0 ] && [ -f /usr/include/box2d/box2d.h ] && g++ -O2 -o "$tmp/box2d_pile" "$here/box2d_pile.cc" -lbox2d 2>/dev/null; then have_box2d=1; fi
t=$(awk -v s="$steps" 'BEGIN { printf "%.6g", s * 1e-3 }')
. "$here/pile_scene.sh"
# the runs under bench/anon_peak.py (the largest anonymous resident size into $ANON_FILE)
cat > "$tmp/anon_moreau" <<EOF
#!/bin/sh
exec python3 "$here/anon_peak.py" "\$ANON_FILE" "$moreau" "\$@"
EOF
chmod +x "$tmp/anon_moreau"
# run N END LABEL [SETS...]: moreau on the scene of N grains to END
run() {
  n=$1; end=$2; label=$3
  shift 3
  ANON_FILE="$tmp/$label.anon" pile_run "$tmp/anon_moreau" "$root" "$n" "$end" "$tmp/$label" "$@"
}
anon() { cat "$tmp/$1.anon"; }
field() { python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$tmp/$1/summary.json" "$2"; }
run 1 0.001 empty
empty=$(field empty "s['peak_rss_bytes']")
run 1 "$t" emptyfull
emptyfull=$(field emptyfull "s['peak_rss_bytes']")
anon_emptyfull=$(anon emptyfull)
printf '%8s %10s %12s %12s %8s %8s %8s %10s %12s %10s %10s %10s %10s %11s\n' N contacts moreau_ms box2d_ms ratio broad_% builds \
  B/grain B/contact B/peak set/cand drv/cand vs_target anon_vs_tgt > "$tmp/table"
for n in $counts; do
  run "$n" 0.001 "start$n"
  run "$n" "$t" "full$n" --set contact.nscd.stop=sweeps --set contact.nscd.max_sweeps=8
  start=$(field "start$n" "s['peak_rss_bytes']")
  line=$(python3 - "$tmp/full$n" "$n" "$empty" "$start" "$emptyfull" "$(anon "full$n")" "$anon_emptyfull" <<'PY'
import csv, json, sys
d, n, empty, start, emptyfull = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
anon_full, anon_emptyfull = int(sys.argv[6]), int(sys.argv[7])
s = json.load(open(d + '/summary.json'))
T, c = s['timings'], s['contact']
steps = s['time']['steps_done']
loop = T['steps']
h = list(csv.DictReader(open(d + '/history.csv')))
closed = [float(r['contact.closed']) for r in h[1:]] or [0.0]
per_grain = (start - empty) / n
nc = max(1, c['candidates'])
per_contact = (s['peak_rss_bytes'] - start) / nc
ncmax = max(nc, c.get('candidates_max', 0))
mem = c.get('memory', {})
# the target (issue 13): below 1 000 bytes a grain plus 200 a contact, the whole run over the scene of
# one grain run as long
vs_target = (s['peak_rss_bytes'] - emptyfull) / (1000.0 * n + 200.0 * c['candidates'])
anon_vs_target = (anon_full - anon_emptyfull) / (1000.0 * n + 200.0 * c['candidates'])
print('%d %.1f %.4f %.3f %.0f %.0f %d %d %.0f %.0f %.0f %d %.3f %.3f' % (n, sum(closed) / len(closed), 1e3 * loop / steps,
      T.get('broad', 0) / loop, per_grain, per_contact, c['candidates'], c.get('broad', {}).get('builds', 0),
      mem.get('set_candidates', 0) / nc, mem.get('driver_candidates', 0) / nc,
      (s['peak_rss_bytes'] - start) / ncmax, ncmax, vs_target, anon_vs_target))
PY
)
  set -- $line
  echo "moreau N=$1 steps=$steps contacts=$2 cpu_per_step_ms=$3 broad_share=$4 bytes_per_grain=$5 bytes_per_contact=$6 candidates_end=$7 broad_builds=$8 set_bytes_per_candidate=$9 driver_bytes_per_candidate=${10} bytes_per_contact_peak=${11} candidates_max=${12} vs_target=${13} anon_vs_target=${14}"
  tb=nan
  if [ "$have_box2d" = 1 ]; then
    pile_geometry "$n"
    bline=$("$tmp/box2d_pile" "$n" "$cols" "$steps" 8)
    echo "$bline"
    tb=$(echo "$bline" | sed 's/.*cpu_per_step_ms=\([^ ]*\).*/\1/')
  fi
  awk -v n="$1" -v c="$2" -v m="$3" -v b="$tb" -v br="$4" -v g="$5" -v k="$6" -v nb="$8" -v sc="$9" -v dc="${10}" -v kp="${11}" -v vt="${13}" -v at="${14}" \
    'BEGIN { printf "%8d %10.0f %12.3f %12s %8s %8.1f %8d %10.0f %12.0f %10.0f %10.0f %10.0f %10.3f %11.3f\n", n, c, m, b, (b == "nan" ? "-" : sprintf("%.3f", m / b)), 100 * br, nb, g, k, kp, sc, dc, vt, at }' >> "$tmp/table"
done
cat "$tmp/table"
