#!/bin/bash
# run.sh: the paper's taps and slides (the twin's own camera and rig) with the stiffer skin,
# the edge within nodes, then Table I (twin evaluate)
set -e
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl
cd "$(dirname "$0")"
twin run taps.yaml --workers 2 --quiet --out runs/taps > /dev/null
twin run slides.yaml --workers 2 --quiet --out runs/slides > /dev/null
twin evaluate --train runs/taps --test runs/slides --out runs/eval > table-i.txt
