#!/bin/sh
# yade_pile.sh: Yade (bench/yade_pile.py, one OpenMP thread) and moreau (cases/disk-pile, its
# default nscd, h = 1 ms) on the same deposition scene; prints both programs' figures and, last,
#   RATIO moreau/yade time-per-simulated-second: R
# with R = (moreau's wall s per simulated s) / (Yade's). Yade's time is its O.run alone; moreau's
# is summary.json's timings.wall (the whole run, its output files included) over time.t_reached.
#   bench/yade_pile.sh [N [SIMULATED_SECONDS [MOREAU]]]     defaults: 1000, 1.0, build/moreau
# Scratch files go to a fresh folder under /tmp, removed on exit.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
n=${1:-1000}
t=${2:-1.0}
moreau=${3:-$root/build/moreau}
yade=${YADE:-/usr/bin/yade}
[ -x "$moreau" ] || { echo "yade_pile.sh: no moreau binary at $moreau" >&2; exit 2; }
[ -x "$yade" ] || { echo "yade_pile.sh: no Yade at $yade (Debian package yade)" >&2; exit 3; }
tmp=$(mktemp -d /tmp/yade_pile.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

# Yade: -n no GUI, -x exit after the script, -j1 one OpenMP thread
OMP_NUM_THREADS=1 "$yade" -n -x -j1 "$here/yade_pile.py" "$n" "$t" > "$tmp/yade.out" 2>&1 ||
  { cat "$tmp/yade.out" >&2; echo "yade_pile.sh: Yade failed" >&2; exit 1; }
yline=$(grep '^yade N=' "$tmp/yade.out") || { cat "$tmp/yade.out" >&2; exit 1; }
echo "$yline"

"$moreau" run "$root/cases/disk-pile" --set "bodies.grains.pack.count=$n" --set "time.end=$t" \
  --out "$tmp/moreau" --quiet

# moreau's line, in Yade's terms: steps and dt; closed contacts (history.csv's contact.closed,
# averaged over its rows after t = 0, and its last row); pile height, mean centre height, v_rms and
# the sum of the radii from bodies.csv (the final state)
mline=$(python3 - "$tmp/moreau" <<'EOF'
import csv, json, math, sys
d = sys.argv[1]
s = json.load(open(d + '/summary.json'))
wall, tr = s['timings']['wall'], s['time']['t_reached']
h = list(csv.DictReader(open(d + '/history.csv')))
closed = [float(r['contact.closed']) for r in h[1:]] or [0.0]
g = [r for r in csv.DictReader(open(d + '/bodies.csv')) if r['group'] == 'grains']
top = max(float(r['y']) + float(r['radius']) for r in g)
ym = sum(float(r['y']) for r in g) / len(g)
v2 = sum(float(r['vx']) ** 2 + float(r['vy']) ** 2 for r in g)
print('moreau N=%d t_end=%.6g steps=%d dt=%.6e wall_s=%.3f wall_per_sim_s=%.3f output_s=%.3f '
      'contacts=%.1f contacts_end=%d pile_height=%.4f y_mean=%.4f v_rms=%.3e sum_r=%.9f'
      % (len(g), tr, s['time']['steps_done'], s['time']['dt'], wall, wall / tr, s['timings']['output'],
         sum(closed) / len(closed), closed[-1], top, ym, math.sqrt(v2 / len(g)),
         sum(float(r['radius']) for r in g)))
EOF
)
echo "$mline"

# the two scenes must be the same grains: the sums of the radii agree to the printed digits
ry=$(echo "$yline" | sed 's/.*sum_r=\([^ ]*\).*/\1/')
rm_=$(echo "$mline" | sed 's/.*sum_r=\([^ ]*\).*/\1/')
[ "$ry" = "$rm_" ] || echo "yade_pile.sh: warning: the radii differ (sum $ry in Yade, $rm_ in moreau)" >&2

wy=$(echo "$yline" | sed 's/.*wall_per_sim_s=\([^ ]*\).*/\1/')
wm=$(echo "$mline" | sed 's/.*wall_per_sim_s=\([^ ]*\).*/\1/')
awk -v m="$wm" -v y="$wy" 'BEGIN { printf "RATIO moreau/yade time-per-simulated-second: %.4g\n", m / y }'
