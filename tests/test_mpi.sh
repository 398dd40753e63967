#!/bin/sh
# test_mpi.sh: runs over MPI ranks equal the serial run (doc/parallel.md). The PETSc solver type
# on 2 ranks against CHOLMOD (tests/test_parallel), then `mpirun -np 2 moreau run` against the
# serial run on rods-3d (dynamic impacts, the Delassus operator from distributed solves) and the
# 14^3 H8 box pressed on a plane (quasi-static), to 1e-8 of every history column, each rank
# computing the element matrices of half of the elements and keeping them (K and M in parts, no
# rank holding them whole; against one process's assembly: tests/test_parallel), and its rows of
# the Delassus build's columns What^-1 H^T (no rank holding them whole). Skipped by
# builds without PETSc. The 2 ranks share CI's 2 cores with nothing else: oversubscription
# allowed, as the CI machine's MPI would refuse it otherwise.
. "$MOREAU_SRCDIR/tests/tap.sh"
if [ "$MOREAU_HAVE_PETSC" != yes ]; then
  # the serial build: a case that asks for PETSc is refused, saying how to get it
  e=$("$MOREAU" check "$MOREAU_SRCDIR/cases/rods-3d" --set 'linear_solver.type="petsc"' 2>&1)
  is "$?" "2" "a build without PETSc: linear_solver.type = \"petsc\" refused as bad input"
  contains "$e" "configure it --with-petsc" "a build without PETSc: the message says how to get it"
  contains "$e" "linear_solver" "a build without PETSc: the message names the key"
  done_testing
  exit
fi
if [ -z "$MOREAU_MPIRUN" ]; then
  echo "1..0 # SKIP no mpirun found by configure"
  exit 0
fi
# Open MPI as root in a container: allowed explicitly; no shared-memory single copy (it needs
# ptrace rights that containers do not give)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMPI_MCA_rmaps_base_oversubscribe=1 OMPI_MCA_mpi_yield_when_idle=1
# a bound on every parallel run: a rank waiting for another that left must not hang CI
mpi() { timeout 300 "$MOREAU_MPIRUN" -np "$@"; }

# 1. the solver type and the collective calls on 2 ranks
mpi 2 "$MOREAU_BUILDDIR/tests/test_parallel" > "$OUT/unit" 2>&1
n=$(grep -c '^ok' "$OUT/unit")
f=$(grep -c '^not ok' "$OUT/unit")
ok $([ "$n" -gt 15 ] && [ "$f" -eq 0 ] && echo 0 || echo 1) "tests/test_parallel on 2 ranks: $n checks pass, $f fail"
grep '^not ok' "$OUT/unit" | sed 's/^/#   /'

