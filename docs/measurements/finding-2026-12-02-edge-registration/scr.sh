#!/bin/bash
# scr.sh NAME REAL: replay NAME.yaml on every fourth tap of the imported recording REAL, then
# the edge figures beside the recording's (twin compare), four of them as rows
# (finding-2026-11-29-pin-posts' figure_rows.py) and the pin misfit on the same taps
# (finding-2026-11-29-sensor-roll's pin_misfit.py)
set -e
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl
here=$(dirname "$0")
twin run "$1.yaml" --taps-from "$2" --every-nth-tap 4 --workers 2 --quiet --out "runs/$1_q" > /dev/null
twin compare "$2" "runs/$1_q" --out "runs/$1_q_compare" --reach-at -4.5 4.5 > "compare-q-$1.txt"
echo "== $1"
python "$here/../finding-2026-11-29-pin-posts/figure_rows.py" "compare-q-$1.txt"
python "$here/../finding-2026-11-29-sensor-roll/pin_misfit.py" "$2" every:4 "runs/$1_q" | tail -1
