# pile_scene.sh (sourced by box2d_pile.sh and granular_scaling.sh): the deposition scene of N
# grains, as every peer builds it. The box is as wide as 33 sqrt(N / 1000) lattice columns of
# 13.2 mm (cases/disk-pile: 33 columns for 1000 grains) and tall enough for the lattice.
# pile_geometry N: sets cols, w (width, m) and hbox (height of the packed box, m).
pile_geometry() {
  cols=$(awk -v n="$1" 'BEGIN { c = int(33 * sqrt(n / 1000) + 0.5); print (c < 1 ? 1 : c) }')
  w=$(awk -v c="$cols" 'BEGIN { printf "%.6g", c * 0.0132 }')
  hbox=$(awk -v n="$1" -v c="$cols" 'BEGIN { printf "%.6g", 0.0132 * (int(n / c) + 2) }')
}
# pile_run MOREAU ROOT N END OUT [SETS...]: moreau on the scene of N grains to END into OUT, without
# the VTK series and with one final drawing, quietly.
pile_run() {
  pr_moreau=$1; pr_root=$2; pr_n=$3; pr_end=$4; pr_out=$5
  shift 5
  pile_geometry "$pr_n"
  "$pr_moreau" run "$pr_root/cases/disk-pile" --set "bodies.grains.pack.count=$pr_n" \
    --set "bodies.grains.pack.box=[0.0,$w,0.0,$hbox]" --set "bodies.right.point=[$w,0.0]" --set "time.end=$pr_end" \
    --set output.vtk.every=100000000 --set output.draw.frames=1 --set output.draw.gif=false "$@" \
    --out "$pr_out" --quiet
}
