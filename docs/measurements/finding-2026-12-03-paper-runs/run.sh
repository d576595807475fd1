#!/bin/bash
# The paper's runs on the dome fitted to the DigiTac recording, and their figures, in this
# folder (about 10 minutes on 2 cores). usage: bash run.sh [path/to/twin]
set -e
twin=${1:-../../../.venv/bin/twin}
py=$(dirname "$twin")/python
cd "$(dirname "$0")"
for s in taps_rectangle_fit slides_rectangle_fit taps_heldout_fit; do
  "$twin" run $s.yaml --workers 2 --quiet --out runs/$s
done
"$twin" evaluate --train runs/taps_rectangle_fit --test runs/slides_rectangle_fit --out runs/eval > table-i.txt
"$twin" evaluate --train runs/taps_rectangle_fit --test runs/taps_heldout_fit --out runs/eval_heldout > heldout.txt
"$py" objects_stl.py
for o in rectangle large_circle small_circle flower spiral tape_measure rectangle_stl flower_stl; do
  "$twin" run contour_${o}_fit.yaml --workers 1 --quiet --out runs/contour_${o}_fit
done
{ "$py" contours.py runs/contour_{rectangle,large_circle,small_circle,flower,spiral,tape_measure}_fit
  echo; "$py" contours.py runs/contour_{rectangle,flower}_stl_fit; } > contours.txt
# friction screens: the taps and slides again with one change each, then evaluate
for mu in 0.5 0.3 0.1 0.0; do
  tag=f${mu/./}
  for s in taps_rectangle slides_rectangle; do
    sed -e "s/friction: 0.95/friction: $mu/" -e "s/^name: ${s}_fit/name: ${s}_$tag/" ${s}_fit.yaml > runs/${s}_$tag.yaml
    "$twin" run runs/${s}_$tag.yaml --workers 2 --quiet --out runs/${s}_$tag
  done
  "$twin" evaluate --train runs/taps_rectangle_$tag --test runs/slides_rectangle_$tag --out runs/eval_$tag > table-i-$tag.txt
done
"$py" slide_figures.py runs/taps_rectangle_fit runs/slides_rectangle_fit \
  runs/taps_rectangle_f05 runs/slides_rectangle_f05 runs/taps_rectangle_f03 runs/slides_rectangle_f03 \
  runs/taps_rectangle_f01 runs/slides_rectangle_f01 runs/taps_rectangle_f00 runs/slides_rectangle_f00 > slide-figures.txt
"$py" cross_planes.py > cross-planes.txt
"$py" drag_by_pc.py runs/taps_rectangle_fit runs/slides_rectangle_fit > drag-by-pc.txt
