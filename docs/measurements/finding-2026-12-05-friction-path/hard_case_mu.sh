#!/bin/bash
# hard_case_mu.sh: the suite's slide and reversal (../finding-2026-12-05-shipped-scenarios/
# hard_case.py) on the fitted dome, scaled to the 4.3 N edge press, at 1.0 mm nodes and
# at the reference level, at μ = 1, 2 and 3, each case stopped after 300 s.
# usage: bash hard_case_mu.sh [path/to/python] > hard-case-mu.txt
cd "$(dirname "$0")/../finding-2026-12-05-shipped-scenarios"
py=${1:-../../../.venv/bin/python}
for mu in 1 2 3; do
  for level in "default surface_spacing_mm=1.0" "reference"; do
    echo "mu $mu, $level"
    timeout 300 "$py" hard_case.py $level --fitted --scaled --friction=$mu
    [ $? = 124 ] && echo "  stopped after 300 s"
  done
done
