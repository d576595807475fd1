#!/bin/bash
# paper.sh TAG HELD [SWAY]: the paper's taps, slides and held-out taps on the DigiTac-fitted
# dome (../finding-2026-12-03-paper-runs/) with the skin held HELD degrees from the apex (and
# the tip's sway SWAY mm/N, else its 0.012), then `twin evaluate` into table-i-TAG.txt and
# heldout-TAG.txt (about 2 minutes on 2 cores). e.g. paper.sh h75 75; paper.sh h75s085 75 0.085
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
cd "$(dirname "$0")"
mkdir -p runs
for s in taps_rectangle slides_rectangle taps_heldout; do
  sed -e "s/skin_held_deg: 90/skin_held_deg: $2/" -e "s/tip_sway_mm_per_n: 0.012/tip_sway_mm_per_n: ${3:-0.012}/" \
    -e "s/^name: ${s}_fit/name: ${s}_$1/" ../finding-2026-12-03-paper-runs/${s}_fit.yaml > runs/${s}_$1.yaml
  twin run runs/${s}_$1.yaml --workers 2 --quiet --out runs/${s}_$1
done
twin evaluate --train runs/taps_rectangle_$1 --test runs/slides_rectangle_$1 --out runs/eval_$1 > table-i-$1.txt
twin evaluate --train runs/taps_rectangle_$1 --test runs/taps_heldout_$1 --out runs/eval_heldout_$1 > heldout-$1.txt
