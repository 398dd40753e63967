#!/bin/sh
# test_mumps_ooc.sh: MUMPS's factor out of core (doc/theory.md (T181)-(T182)). The 12^3 H8 box
# pressed on a plane, 3 steps, through PETSc's MUMPS in core and out of core (linear_solver.
# out_of_core = true): the histories agree to 1e-10, summary.json states MUMPS's estimates before
# the numeric factorization, the folder of the factor's files is gone after the run; the keys'
# bad uses are refused naming them. Skipped by builds without PETSc.
. "$MOREAU_SRCDIR/tests/tap.sh"
if [ "$MOREAU_HAVE_PETSC" != yes ]; then
  echo "1..0 # SKIP this build has no PETSc (configure --with-petsc)"
  exit 0
fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
mkdir -p "$OUT/ooc"
cat > "$OUT/box.cfg" <<CFG
title = "the 12^3 box of bench/box_scaling.sh, 3 steps";
bodies = (
  { name = "box";
    mesh = { generator = "box"; size = [0.1, 0.1, 0.1]; elements = [12, 12, 12]; };
    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; };
    loads = ( { type = "pressure"; set = "zmax"; value = 1.0e6; } ); },
  { name = "ground"; type = "plane"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; }
);
time = { scheme = "theta"; theta = 1.0; dt = 1.0e-4; steps = 3; };
contact = { solver = "nscd";
  pairs = ( { name = "base"; slave = "box"; slave_set = "zmin"; master = "ground"; mu = 0.0; } ); };
output = { energy = false; precision = 17; };
CFG
petsc='linear_solver.type="petsc"'
"$MOREAU" run "$OUT/box.cfg" --out "$OUT/in" --quiet --set "$petsc" > "$OUT/in.log" 2>&1
ran $? "$OUT/in.log" "the 12^3 box in core (MUMPS) completes"
"$MOREAU" run "$OUT/box.cfg" --out "$OUT/out" --quiet --set "$petsc" --set linear_solver.out_of_core=true \
  --set "linear_solver.ooc_dir=\"$OUT/ooc\"" > "$OUT/out.log" 2>&1
ran $? "$OUT/out.log" "the 12^3 box out of core (MUMPS) completes"
/usr/bin/python3 "$MOREAU_SRCDIR/tests/compare_runs.py" "$OUT/in" "$OUT/out" 1e-10 > "$OUT/cmp" 2>&1 ||
  echo "1	compare_runs.py crashed: $(tail -1 "$OUT/cmp")" >> "$OUT/cmp"
while IFS= read -r line; do
  case "$line" in
    [01]'	'*) ok "${line%%	*}" "out of core against in core: ${line#*	}" ;;
    *) echo "# $line" ;;
  esac
done < "$OUT/cmp"
is "$(json "$OUT/out/summary.json" "(lambda L: [L['out_of_core'], L['contact_dofs_last'], 0 < L['bytes_mumps_out_of_core'] <= L['bytes_mumps_in_core'], L['bytes_workspace'] == L['bytes_mumps_out_of_core'], L['ordering'].endswith(', given to mumps (INFOG(7) = 1)')])(d['linear_solver'])")" \
  "[True, 507, True, True, True]" "summary.json: out of core, the 507 contact dofs as Schur variables in CHOLMOD's order (INFOG(7) = 1), MUMPS's estimates ($(json "$OUT/out/summary.json" "'%.3g in core, %.3g out of core' % (d['linear_solver']['bytes_mumps_in_core'], d['linear_solver']['bytes_mumps_out_of_core'])"))"
is "$(json "$OUT/in/summary.json" "d['linear_solver']['out_of_core']")" "False" "summary.json: the in-core run says so"
is "$(ls -A "$OUT/ooc" | wc -l)" "0" "the folder of the out-of-core factor is removed after the run"
# bad uses of the keys
e=$("$MOREAU" check "$OUT/box.cfg" --set linear_solver.out_of_core=true 2>&1)
is "$?" "2" "out_of_core with CHOLMOD: refused as bad input"
contains "$e" "linear_solver.out_of_core" "out_of_core with CHOLMOD: the message names the key"
contains "$e" "mumps" "out_of_core with CHOLMOD: the message says what it needs"
e=$("$MOREAU" check "$OUT/box.cfg" --set "$petsc" --set 'linear_solver.ooc_dir="/tmp"' 2>&1)
is "$?" "2" "ooc_dir without out_of_core: refused as bad input"
contains "$e" "linear_solver.ooc_dir" "ooc_dir without out_of_core: the message names the key"
e=$("$MOREAU" run "$OUT/box.cfg" --out "$OUT/bad" --quiet --set "$petsc" --set linear_solver.out_of_core=true \
  --set "linear_solver.ooc_dir=\"$OUT/no/such/folder\"" 2>&1)
ok "$([ $? -ne 0 ] && echo 0 || echo 1)" "ooc_dir that does not exist: the run fails"
contains "$e" "linear_solver.ooc_dir" "ooc_dir that does not exist: the message names the key"
done_testing
