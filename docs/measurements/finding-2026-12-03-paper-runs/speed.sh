#!/bin/bash
# Whole-run wall times of the paper's taps and slides, the flex default (the shipped
# scenarios) and the fitted dome alternated, twice, 2 workers each. usage: bash speed.sh [twin]
twin=${1:-../../../.venv/bin/twin}
cd "$(dirname "$0")"
rm -f speed.txt
for round in 1 2; do
  for s in ../../../scenarios/taps_rectangle.yaml taps_rectangle_fit.yaml ../../../scenarios/slides_rectangle.yaml slides_rectangle_fit.yaml; do
    rm -rf runs/speed
    /usr/bin/time -f "$round $(basename $s .yaml) %e s" -a -o speed.txt "$twin" run $s --workers 2 --quiet --out runs/speed > /dev/null
  done
done
