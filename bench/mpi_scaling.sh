#!/bin/sh
# mpi_scaling.sh: runs over MPI ranks, timed and counted (issue 17; doc/scaling.md). For each
# scene, a run on 1 rank with CHOLMOD (the serial program), on 1 rank with PETSc (MUMPS), and on
# NP ranks with PETSc, each with Open MPI's monitoring of every message (point to point and
# collective, counted at MPI_Finalize): the wall time of the steps (less the Delassus build of the
# first one), the factorization, the step,
# and the messages and bytes a step sends (a run of STEPS steps less a run of one step, over
# STEPS - 1); the element loop of the assembly (the slowest rank's seconds, summary.json
# parallel.element_seconds: each rank computes the matrices of its block of elements) and the
# largest peak memory of a rank (GNU time's maximum resident set, when /usr/bin/time is
# installed: apt-get install time; "-" without it) and the largest rank's rows of the Delassus
# build's columns What^-1 H^T over the rows (summary.json parallel.delassus_columns; "-" when the
# build did not take them: CHOLMOD's contact dofs last). Strong scaling: the same scene on 1 and NP
# ranks; weak: a scene NP times larger on NP ranks.
#
#   bench/mpi_scaling.sh [--np 2] [--steps 11] [--moreau build/moreau] [--out DIR] [--set KEY=VALUE]... [SCENE...]
#   bench/mpi_scaling.sh --assembly [--np 2] [box:N ...]
#
# --set KEY=VALUE: passed to every run (e.g. --set contact.distributed_set=true, doc/scaling.md §4).
# --assembly: K and M of each box on 1 and NP ranks, the scene's assembly (each rank its block of
# elements, then the sums: K and M whole on every rank) against the distributed one (each rank its
# elements straight into PETSc's matrices, its own rows only; doc/parallel.md §3), by
# bench/dist_assembly.c (built here with cc against the build's libmoreau): the slowest rank's
# seconds, the largest rank's bytes of K and M, the entries a rank stores and sends.
#
# SCENE: box:N (the H8 cube of bench/box_scaling.sh, N^3 elements, theta = 1, dt = 1e-4),
# pile:N (cases/disk-pile with N grains, h = 1 ms) or spheres:N (cases/sphere-deposit with N
# spheres, h = 1 ms). Default: box:14 box:18 box:21 pile:1000 pile:2000. For the grains, `ifc` is
# the mean count of interface bodies a solve (bodies touched by contacts of several ranks,
# summary.json parallel.grain_interface_bodies_mean) and `sweeps` the sweeps of the run.
# Needs a build configured --with-petsc, Open MPI's mpirun and python3. On a machine with fewer
# cores than ranks the times mean nothing (oversubscribed ranks wait for each other); the
# message counts and sizes do not depend on the machine.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
np=2
steps=11
assembly=0
moreau="$root/build/moreau"
out=""
scenes=""
extra=""
while [ $# -gt 0 ]; do
  case "$1" in
  --np) np=$2; shift ;;
  --steps) steps=$2; shift ;;
  --moreau) moreau=$2; shift ;;
  --out) out=$2; shift ;;
  --assembly) assembly=1 ;;
  --set) extra="$extra --set $2"; shift ;;
  -h|--help) sed -n '2,30p' "$0"; exit 0 ;;
  box:*|pile:*|spheres:*) scenes="$scenes $1" ;;
  *) echo "mpi_scaling.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
  shift
done
[ -n "$scenes" ] || scenes="box:14 box:18 box:21 pile:1000 pile:2000"
[ -x "$moreau" ] || { echo "mpi_scaling.sh: no moreau binary at $moreau" >&2; exit 2; }
command -v mpirun > /dev/null || { echo "mpi_scaling.sh: no mpirun (apt-get install openmpi-bin)" >&2; exit 3; }
if [ -z "$out" ]; then
  out=$(mktemp -d /tmp/mpi_scaling.XXXXXX)
  trap 'rm -rf "$out"' EXIT
fi
mkdir -p "$out"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMPI_MCA_rmaps_base_oversubscribe=1
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

case_of() { # case_of SCENE STEPS: the case file of a scene, and its --set arguments
  kind=${1%%:*}
  n=${1#*:}
  if [ "$kind" = box ]; then
    f="$out/box$n-$2.cfg"
    cat > "$f" <<EOF
title = "an H8 cube of $n^3 elements pressed on a frictionless rigid plane";
bodies = (
  { name = "box";
    mesh = { generator = "box"; size = [0.1, 0.1, 0.1]; elements = [$n, $n, $n]; };
    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; };
    loads = ( { type = "pressure"; set = "zmax"; value = 1.0e6; } ); },
  { name = "ground"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; }
);
time = { scheme = "theta"; theta = 1.0; dt = 1.0e-4; steps = $2; };
contact = { solver = "nscd";
  pairs = ( { name = "base"; slave = "box"; slave_set = "zmin"; master = "ground"; mu = 0.0; } ); };
output = { energy = false; };
EOF
    echo "$f"
  else
    c=disk-pile
    [ "$kind" = spheres ] && c=sphere-deposit
    echo "$root/cases/$c --set bodies.grains.pack.count=$n --set time.end=$(awk "BEGIN{print $2 * 1e-3}") --set output.vtk.every=1000000 --set output.draw.frames=1 --set output.draw.gif=false"
  fi
}

