#!/bin/sh
# box2d_pile.sh: Box2D (bench/box2d_pile.cc, Debian libbox2d-dev) and moreau (cases/disk-pile) on
# the same deposition scene, N grains in a box as wide as 33 sqrt(N / 1000) lattice columns, 1 s
# at h = 1 ms (or STEPS steps). Box2D runs its default 8 velocity and 3 position iterations,
# sleeping off; moreau runs nscd twice: held to the same 8 sweeps a step (stop = "sweeps"), and at
# its default, Jean's quad criterion at 1e-4. Prints each program's line, then
#   RATIO moreau/box2d time-per-step (nscd 8 sweeps): R
#   RATIO moreau/box2d time-per-step (nscd quad 1e-4): R
# Box2D's time is its world.Step calls alone; moreau's is summary.json's timings.steps (the steps
# without setup and output), over the steps: both the time loop without the writing of files. Both
# programs count the thread's CPU time (moreau with MOREAU_CLOCK=cpu), which a machine shared with
# other jobs inflates far less than the wall clock; the wall-clock figures are printed beside.
#   bench/box2d_pile.sh [N [STEPS [MOREAU]]]     defaults: 1000, 1000, build/moreau
set -eu
MOREAU_CLOCK=cpu # moreau's timers on the thread's CPU time, as Box2D's cpu_per_step_ms
export MOREAU_CLOCK
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
n=${1:-1000}
steps=${2:-1000}
moreau=${3:-$root/build/moreau}
[ -x "$moreau" ] || { echo "box2d_pile.sh: no moreau binary at $moreau" >&2; exit 2; }
[ -f /usr/include/box2d/box2d.h ] || { echo "box2d_pile.sh: no Box2D headers (Debian package libbox2d-dev)" >&2; exit 3; }
tmp=$(mktemp -d /tmp/box2d_pile.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
g++ -O2 -o "$tmp/box2d_pile" "$here/box2d_pile.cc" -lbox2d
. "$here/pile_scene.sh"
pile_geometry "$n"
t=$(awk -v s="$steps" 'BEGIN { printf "%.6g", s * 1e-3 }')
bline=$("$tmp/box2d_pile" "$n" "$cols" "$steps" 8)
echo "$bline"
run() { # run LABEL SETS...: moreau on the scene, its line
  label=$1
  shift
  pile_run "$moreau" "$root" "$n" "$t" "$tmp/$label" "$@"
  python3 - "$tmp/$label" "$label" <<'PY'
import csv, json, sys
d, label = sys.argv[1], sys.argv[2]
s = json.load(open(d + '/summary.json'))
T, c = s['timings'], s['contact']
steps = s['time']['steps_done']
loop = T['steps']
h = list(csv.DictReader(open(d + '/history.csv')))
closed = [float(r['contact.closed']) for r in h[1:]] or [0.0]
g = [r for r in csv.DictReader(open(d + '/bodies.csv')) if r['group'] == 'grains']
top = max(float(r['y']) + float(r['radius']) for r in g)
print('moreau %s N=%d steps=%d cpu_per_step_ms=%.4f contacts=%.1f sweeps_mean=%.1f us_per_update=%.4f '
      'broad_share=%.3f failed_solves=%d pile_height=%.4f peak_rss_mb=%.1f'
      % (label, len(g), steps, 1e3 * loop / steps, sum(closed) / len(closed), c['iterations_mean'],
         1e6 * T['contact'] / max(1.0, c['iterations_total'] * sum(closed) / len(closed)),
         T.get('broad', 0.0) / loop, c['failed_solves'], top, s['peak_rss_bytes'] / 2 ** 20))
PY
}
m8=$(run sweeps8 --set contact.nscd.stop=sweeps --set contact.nscd.max_sweeps=8)
echo "$m8"
mq=$(run quad)
echo "$mq"
tb=$(echo "$bline" | sed 's/.*cpu_per_step_ms=\([^ ]*\).*/\1/')
t8=$(echo "$m8" | sed 's/.*cpu_per_step_ms=\([^ ]*\).*/\1/')
tq=$(echo "$mq" | sed 's/.*cpu_per_step_ms=\([^ ]*\).*/\1/')
awk -v m="$t8" -v b="$tb" 'BEGIN { printf "RATIO moreau/box2d time-per-step (nscd 8 sweeps): %.4g\n", m / b }'
awk -v m="$tq" -v b="$tb" 'BEGIN { printf "RATIO moreau/box2d time-per-step (nscd quad 1e-4): %.4g\n", m / b }'
