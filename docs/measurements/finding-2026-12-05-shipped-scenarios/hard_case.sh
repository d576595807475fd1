#!/bin/bash
# hard_case.sh: hard_case.py on the plain solid (no physics) and on the fitted dome
# (run.sh's physics) at 1.8 mm, 1.0 mm and the reference level, each stopped after 300 s.
# usage: bash hard_case.sh [path/to/python] > hard-case.txt
cd "$(dirname "$0")"
py=${1:-../../../.venv/bin/python}
fitted="membrane_young_mpa=0.5 gel_young_kpa=40 skin_bending=true skin_bending_mpa=0.8664 skin_held_deg=75 pin_lever_mm=1.55 tip_sway_mm_per_n=0.063 apex_radius_mm=30"
while read -r name level extra; do
  echo "$name"
  timeout 300 "$py" hard_case.py $level $extra
  [ $? = 124 ] && echo "  stopped after 300 s"
done <<LIST
plain-solid-1.5mm default
plain-solid-1.0mm default surface_spacing_mm=1.0
plain-solid-reference reference
fitted-1.8mm default $fitted surface_spacing_mm=1.8
fitted-1.0mm default $fitted surface_spacing_mm=1.0
fitted-reference reference $fitted
LIST