if [ "$assembly" = 1 ]; then
  lib=$(dirname "$moreau")/.libs
  cc -O2 -I "$root/src" -I "$(dirname "$moreau")" "$root/bench/dist_assembly.c" -L "$lib" -lmoreau -o "$out/dist_assembly" ||
    { echo "mpi_scaling.sh: bench/dist_assembly.c does not build" >&2; exit 2; }
  printf '%-8s %5s %8s %14s %16s %16s %18s %12s %10s %8s %9s\n' scene ranks dofs "scene build s" "replicated K+M MB" \
    "distributed s" "distributed K+M MB" "entries max" "sent max" "local" "rows max"
  for scene in $scenes; do
    case "$scene" in box:*) ;; *) continue ;; esac
    for p in 1 $np; do
      # shellcheck disable=SC2046
      mpirun -np "$p" env LD_LIBRARY_PATH="$lib" "$out/dist_assembly" $(case_of "$scene" 1) > "$out/asm.log" 2>&1 ||
        { echo "mpi_scaling.sh: $scene on $p ranks failed:" >&2; tail -3 "$out/asm.log" >&2; continue; }
      awk -v s="$scene" '/^ranks/ { printf "%-8s %5s %8s %14s %16s %16s %18s %12s %10s %8s %9s\n", s, $2, $4, $6, $8, $10, $12, $14, $16, $18, $20 }' "$out/asm.log"
    done
  done
  exit 0
fi

# one NAME NP SOLVER SCENE STEPS: a run, its summary and its message counts
one() {
  o_dir="$out/$1"
  o_args=$(case_of "$4" "$5")
  rm -f "$o_dir.rss"
  timer=""
  [ -x /usr/bin/time ] && timer="/usr/bin/time -a -f %M -o $o_dir.rss"
  # shellcheck disable=SC2086
  mpirun -np "$2" --mca pml_monitoring_enable 1 --mca pml_monitoring_enable_output 1 $timer \
    "$moreau" run $o_args --out "$o_dir" --quiet --set "linear_solver.type=\"$3\"" $extra > "$o_dir.log" 2>&1 ||
    { echo "mpi_scaling.sh: $1 failed:" >&2; tail -5 "$o_dir.log" >&2; return 1; }
}

# each rank's peak resident memory (kB), one line per rank appended to NAME.rss
rss() { # rss DIR: the largest rank's peak memory, MB
  if [ -s "$1.rss" ]; then awk '$1 ~ /^[0-9]+$/ && $1 > m { m = $1 } END { printf "%.1f", m / 1024 }' "$1.rss"; else echo -; fi
}
summary() { # summary DIR EXPR
  python3 -c "import json,sys; d=json.load(open(sys.argv[1]+'/summary.json')); print($2)" "$1"
}
traffic() { # traffic LOG: messages and bytes sent, point to point and collective, over the ranks
  awk -F'\t' '$1 == "E" || $1 == "C" { split($4, b, " "); split($5, m, " "); B += b[1]; M += m[1] }
              END { printf "%.0f %.0f\n", M, B }' "$1.log"
}

printf '%-12s %5s %-8s %10s %10s %10s %10s %12s %14s %10s %8s %10s %12s %8s %8s\n' scene ranks solver "steps s" "factor s" "W s" \
  "step ms" "msgs/step" "bytes/step" "setup MB" "elem s" "rank MB" "column rows" ifc sweeps
for scene in $scenes; do
  for cfg in "1 cholmod" "1 petsc" "$np petsc"; do
    set -- $cfg
    p=$1 solver=$2
    name="$(echo "$scene" | tr : -)-$p-$solver"
    one "$name-1" "$p" "$solver" "$scene" 1 || continue
    one "$name" "$p" "$solver" "$scene" "$steps" || continue
    set -- $(traffic "$out/$name-1") $(traffic "$out/$name")
    m1=$1 b1=$2 m=$3 b=$4
    # the steps less the Delassus build (the first step builds W)
    tsteps=$(summary "$out/$name" "d['timings']['steps'] - d['timings']['delassus']")
    tfac=$(summary "$out/$name" "d['timings']['factor']")
    tw=$(summary "$out/$name" "d['timings']['delassus']")
    telem=$(summary "$out/$name" "max(d['parallel']['element_seconds'])")
    # the largest rank's rows of the Delassus columns What^-1 H^T, of the rows (doc/parallel.md §2)
    crows=$(summary "$out/$name" "(lambda c: '%d/%d' % (c['rows_largest_rank'], c['rows']) if c else '-')(d['parallel'].get('delassus_columns'))")
    # the grains' interface bodies a solve and the sweeps (the pile's, over the ranks)
    ifc=$(summary "$out/$name" "'%.1f' % d['parallel']['grain_interface_bodies_mean'] if 'grain_interface_bodies_mean' in d.get('parallel', {}) else '-'")
    sw=$(summary "$out/$name" "d['contact'].get('iterations_total', '-') if '${scene%%:*}' != 'box' else '-'")
    printf '%-12s %5s %-8s %10.3f %10.3f %10.3f %10.2f %12.1f %14.0f %10.2f %8.3f %10s %12s %8s %8s\n' "$scene" "$p" "$solver" "$tsteps" \
      "$tfac" "$tw" "$(awk "BEGIN{print 1e3 * $tsteps / $steps}")" "$(awk "BEGIN{print ($m - $m1) / ($steps - 1)}")" \
      "$(awk "BEGIN{print ($b - $b1) / ($steps - 1)}")" "$(awk "BEGIN{print $b1 / 1e6}")" "$telem" "$(rss "$out/$name")" "$crows" "$ifc" "$sw"
  done
done