# 2. whole runs: serial CHOLMOD against PETSc (MUMPS) on 2 ranks
run_pair() { # run_pair NAME CASE ARGS...: serial and 2-rank runs, then their comparison
  name=$1
  c=$2
  shift 2
  "$MOREAU" run "$c" --out "$OUT/$name-1" --quiet "$@" > "$OUT/$name-1.log" 2>&1
  ran $? "$OUT/$name-1.log" "$name: the serial run completes"
  mpi 2 "$MOREAU" run "$c" --out "$OUT/$name-2" --quiet "$@" > "$OUT/$name-2.log" 2>&1
  ran $? "$OUT/$name-2.log" "$name: mpirun -np 2 completes"
  check_runs "$OUT/$name-1" "$OUT/$name-2" 1e-8 "$name"
  is "$(json "$OUT/$name-2/summary.json" "d['parallel']['ranks']")" "2" "$name: summary.json says 2 ranks"
  is "$(json "$OUT/$name-2/summary.json" "d['parallel']['linear_solver']")" "petsc" "$name: the 2-rank run solved with PETSc"
  is "$(ls "$OUT/$name-2" | grep -c '\.tmp\.')" "0" "$name: one set of outputs, no temporary left by another rank"
  # the element matrices split over the ranks (doc/parallel.md §3): each rank its half of the
  # elements the serial run lists, none twice
  is "$(json "$OUT/$name-2/summary.json" "(lambda n, a: [len(a), sum(a) == n, max(a) - min(a) <= 1, min(a) > 0])( \
         sum(b.get('elements', 0) for b in d['scene']['bodies']), d['parallel']['elements_assembled'])")" "[2, True, True, True]" \
    "$name: each rank computed half of the elements ($(json "$OUT/$name-2/summary.json" "d['parallel'].get('elements_assembled')"))"
  # no rank holds K and M whole (doc/parallel.md §3): each keeps its elements' entries, the
  # largest part 60 % of the serial run's entries at most, the parts all of them
  whole=$(json "$OUT/$name-1/summary.json" "d['scene']['matrix_entries']")
  is "$(json "$OUT/$name-2/summary.json" "(lambda p: [p['matrices'], max(p['matrix_entries']) <= 0.6 * $whole, sum(p['matrix_entries']) >= $whole])(d['parallel'])")" \
    "['parts', True, True]" "$name: K and M in parts, the largest rank's $(json "$OUT/$name-2/summary.json" "max(d['parallel']['matrix_entries'])") of the $whole entries"
  # the Delassus build's columns What^-1 H^T by rows (doc/parallel.md §2, (T210)): no rank holds
  # them whole, the largest rank 60 % of the free nodal rows at most (the serial run's free dofs)
  free=$(json "$OUT/$name-1/summary.json" "d['scene']['free_dofs']")
  is "$(json "$OUT/$name-2/summary.json" "(lambda c: [c['rows'] == $free, c['columns'] > 0, c['rows_largest_rank'] <= 0.6 * c['rows']])(d['parallel']['delassus_columns'])")" \
    "[True, True, True]" "$name: the Delassus columns by rows, the largest rank's $(json "$OUT/$name-2/summary.json" "d['parallel']['delassus_columns']['rows_largest_rank']") of the $free rows"
}
check_runs() { # check_runs A B TOL NAME [grains]
  /usr/bin/python3 "$MOREAU_SRCDIR/tests/compare_runs.py" "$1" "$2" "$3" $5 > "$OUT/cmp" 2>&1 || echo "1	compare_runs.py crashed: $(tail -1 "$OUT/cmp")" >> "$OUT/cmp"
  while IFS= read -r line; do
    case "$line" in
      [01]'	'*) ok "${line%%	*}" "$4: ${line#*	}" ;;
      *) echo "# $line" ;;
    esac
  done < "$OUT/cmp"
}
run_pair rods-3d "$MOREAU_SRCDIR/cases/rods-3d" --set 'output.vtk={every=50;}'
# the fields: each rank's piece of every body, joined by rank 0's .pvtu, read back by VTK
/usr/bin/python3 "$MOREAU_SRCDIR/tests/pvtu_check.py" "$OUT/rods-3d-1" "$OUT/rods-3d-2" 1e-8 > "$OUT/pvtu" 2>&1 ||
  echo "1	pvtu_check.py crashed: $(tail -1 "$OUT/pvtu")" >> "$OUT/pvtu"
while IFS= read -r line; do
  case "$line" in
    [01]'	'*) ok "${line%%	*}" "rods-3d VTK: ${line#*	}" ;;
    *) echo "# $line" ;;
  esac
done < "$OUT/pvtu"
is "$(ls "$OUT/rods-3d-2" | grep -c '^fields_left_.*_[01]\.vtu$')" "$((2 * $(ls "$OUT/rods-3d-1" | grep -c '^fields_left_.*\.vtu$')))" \
  "rods-3d VTK: two pieces per frame of each body"
run_pair box-14 "$MOREAU_SRCDIR/cases/box-on-plane" --set 'bodies.box.mesh.elements=[14,14,14]'

