#!/bin/sh
# collapse.sh: the runout law of the column collapse (README): the case run for aspect ratios
# a = H0 / L0 from about 0.5 to 8 (the number of grains sets H0; moreau compare --vary), then
# runout.py reads each run's settled height (history.csv, rigid.ymax at the gate's opening) and
# the front of its deposit (bodies.csv), fits the two regimes and draws runout.png.
#   cases/column-collapse/collapse.sh [MOREAU] [OUT] [COUNTS]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
moreau=${1:-$here/../../build/moreau}
out=${2:-out/collapse}
counts=${3:-195,390,585,780,1170,1575,2355,3150}
"$moreau" compare "$here" --solvers nscd --vary "bodies.grains.pack.count=$counts" --out "$out"
/usr/bin/python3 "$here/runout.py" "$out"
