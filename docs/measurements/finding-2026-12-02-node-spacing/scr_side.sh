#!/bin/bash
# scr_side.sh NAME REAL SIDE L: replay NAME.yaml on the taps of REAL (a recording made by
# finding-2026-11-29-pin-posts' quarter.py … --at-laterals), compare them with REAL (the
# reach profile at l = L mm), and print the edge figures; the run goes to runs/NAME_SIDE
# and the comparison to compare-SIDE-NAME.txt.
set -e
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl
T=${TWIN_BIN:-.venv/bin}
$T/twin run "$1.yaml" --taps-from "$2" --workers 2 --quiet --out "runs/$1_$3" > /dev/null
$T/twin compare "$2" "runs/$1_$3" --out "runs/$1_$3_compare" --reach-at "$4" > "compare-$3-$1.txt"
$T/python "$(dirname "$0")/../finding-2026-11-29-pin-posts/figure_rows.py" "compare-$3-$1.txt"