# 3. grains over the ranks (doc/parallel.md §4): the nscd sweep split into parts of contacts,
# Gauss-Seidel within a part and the interface velocities summed after each sweep. At a natural-map
# tolerance of 1e-11 the motion equals the serial sweep's (the reactions of a pile are not unique:
# compare_runs.py's `grains` mode); the windows end before the first step whose sweeps stall.
# These sets (up to 400 contacts, 60-200 bodies) are mostly below the 128 contacts a rank from
# which a solve is split by default (T333), and below the 64 bodies a rank from which the
# detection is (T337): split_min = 0 and detect_split_min = 0 split every solve and detection
grains_pair() { # grains_pair NAME CASE ARGS...
  name=$1
  c=$2
  shift 2
  set -- --set contact.nscd.tol=1e-11 --set 'contact.nscd.stop="natural"' --set contact.nscd.max_sweeps=50000 --set contact.nscd.split_min=0 \
    --set contact.detect_split_min=0 "$@"
  "$MOREAU" run "$c" --out "$OUT/$name-1" --quiet "$@" > "$OUT/$name-1.log" 2>&1
  ran $? "$OUT/$name-1.log" "$name: the serial run completes"
  mpi 2 "$MOREAU" run "$c" --out "$OUT/$name-2" --quiet "$@" > "$OUT/$name-2.log" 2>&1
  ran $? "$OUT/$name-2.log" "$name: mpirun -np 2 completes"
  is "$(json "$OUT/$name-2/summary.json" "d['contact']['failed_solves']")" "0" "$name: every solve of the 2-rank run converged"
  ok $([ "$(json "$OUT/$name-2/summary.json" "d['parallel'].get('grain_sweeps', 0) > 0")" = True ] && echo 0 || echo 1) \
    "$name: the 2-rank run swept its grains split over the ranks"
  # (T340) the natural rule's residual joins the sweep's one sum on 2 ranks: about 1 collective
  # a sweep (2 before)
  ok $(json "$OUT/$name-2/summary.json" "0 if d['parallel']['collective_calls'] < 1.2 * d['parallel']['grain_sweeps'] else 1") \
    "$name: $(json "$OUT/$name-2/summary.json" "d['parallel']['collective_calls']") collectives for $(json "$OUT/$name-2/summary.json" "d['parallel']['grain_sweeps']") split sweeps on 2 ranks, fewer than 1.2 a sweep"
  detected_split "$name"
  check_runs "$OUT/$name-1" "$OUT/$name-2" 1e-8 "$name" grains
  # (T341) the split solves swept in the detection's parts (each contact by the rank that detected
  # it), the boxes cut at the builds from the last solve's contact points once the grains touch
  is "$(json "$OUT/$name-2/summary.json" "(lambda p: [p['grain_solves_in_detection_parts'] == p['grain_solves'], 0 < p['grain_detect_builds_on_contacts'] < p['grain_detect_builds']])(d['parallel'])")" \
    "[True, True]" "$name: $(json "$OUT/$name-2/summary.json" "d['parallel']['grain_solves_in_detection_parts']") of $(json "$OUT/$name-2/summary.json" "d['parallel']['grain_solves']") split solves in the detection's parts, $(json "$OUT/$name-2/summary.json" "d['parallel']['grain_detect_builds_on_contacts']") of $(json "$OUT/$name-2/summary.json" "d['parallel']['grain_detect_builds']") builds cut on the contact points"
}
# the detection split over the ranks (doc/parallel.md §4, (T215)-(T217)): each rank the pairs of
# its slab, the largest rank 60 % of every rank's candidates at most (the set gathered, in the
# serial order, is compared with the serial run's by check_runs: contact.csv); the Verlet list's
# validity decided by each rank on its own bodies and one maximum over the ranks (T230): the
# list rebuilt at as many steps as the serial run's, which decides over every body
detected_split() { # detected_split NAME
  b1=$(json "$OUT/$1-1/summary.json" "d['contact']['broad']['builds']")
  is "$(json "$OUT/$1-2/summary.json" "d['contact']['broad']['builds']")" "$b1" "$1: the 2-rank run rebuilt its pair list as often as the serial run ($b1)"
  is "$(json "$OUT/$1-2/summary.json" "(lambda p: [p.get('grain_detected', 0) > 0, p.get('grain_detected_largest_rank', 1) <= 0.6 * p.get('grain_detected', 0)])(d['parallel'])")" \
    "[True, True]" "$1: each rank detected a part, the largest rank $(json "$OUT/$1-2/summary.json" "d['parallel'].get('grain_detected_largest_rank')") of the $(json "$OUT/$1-2/summary.json" "d['parallel'].get('grain_detected')") candidates"
}
grains_pair disk-pile "$MOREAU_SRCDIR/cases/disk-pile" --set bodies.grains.pack.count=60 --set time.end=0.22
# (T337) 60 bodies on 2 ranks, below detect_split_min's 64 a rank: detected whole on every rank,
# as one process detects them, without the detection's messages (its gather, the list's
# validity). The candidates are the split detection's; the sweep's parts are cut at each solve
# instead of being the detection's owners (T341), so the run is the serial one's to the tolerance
mpi 2 "$MOREAU" run "$MOREAU_SRCDIR/cases/disk-pile" --out "$OUT/dwhole-2" --quiet --set contact.nscd.tol=1e-11 \
  --set 'contact.nscd.stop="natural"' --set contact.nscd.max_sweeps=50000 --set contact.nscd.split_min=0 \
  --set bodies.grains.pack.count=60 --set time.end=0.22 > "$OUT/dwhole-2.log" 2>&1
