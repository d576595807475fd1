#!/bin/bash
# variants.sh: the screened domes, written to runs/ beside this script: the fitted dome
# (../finding-2026-12-04-lever-friction-fit/fitfrom.yaml) and the skin held at 75° with a
# 0.5 MPa membrane and 0.15 mm/N of sway (../finding-2026-12-04-reach-screen/variants.sh),
# each replayed with the arm's yield carried through the slides, and the latter with adhesion
set -e
mkdir -p "$(dirname "$0")/runs" && cd "$(dirname "$0")/runs"
v() { python ../../finding-2026-11-29-pin-posts/variant.py ../../finding-2026-12-04-lever-friction-fit/fitfrom.yaml "$@"; }
cp ../../finding-2026-12-04-lever-friction-fit/fitfrom.yaml base.yaml
held75_stiff_sway="material.skin_held_deg=75 physics.skin_held_deg=75 material.membrane_young_mpa=0.5
  physics.membrane_young_mpa=0.5 material.tip_sway_mm_per_n=0.15 physics.tip_sway_mm_per_n=0.15"
v held75_m0.5_s015 $held75_stiff_sway
v held75_m0.5_s015_a10 $held75_stiff_sway physics.adhesion_kpa=10
v held75_m0.5_s015_f07 $held75_stiff_sway calibration.friction=0.7
v held75_m0.5_s015_f06_a10 $held75_stiff_sway calibration.friction=0.6 physics.adhesion_kpa=10
