#!/bin/bash
# screen.sh NAME TAPS: replay runs/NAME.yaml (variants.sh) on an imported recording's taps (TAPS, a folder), then
# the edge figures beside the recording's, with the reach at l = ±4.5 mm, into cmp-NAME-TAPS.txt
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
taps=$(basename "$2")
twin run "runs/$1.yaml" --taps-from "$2" --workers 2 --quiet --out "runs/$1_$taps"
twin compare "$2" "runs/$1_$taps" --reach-at -4.5 4.5 --out "runs/$1_${taps}_cmp" > "cmp-$1-$taps.txt"