ran $? "$OUT/dwhole-2.log" "disk-pile, the detection whole: mpirun -np 2 completes"
check_runs "$OUT/disk-pile-1" "$OUT/dwhole-2" 1e-8 "disk-pile, the detection whole on every rank" grains
is "$(json "$OUT/dwhole-2/summary.json" "[d['parallel'].get('grain_detected', 0), d['parallel']['collective_calls'] + 3 * 220 <= $(json "$OUT/disk-pile-2/summary.json" "d['parallel']['collective_calls']")]")" \
  "[0, True]" "disk-pile, the detection whole: no candidate gathered, $(json "$OUT/dwhole-2/summary.json" "d['parallel']['collective_calls']") collectives against $(json "$OUT/disk-pile-2/summary.json" "d['parallel']['collective_calls']") (3 a step fewer at least)"
grains_pair sphere-deposit "$MOREAU_SRCDIR/cases/sphere-deposit" --set bodies.grains.pack.count=200 --set time.end=0.12
# more than 2 ranks ((T330)-(T331)): the parts boxes cut by recursive bisection (3 ranks: unequal
# halves), the interface velocities sent point to point between the ranks that share bodies and
# summed in rank order; against the serial runs above
grains_more() { # grains_more NAME NP CASE ARGS...
  name=$1
  np=$2
  c=$3
  shift 3
  set -- --set contact.nscd.tol=1e-11 --set 'contact.nscd.stop="natural"' --set contact.nscd.max_sweeps=50000 --set contact.nscd.split_min=0 \
    --set contact.detect_split_min=0 "$@"
  mpi "$np" "$MOREAU" run "$c" --out "$OUT/$name-$np" --quiet "$@" > "$OUT/$name-$np.log" 2>&1
  ran $? "$OUT/$name-$np.log" "$name: mpirun -np $np completes"
  is "$(json "$OUT/$name-$np/summary.json" "[d['parallel']['ranks'], d['contact']['failed_solves'], d['parallel']['grain_sweeps'] > 0, d['parallel']['grain_interface_exchange'], d['parallel']['grain_detected_largest_rank'] <= 0.6 * d['parallel']['grain_detected'] / $np * 2]")" \
    "[$np, 0, True, 'point to point', True]" "$name on $np ranks: every solve converged, the sweep and the detection split, the interface point to point"
  # (T339) under the natural rule the residual's parts join the sweep's one sum, after the
  # exchange: 2 calls a sweep (the exchange and the sum), 3 before
  ok $(json "$OUT/$name-$np/summary.json" "0 if d['parallel']['collective_calls'] < 2.2 * d['parallel']['grain_sweeps'] else 1") \
    "$name on $np ranks: $(json "$OUT/$name-$np/summary.json" "d['parallel']['collective_calls']") calls for $(json "$OUT/$name-$np/summary.json" "d['parallel']['grain_sweeps']") split sweeps, fewer than 2.2 a sweep"
  check_runs "$OUT/$name-1" "$OUT/$name-$np" 1e-8 "$name on $np ranks" grains
}
grains_more disk-pile 3 "$MOREAU_SRCDIR/cases/disk-pile" --set bodies.grains.pack.count=60 --set time.end=0.22
grains_more sphere-deposit 4 "$MOREAU_SRCDIR/cases/sphere-deposit" --set bodies.grains.pack.count=200 --set time.end=0.12
# the distributed set (contact.distributed_set, doc/scaling.md §4): each rank keeps only the
# contacts it detected (nothing of the set gathered: the sweep's interface found from one sum of
# body masks and exchanged point to point, the outputs the ranks' contacts merged on rank 0), and
# from the second build of the list only the bodies of its box and halo (doc/theory.md §13.18: the
# solve's end sends each body's velocity to the ranks that hold it, the builds each body's state
# to its next holders); against the serial runs above. Every body a rank does not hold is made NaN
# at each build (MOREAU_TEST_POISON_UNHELD), so that a rank reading one would stop on it or part from
# the serial run
grains_dist() { # grains_dist NAME NP CASE ARGS...
  name=$1
  np=$2
  c=$3
  shift 3
  set -- --set contact.nscd.tol=1e-11 --set 'contact.nscd.stop="natural"' --set contact.nscd.max_sweeps=50000 \
    --set contact.detect_split_min=0 --set contact.distributed_set=true "$@"
  MOREAU_TEST_POISON_UNHELD=1 mpi "$np" "$MOREAU" run "$c" --out "$OUT/$name-d$np" --quiet "$@" \
    > "$OUT/$name-d$np.log" 2>&1
  ran $? "$OUT/$name-d$np.log" "$name, the set distributed: mpirun -np $np completes"
  is "$(json "$OUT/$name-d$np/summary.json" "(lambda p: [p['bodies_state'], p['state_records_sent'] > 0, p['state_joins'] > 0])(d['parallel'])")" \
    "['per rank', True, True]" \
    "$name, the set distributed on $np ranks: each rank held its box's bodies only ($(json "$OUT/$name-d$np/summary.json" "d['parallel']['state_records_sent']") records sent by rank 0 at the builds), the others' state NaN on it"
  is "$(json "$OUT/$name-d$np/summary.json" "(lambda p: [p['ranks'], d['contact']['failed_solves'], p['contact_set'], p['grain_interface_exchange'], p['grain_sweeps'] > 0, p['grain_solves_in_detection_parts'] == p['grain_solves'], p['grain_detected_largest_rank'] < 0.75 * p['grain_detected'] if $np == 2 else p['grain_detected_largest_rank'] < 0.6 * p['grain_detected']])(d['parallel'])")" \
    "[$np, 0, 'distributed', 'point to point', True, True, True]" \
    "$name, the set distributed on $np ranks: every solve converged and split, each rank holding $(json "$OUT/$name-d$np/summary.json" "round(d['parallel']['grain_detected_largest_rank'] / d['parallel']['grain_detected'], 3)") of the candidates at most"
  check_runs "$OUT/$name-1" "$OUT/$name-d$np" 1e-8 "$name, the set distributed on $np ranks" grains
  # the VTK contact points gathered to rank 0 in the serial run's order: the same candidates,
  # numbers, pairs and bodies, their points and gaps to 1e-8 of the largest
  is "$(/usr/bin/python3 -c "
import sys
sys.path.insert(0, '$MOREAU_SRCDIR/tests')
import vtkread
f = [vtkread.read('$OUT/$name-%s/contact_points_00001.vtu' % k)[2] for k in ('1', 'd$np')]
same = all(f[0][k] == f[1][k] for k in ('candidate', 'pair', 'slave', 'master'))
def near(k):
    a, b = f[0][k][1], f[1][k][1]
    s = max([abs(v) for v in a] + [1e-300])
    return len(a) == len(b) and max([abs(x - y) for x, y in zip(a, b)] + [0]) <= 1e-8 * s
print([len(f[0]['candidate'][1]) > 0, same, near('points'), near('gap')])")" "[True, True, True, True]" \
    "$name, the set distributed on $np ranks: the VTK contact points the serial run's, in its order"
}
grains_dist disk-pile 2 "$MOREAU_SRCDIR/cases/disk-pile" --set bodies.grains.pack.count=60 --set time.end=0.22
grains_dist disk-pile 3 "$MOREAU_SRCDIR/cases/disk-pile" --set bodies.grains.pack.count=60 --set time.end=0.22
grains_dist sphere-deposit 2 "$MOREAU_SRCDIR/cases/sphere-deposit" --set bodies.grains.pack.count=200 --set time.end=0.12
grains_dist sphere-deposit 4 "$MOREAU_SRCDIR/cases/sphere-deposit" --set bodies.grains.pack.count=200 --set time.end=0.12
# contact_history.csv is not gathered: the run is refused, naming both keys, before any step
mpi 2 "$MOREAU" run "$MOREAU_SRCDIR/cases/disk-pile" --out "$OUT/dhist" --quiet --set contact.detect_split_min=0 \
  --set contact.distributed_set=true --set 'output.contact_history={every=10;}' --set bodies.grains.pack.count=60 \
  > "$OUT/dhist.log" 2>&1
