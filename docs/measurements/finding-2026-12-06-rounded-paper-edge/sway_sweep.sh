#!/bin/bash
# sway_sweep.sh: the pooled fit on the paper's rig, the rectangle rounded by 1 mm, with the
# tip's sway at 0, 0.02, 0.04, 0.08, 0.12 mm/N (the default's stiffness scale; the fit's is
# 0.2288) and all else as fitted: each sway's taps, slides and held-out taps (run.sh of the
# shipped scenarios, TABLES_ONLY) in sway_S/, then `twin evaluate --shift-free`; prints each
# sway's PCA + GP row, its GP baseline row, its row with the uniform shift out and the
# along-edge drag in the PC2–PC3 plane. A sway's folder that holds completed runs is reused.
# usage: bash sway_sweep.sh [path/to/twin] > sway-paper.txt   (about 2 minutes a sway here)
set -e
twin=$(realpath "${1:-$(dirname "$0")/../../../.venv/bin/twin}")
here=$(cd "$(dirname "$0")" && pwd)
for s in 0 0.02 0.04 0.08 0.12; do
  mkdir -p sway_$s
  sed "s/tip_sway_mm_per_n: 0.2288/tip_sway_mm_per_n: $s/" "$here/../finding-2026-12-06-pooled-fit/pooledfit.yaml" \
      > sway_$s/fitted.yaml
  OUT=$PWD/sway_$s FITTED=$PWD/sway_$s/fitted.yaml FRICTION_SCALE=0.366 EDGE_RADIUS_MM=1 TABLES_ONLY=1 \
      bash "$here/../finding-2026-12-05-shipped-scenarios/run.sh" "$twin" > /dev/null
  "$twin" evaluate --train sway_$s/runs/taps_rectangle --test sway_$s/runs/slides_rectangle --shift-free \
      --out sway_$s/runs/eval_sf > sway_$s/table-i.txt
  echo "tip sway $s mm/N:"
  grep -E "^(model|twin PCA|twin GP)|drag in the plane" sway_$s/table-i.txt
done
