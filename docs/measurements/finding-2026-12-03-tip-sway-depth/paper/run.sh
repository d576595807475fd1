#!/bin/bash
# run.sh: the paper's taps and slides (the twin's own camera and rig) on the skin-bending ×3
# dome with the edge within nodes at the pins' tip sway (0.012 mm/N), straight and tilted
# (−1°, −1°) on its mount, then Table I (twin evaluate)
set -e
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl
cd "$(dirname "$0")"
for tag in "" _t11; do
  twin run taps$tag.yaml --workers 1 --quiet --out runs/taps$tag > /dev/null
  twin run slides$tag.yaml --workers 1 --quiet --out runs/slides$tag > /dev/null
  twin evaluate --train runs/taps$tag --test runs/slides$tag --out runs/eval$tag > table-i$tag.txt
done