rc=$?
ok $([ $rc -ne 0 ] && grep -q "output.contact_history is not written with contact.distributed_set" "$OUT/dhist.log" && echo 0 || echo 1) \
  "the set distributed with output.contact_history: refused with a message naming both keys (exit $rc)"
mpi 2 "$MOREAU" run "$MOREAU_SRCDIR/cases/disk-pile" --out "$OUT/dfcl" --quiet --set contact.detect_split_min=0 \
  --set contact.distributed_set=true --set bodies.grains.pack.count=60 --dump-fclib "$OUT/dfcl-dump" > "$OUT/dfcl.log" 2>&1
rc=$?
ok $([ $rc -ne 0 ] && grep -q "dump-fclib.*contact.distributed_set" "$OUT/dfcl.log" && echo 0 || echo 1) \
  "the set distributed with --dump-fclib: refused, naming the key (exit $rc)"
# Jean's rules over the ranks (T334): the sweep's sync is one sum, the maximum of a breakdown's
# index and of |dU| |r| taken only under the maxm rule (and when a rank broke down); quad's
# reported Maxm once after the last sweep. Against the serial runs under the same rule
jean_pair() { # jean_pair RULE TOL
  rule=$1
  tol=$2
  set -- --set bodies.grains.pack.count=60 --set time.end=0.22 --set contact.nscd.tol="$tol" --set "contact.nscd.stop=\"$rule\"" \
    --set contact.nscd.max_sweeps=50000 --set contact.nscd.split_min=0
  "$MOREAU" run "$MOREAU_SRCDIR/cases/disk-pile" --out "$OUT/jean-$rule-1" --quiet "$@" > "$OUT/jean-$rule-1.log" 2>&1
  ran $? "$OUT/jean-$rule-1.log" "disk-pile under $rule $tol: the serial run completes"
  mpi 2 "$MOREAU" run "$MOREAU_SRCDIR/cases/disk-pile" --out "$OUT/jean-$rule-2" --quiet "$@" > "$OUT/jean-$rule-2.log" 2>&1
  ran $? "$OUT/jean-$rule-2.log" "disk-pile under $rule $tol: mpirun -np 2 completes"
  check_runs "$OUT/jean-$rule-1" "$OUT/jean-$rule-2" 1e-8 "disk-pile under $rule" grains
  # the redundancy count, joined in the end-of-solve gather (T279, (T335))
  is "$(json "$OUT/jean-$rule-2/summary.json" "d['contact']['redundancy']")" "$(json "$OUT/jean-$rule-1/summary.json" "d['contact']['redundancy']")" \
    "disk-pile under $rule: the redundancy count of the serial run ($(json "$OUT/jean-$rule-1/summary.json" "d['contact']['redundancy']['last_unknowns']") closed unknowns)"
}
jean_pair quad 1e-10
ok $(json "$OUT/jean-quad-2/summary.json" "0 if d['parallel']['collective_calls'] < 1.2 * d['parallel']['grain_sweeps'] else 1") \
  "quad: one collective a split sweep ($(json "$OUT/jean-quad-2/summary.json" "'%d collectives, %d sweeps' % (d['parallel']['collective_calls'], d['parallel']['grain_sweeps'])"))"
