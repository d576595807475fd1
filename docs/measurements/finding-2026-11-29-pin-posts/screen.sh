#!/bin/bash
# screen.sh NAME QUARTER: replay NAME.yaml on the quarter set (quarter.py), then the edge
# figures per lateral bin beside the real's (twin compare) and the pin misfit (pin_misfit.py)
set -e
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl
here=$(dirname "$0")
twin run "$1.yaml" --taps-from "$2" --workers 2 --quiet --out "runs/$1_quarter"
twin compare "$2" "runs/$1_quarter" --out "runs/$1_quarter_compare" > "compare-$1-quarter.txt"
echo "== $1"
python "$here/figure_rows.py" "compare-$1-quarter.txt"
python "$here/../finding-2026-11-29-sensor-roll/pin_misfit.py" "$2" 5000 "runs/$1_quarter" | tail -1
