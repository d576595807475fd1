#!/bin/bash
# variants.sh: the screened domes, written to runs/ beside this script: each one change to the fitted
# dome (../finding-2026-12-04-lever-friction-fit/fitfrom.yaml; a material value is set in
# both the calibration's dome_material, which a replay reads, and the scenario's physics)
set -e
mkdir -p "$(dirname "$0")/runs" && cd "$(dirname "$0")/runs"
v() { python ../../finding-2026-11-29-pin-posts/variant.py ../../finding-2026-12-04-lever-friction-fit/fitfrom.yaml "$@"; }
cp ../../finding-2026-12-04-lever-friction-fit/fitfrom.yaml base.yaml
for h in 70 75 80 85; do v held$h material.skin_held_deg=$h physics.skin_held_deg=$h; done
v held75_sway085 material.skin_held_deg=75 physics.skin_held_deg=75 \
  material.tip_sway_mm_per_n=0.085 physics.tip_sway_mm_per_n=0.085
v thick3 material.skin_thickening=3 physics.skin_thickening=3
v apex20 physics.apex_radius_mm=20
v nosway material.tip_sway_mm_per_n=0 physics.tip_sway_mm_per_n=0
v membrane005 material.membrane_young_mpa=0.05 physics.membrane_young_mpa=0.05
v noyield "calibration.arm_yield_mm_per_n=[0,0,0]"
v open physics.gel_enclosed=false
v poisson045 material.poisson=0.45
v poisson040 material.poisson=0.4
v bend029 material.skin_bending_mpa=0.29 physics.skin_bending_mpa=0.29
v bend01 material.skin_bending_mpa=0.1 physics.skin_bending_mpa=0.1
v shallow1 "calibration.tcp_offset_mm=[0,0,-1.51]"
v yieldz04 "calibration.arm_yield_mm_per_n=[0.05,0,-0.4]"