jean_pair maxm 1e-12
ok $(json "$OUT/jean-maxm-2/summary.json" "0 if d['parallel']['collective_calls'] >= 2 * d['parallel']['grain_sweeps'] else 1") \
  "maxm: the sum and the maximum a split sweep ($(json "$OUT/jean-maxm-2/summary.json" "'%d collectives, %d sweeps' % (d['parallel']['collective_calls'], d['parallel']['grain_sweeps'])"))"
# bodies where 3 or 4 parts meet (T332): the 2000-sphere deposit on 4 ranks, at the case's own
# tolerance, whose split sweep summing 4 ranks' full increments diverged at step 192 (speeds of
# 1e116); it runs as the serial one does, its kinetic energy within 10 % of the serial run's at
# every output (the two sweeps stop at different points within quad 1e-4: 3.4 % measured)
c="$MOREAU_SRCDIR/cases/sphere-deposit"
set -- --set bodies.grains.pack.count=2000 --set time.end=0.2 --set output.vtk.every=1000000 --set output.draw.frames=1 --set output.draw.gif=false
"$MOREAU" run "$c" --out "$OUT/deposit2000-1" --quiet "$@" > "$OUT/deposit2000-1.log" 2>&1
ran $? "$OUT/deposit2000-1.log" "2000 spheres: the serial run completes"
mpi 4 "$MOREAU" run "$c" --out "$OUT/deposit2000-4" --quiet "$@" > "$OUT/deposit2000-4.log" 2>&1
ran $? "$OUT/deposit2000-4.log" "2000 spheres: mpirun -np 4 completes"
is "$(/usr/bin/python3 -c "
import csv, json
a, b = (list(csv.DictReader(open('$OUT/deposit2000-%d/history.csv' % k))) for k in (1, 4))
p = json.load(open('$OUT/deposit2000-4/summary.json'))['parallel']
ke = max(abs(float(x['energy.kinetic']) - float(y['energy.kinetic'])) / max(float(x['energy.kinetic']), 1e-9) for x, y in zip(a, b))
print([len(a) == len(b) == 21, ke < 0.1, p['grain_interface_bodies_over_2_ranks_mean'] > 0.5])")" "[True, True, True]" \
  "2000 spheres on 4 ranks: bodies of 3-4 ranks ($(json "$OUT/deposit2000-4/summary.json" "'%.2f' % d['parallel']['grain_interface_bodies_over_2_ranks_mean']") a solve), the kinetic energy the serial run's within 10 %"
