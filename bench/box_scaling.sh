#!/bin/sh
# box_scaling.sh: 3D linear algebra at scale (issue 16; doc/theory.md §13). An H8 cube of n^3
# elements (0.1 m, steel, no support) pressed by 1 MPa on its top face onto a frictionless rigid
# plane, theta = 1, dt = 1e-4 s (the box settles on the plane within a few steps), 10 steps; its
# (n + 1)^2 bottom nodes are the contact candidates. For each n: a run without contact (the pair
# switched off: the step is then the unconstrained step, two triangular solves and the products
# that build their right-hand side: the limit a contact step is measured against), then one run
# per back end. One line per run, then the table: dofs, contacts, nnz(L), the numeric
# factorization, the Delassus build, the step without contact ("2 solves"), the mean forward and
# backward solve of the contact run's own factor ("own 2 solves": the contact dofs last fill it
# more), the step of each back end, their ratios to both and to each other, and the peak resident
# size (the largest of the runs of that n) with the estimate made before building over it.
#
#   bench/box_scaling.sh [--large] [--sizes "14 21 31 45"] [--steps 10] [--solvers nscd,levelset]
#                        [--clock wall|cpu] [--moreau build/moreau] [--out DIR] [--set KEY=VALUE]...
#                        [--linear cholmod|mumps|mumps-ooc]
#
# --linear mumps runs every case through PETSc's MUMPS (builds configured --with-petsc), the
# contact dofs as its Schur variables (doc/theory.md (T180)); mumps-ooc with its factor out of
# core in TMPDIR (linear_solver.out_of_core, (T182)); cholmod (the default) CHOLMOD's trailing
# block.
# --large adds n = 68 (985 527 dofs: about 25 GB; run it alone). A step's time is the run's
# `timings.steps` less the Delassus build, over the steps (the first step builds W); "first" is
# `timings.first_step` less the Delassus build, "steady" the mean of steps 2..n (the contact set
# and W fixed: the linear scene of issue 16's limit); the
# factorization is `timings.factor`. --clock cpu times every phase on the thread's CPU clock
# (MOREAU_CLOCK=cpu): on a machine shared with other jobs the time waited for a core is left out
# (BLAS runs one thread unless MOREAU_BLAS_THREADS says otherwise). Needs python3 (summary.json).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
sizes="14 21 31 45"
steps=10
solvers="nscd,levelset"
moreau="$root/build/moreau"
out=""
sets=""
while [ $# -gt 0 ]; do
  case "$1" in
  --large) sizes="$sizes 68" ;;
  --sizes) sizes=$2; shift ;;
  --steps) steps=$2; shift ;;
  --solvers) solvers=$2; shift ;;
  --moreau) moreau=$2; shift ;;
  --out) out=$2; shift ;;
  --set) sets="$sets --set $2"; shift ;;
  --linear)
    case "$2" in
    cholmod) ;;
    mumps) sets="$sets --set linear_solver.type=\"petsc\"" ;;
    mumps-ooc) sets="$sets --set linear_solver.type=\"petsc\" --set linear_solver.out_of_core=true" ;;
    *) echo "box_scaling.sh: --linear cholmod, mumps or mumps-ooc (got '$2')" >&2; exit 2 ;;
    esac
    shift ;;
  --clock) [ "$2" = cpu ] && export MOREAU_CLOCK=cpu; shift ;;
  -h|--help) sed -n '2,29p' "$0"; exit 0 ;;
  *) echo "box_scaling.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
  shift
done
[ -x "$moreau" ] || { echo "box_scaling.sh: no moreau binary at $moreau" >&2; exit 2; }
command -v python3 > /dev/null || { echo "box_scaling.sh: python3 is needed to read summary.json" >&2; exit 2; }
if [ -z "$out" ]; then
  out=$(mktemp -d /tmp/box_scaling.XXXXXX)
  trap 'rm -rf "$out"' EXIT
fi
mkdir -p "$out"

# the scene of n^3 elements
scene() {
  cat > "$out/box$1.cfg" <<EOF
title = "box-scaling: an H8 cube of $1^3 elements pressed on a frictionless rigid plane";
bodies = (
  { name = "box";
    mesh = { generator = "box"; size = [0.1, 0.1, 0.1]; elements = [$1, $1, $1]; };
    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; };
    loads = ( { type = "pressure"; set = "zmax"; value = 1.0e6; } ); },
  { name = "ground"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; }
);
time = { scheme = "theta"; theta = 1.0; dt = 1.0e-4; steps = $steps; };
contact = { solver = "nscd";
  pairs = ( { name = "base"; slave = "box"; slave_set = "zmin"; master = "ground"; mu = 0.0; } ); };
output = { energy = false; };
EOF
}

