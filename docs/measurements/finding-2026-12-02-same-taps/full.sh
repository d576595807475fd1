#!/bin/bash
# full.sh REAL NAME [NAME ...]: replay NAME.yaml on every tap of the imported recording REAL,
# then the edge figures on the same taps beside the recording's (twin compare, 50 paired
# bootstrap resamples) and the pin misfit (finding-2026-11-29-sensor-roll's pin_misfit.py)
set -e
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl
here=$(dirname "$0")
real=$1
shift
for n in "$@"; do
  twin run "$n.yaml" --taps-from "$real" --workers 2 --quiet --out "runs/${n}_full" > /dev/null
  twin compare "$real" "runs/${n}_full" --out "runs/${n}_full_compare" --reach-at -4.5 4.5 > "compare-full-$n.txt"
  python "$here/../finding-2026-11-29-sensor-roll/pin_misfit.py" "$real" 5001 "runs/${n}_full" | tail -1
done