# masonry-arch's 74 contacts are swept whole on every rank by default (T333): the 2-rank run is
# the serial run to the byte
c="$MOREAU_SRCDIR/cases/masonry-arch"
"$MOREAU" run "$c" --out "$OUT/arch-1" --quiet > "$OUT/arch-1.log" 2>&1
ran $? "$OUT/arch-1.log" "masonry-arch: the serial run completes"
mpi 2 "$MOREAU" run "$c" --out "$OUT/arch-w" --quiet > "$OUT/arch-w.log" 2>&1
ran $? "$OUT/arch-w.log" "masonry-arch: mpirun -np 2 completes"
is "$(json "$OUT/arch-w/summary.json" "[d['contact']['failed_solves'], d['parallel'].get('grain_whole_solves'), d['parallel'].get('grain_sweeps', 0), d['contact']['iterations_total'] == $(json "$OUT/arch-1/summary.json" "d['contact']['iterations_total']")]")" \
  "[0, 2000, 0, True]" "masonry-arch on 2 ranks: every solve swept whole on every rank, the serial run's sweeps"
for f in bodies.csv history.csv contact.csv; do
  cmp -s "$OUT/arch-1/$f" "$OUT/arch-w/$f"; ok $? "masonry-arch on 2 ranks: $f the serial run's to the byte"
done
# a set swept whole on every rank draws the one process's permutations (one seed, the same draws):
# the 60-disk pile in shuffled order, reshuffled every sweep, on 2 and 3 ranks is the serial run
c="$MOREAU_SRCDIR/cases/disk-pile"
set -- --set bodies.grains.pack.count=60 --set time.end=0.3 --set 'contact.nscd.order="shuffled"' --set contact.nscd.reshuffle=true
"$MOREAU" run "$c" --out "$OUT/shuf-1" --quiet "$@" > "$OUT/shuf-1.log" 2>&1
ran $? "$OUT/shuf-1.log" "shuffled pile: the serial run completes"
for np in 2 3; do
  mpi $np "$MOREAU" run "$c" --out "$OUT/shuf-$np" --quiet "$@" > "$OUT/shuf-$np.log" 2>&1
  ran $? "$OUT/shuf-$np.log" "shuffled pile: mpirun -np $np completes"
  same=0
  for f in bodies.csv history.csv contact.csv; do cmp -s "$OUT/shuf-1/$f" "$OUT/shuf-$np/$f" || same=1; done
  ok $same "shuffled pile on $np ranks, every solve whole ($(json "$OUT/shuf-$np/summary.json" "d['parallel'].get('grain_whole_solves')")): bodies, history and contact.csv the serial run's to the byte"
done
c="$MOREAU_SRCDIR/cases/masonry-arch"
# a split sweep that stalls goes on as the serial sweep on every rank (doc/parallel.md §4): on
# masonry-arch at the case's own tolerance (scaled, 1e-11) the split sweep sat at 1.9e-9 and rank 1
# failed at step 185 with 200 000 sweeps; the run now ends as the serial one does
mpi 2 "$MOREAU" run "$c" --out "$OUT/arch-2" --quiet --set contact.nscd.split_min=0 --set contact.detect_split_min=0 \
  > "$OUT/arch-2.log" 2>&1
ran $? "$OUT/arch-2.log" "masonry-arch: mpirun -np 2 with every solve split completes"
is "$(json "$OUT/arch-2/summary.json" "[d['contact']['failed_solves'], d['parallel']['grain_sweeps'] > 0, d['parallel']['grain_serial_fallbacks'] > 0]")" \
  "[0, True, True]" "masonry-arch: every solve of the 2-rank run converged, split sweeps that stalled went on serial"
