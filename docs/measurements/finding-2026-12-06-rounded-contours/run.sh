#!/bin/bash
# run.sh: the paper's taps, slides, held-out taps and the six contours (and two as user STL
# objects) with every object's top edge rounded by 1 mm, as the fitted DigiTac edge is, on
# three domes: the shipped default (default/), the pooled fit (pooled/) and the pooled fit
# with no tip sway (sway0/); each dome's Table I, held-out taps and contours beside this
# script as DOME-table-i.txt, DOME-heldout.txt, DOME-contours.txt. A dome's folder that holds
# completed runs is reused. About 3 minutes a dome on this host, 6 for the pooled fit's
# contours, which run to their step limit.
# usage: bash run.sh [path/to/twin]
set -e
twin=$(realpath "${1:-$(dirname "$0")/../../../.venv/bin/twin}")
here=$(cd "$(dirname "$0")" && pwd)
shipped="$here/../finding-2026-12-05-shipped-scenarios/run.sh"
pooled="$here/../finding-2026-12-06-pooled-fit/pooledfit.yaml"
mkdir -p default pooled sway0
sed "s/tip_sway_mm_per_n: 0.2288/tip_sway_mm_per_n: 0.0/" "$pooled" > sway0/fitted.yaml
export EDGE_RADIUS_MM=1 CONTOUR_EDGE_RADIUS_MM=1
OUT=$PWD/default AS_SHIPPED=1 bash "$shipped" "$twin" > /dev/null
OUT=$PWD/pooled FITTED="$pooled" FRICTION_SCALE=0.366 bash "$shipped" "$twin" > /dev/null
OUT=$PWD/sway0 FITTED=$PWD/sway0/fitted.yaml FRICTION_SCALE=0.366 bash "$shipped" "$twin" > /dev/null
for dome in default pooled sway0; do
  cp $dome/table-i.txt "$here/$dome-table-i.txt"
  cp $dome/heldout.txt "$here/$dome-heldout.txt"
  cp $dome/contours.txt "$here/$dome-contours.txt"
done