# run N LABEL [ARGS...]: one run into $out/N-LABEL; prints its line
run() {
  n=$1; label=$2
  shift 2
  dir="$out/$n-$label"
  # shellcheck disable=SC2086
  if ! "$moreau" run "$out/box$n.cfg" --out "$dir" --quiet $sets "$@" > "$dir.log" 2>&1; then
    echo "box_scaling.sh: n = $n, $label failed:" >&2
    tail -3 "$dir.log" >&2
  fi
  python3 - "$dir" "$n" "$label" <<'PY'
import json, sys
d, n, label = sys.argv[1:4]
try:
    s = json.load(open(d + '/summary.json'))
except (OSError, ValueError):
    print('n=%s run=%s status=failed' % (n, label)); sys.exit(0)
T, L = s['timings'], s.get('linear_solver', {})
steps = max(1, s['time'].get('steps_done', 1))
step = (T['steps'] - T.get('delassus', 0)) / steps
# the first step (less the Delassus build) and the steady one (steps 2..n: the contact set and W fixed)
first = T.get('first_step', float('nan')) - T.get('delassus', 0)
steady = (T['steps'] - T.get('first_step', float('nan'))) / (steps - 1) if steps > 1 else float('nan')
c = s.get('contact', {})
print('n=%s run=%s status=%s dofs=%s contacts=%s nnz_L=%s factor_s=%.3f delassus_s=%.3f step_ms=%.2f '
      'first_ms=%.2f steady_ms=%.2f '
      'own_2solves_ms=%.2f iterations=%s peak_rss_MB=%.0f estimate_MB=%.0f' % (n, label, s['status'], L.get('n', 'nan'),
      c.get('candidates', 0), L.get('nnz_L', 'nan'), T['factor'], T.get('delassus', 0), 1e3 * step,
      1e3 * first, 1e3 * steady,
      1e3 * L.get('two_solves_seconds', float('nan')), c.get('iterations_mean', 'nan'), s.get('peak_rss_bytes', 0) / 1e6,
      (s.get('bytes_estimate') or float('nan')) / 1e6))
PY
}

: > "$out/lines"
for n in $sizes; do
  scene "$n"
  run "$n" none --set contact.pairs.base.active=false | tee -a "$out/lines"
  for s in $(echo "$solvers" | tr ',' ' '); do
    run "$n" "$s" --solver "$s" | tee -a "$out/lines"
  done
done

python3 - "$out/lines" "$solvers" <<'PY'
import sys
rows = {}
for line in open(sys.argv[1]):
    f = dict(kv.split('=', 1) for kv in line.split())
    rows.setdefault(int(f['n']), {})[f['run']] = f
solvers = sys.argv[2].split(',')
def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float('nan')
head = ['n^3', 'dofs', 'contacts', 'nnz(L)', 'factor s', 'Delassus s', '2 solves ms', 'own 2 solves ms'] + \
       ['step %s ms' % s for s in solvers] + ['%s / 2 solves' % s for s in solvers] + \
       ['%s / own 2 solves' % s for s in solvers] + \
       ['first %s ms' % s for s in solvers] + ['steady %s ms' % s for s in solvers] + \
       ['steady %s / own 2 solves' % s for s in solvers]
if len(solvers) == 2:
    head += ['%s / %s' % (solvers[1], solvers[0]), 'steady %s / %s' % (solvers[1], solvers[0])]
head += ['peak RSS MB', 'estimate / peak']
print('| ' + ' | '.join(head) + ' |')
print('|' + '---|' * len(head))
for n in sorted(rows):
    r = rows[n]
    ref = r.get(solvers[0], r.get('none', {}))
    lim = num(r.get('none', {}).get('step_ms'))
    st = [num(r.get(s, {}).get('step_ms')) for s in solvers]
    ok = [r.get(s, {}).get('status') == 'complete' for s in solvers]
    cells = ['%d' % n, ref.get('dofs', 'nan'), ref.get('contacts', 'nan'),
             '%.3g' % num(ref.get('nnz_L')) if ref.get('nnz_L', 'nan') != 'nan' else 'n/a',
             '%.2f' % num(ref.get('factor_s')), '%.2f' % max(num(r.get(s, {}).get('delassus_s')) for s in solvers),
             '%.1f' % lim]
    own = num(ref.get('own_2solves_ms'))
    cells.append('%.1f' % own if own == own else 'n/a')
    cells += ['%.1f' % t if o else 'failed' for t, o in zip(st, ok)]
    cells += ['%.2f' % (t / lim) if o else '-' for t, o in zip(st, ok)]
    cells += ['%.2f' % (t / own) if o and own == own else '-' for t, o in zip(st, ok)]
    fi = [num(r.get(s, {}).get('first_ms')) for s in solvers]
    sd = [num(r.get(s, {}).get('steady_ms')) for s in solvers]
    cells += ['%.1f' % t if o else '-' for t, o in zip(fi, ok)]
    cells += ['%.1f' % t if o else '-' for t, o in zip(sd, ok)]
    cells += ['%.2f' % (t / own) if o and own == own else '-' for t, o in zip(sd, ok)]
    if len(solvers) == 2:
        cells.append('%.2f' % (st[1] / st[0]) if all(ok) else '-')
        cells.append('%.2f' % (sd[1] / sd[0]) if all(ok) else '-')
    cells.append('%.0f' % max(num(x.get('peak_rss_MB')) for x in r.values()))
    # the estimate before building (doc/theory.md (T165)) of the largest run against its peak
    big = max(r.values(), key=lambda x: num(x.get('peak_rss_MB')))
    cells.append('%.2f' % (num(big.get('estimate_MB')) / num(big.get('peak_rss_MB'))))
    print('| ' + ' | '.join(cells) + ' |')
PY