# the count over the ranks' closed contacts, gathered at the end of each split solve (T279, (T335)):
# 40 redundant unknowns at every step, as the serial run finds
is "$(json "$OUT/arch-2/summary.json" "[d['contact']['redundancy'][k] for k in ('max_redundant', 'steps_redundant')]")" \
  "$(json "$OUT/arch-1/summary.json" "[d['contact']['redundancy'][k] for k in ('max_redundant', 'steps_redundant')]")" \
  "masonry-arch split: the redundancy of the serial run ($(json "$OUT/arch-1/summary.json" "d['contact']['redundancy']['max_redundant']") unknowns at $(json "$OUT/arch-1/summary.json" "d['contact']['redundancy']['steps_redundant']") steps)"
detected_split arch
# the arch stands: its velocities are round-off (1e-11 m/s), so the runs are compared by the
# voussoirs' final positions (to 1e-9 m) and both runs' largest speed (below 1e-8 m/s)
is "$(/usr/bin/python3 -c "
import csv
a, b = (list(csv.DictReader(open('$OUT/arch-%d/bodies.csv' % k))) for k in (1, 2))
dx = max(abs(float(p[c]) - float(q[c])) for p, q in zip(a, b) for c in ('x', 'y'))
vm = max(abs(float(p[c])) for p in a + b for c in ('vx', 'vy'))
print([len(a) == len(b) == 38, dx < 1e-9, vm < 1e-8])")" "[True, True, True]" \
  "masonry-arch: the 2-rank arch stands where the serial one does, the voussoirs within 1e-9 m"
# the set distributed (doc/scaling.md §4): no serial sweep to go on with when the split sweep
# stalls, the arch converges split (each rank its own blocks' contacts, the interface point to point);
# the bodies' state whole on every rank (the abutments' prescribed dofs: doc/theory.md §13.18)
mpi 2 "$MOREAU" run "$c" --out "$OUT/arch-d2" --quiet --set contact.detect_split_min=0 --set contact.distributed_set=true \
  > "$OUT/arch-d2.log" 2>&1
ran $? "$OUT/arch-d2.log" "masonry-arch, the set distributed: mpirun -np 2 completes"
is "$(json "$OUT/arch-d2/summary.json" "[d['contact']['failed_solves'], d['parallel']['contact_set'], d['parallel']['bodies_state'], d['parallel']['grain_serial_fallbacks']] + [d['contact']['redundancy'][k] for k in ('max_redundant', 'steps_redundant')]")" \
  "[0, 'distributed', 'whole on every rank', 0, $(json "$OUT/arch-1/summary.json" "', '.join(str(d['contact']['redundancy'][k]) for k in ('max_redundant', 'steps_redundant'))")]" \
  "masonry-arch, the set distributed: every solve converged split, the serial run's redundancy"
is "$(/usr/bin/python3 -c "
import csv
a, b = (list(csv.DictReader(open('$OUT/arch-%s/bodies.csv' % k))) for k in ('1', 'd2'))
dx = max(abs(float(p[c]) - float(q[c])) for p, q in zip(a, b) for c in ('x', 'y'))
vm = max(abs(float(p[c])) for p in a + b for c in ('vx', 'vy'))
print([len(a) == len(b) == 38, dx < 1e-9, vm < 1e-8])")" "[True, True, True]" \
  "masonry-arch, the set distributed: the arch stands where the serial one does, the voussoirs within 1e-9 m"

# 4. a rank that fails alone does not leave the others waiting: rank 0's folder is locked
mkdir -p "$OUT/locked"
"$MOREAU" run "$MOREAU_SRCDIR/cases/rods-3d" --out "$OUT/locked" --quiet --set time.end=2e-5 > /dev/null 2>&1
( exec 9> "$OUT/locked/.lock"; flock -x 9; sleep 30 ) &
holder=$!
sleep 0.5
start=$(date +%s)
mpi 2 "$MOREAU" run "$MOREAU_SRCDIR/cases/rods-3d" --out "$OUT/locked" --quiet > "$OUT/locked.log" 2>&1
rc=$?
kill $holder 2> /dev/null
ok $([ "$rc" -ne 0 ] && [ $(($(date +%s) - start)) -lt 20 ] && echo 0 || echo 1) \
  "a folder another run holds: the 2-rank run stops (exit $rc) without waiting"
done_testing
