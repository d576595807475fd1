#!/bin/bash
# hard_case.sh: hard_case.py on the plain solid (no physics) and on the fitted dome
# (fitted.yaml) at 1.8 mm, 1.0 mm and the reference level, each stopped after 300 s.
# usage: bash hard_case.sh [path/to/python] > hard-case.txt
cd "$(dirname "$0")"
py=${1:-../../../.venv/bin/python}
while read -r name level extra; do
  echo "$name"
  timeout 300 "$py" hard_case.py $level $extra
  [ $? = 124 ] && echo "  stopped after 300 s"
done <<LIST
plain-solid-1.5mm default surface_spacing_mm=1.5
plain-solid-1.0mm default surface_spacing_mm=1.0
plain-solid-reference reference
fitted-1.8mm default --fitted surface_spacing_mm=1.8
fitted-1.0mm default --fitted surface_spacing_mm=1.0
fitted-reference reference --fitted
LIST
