#!/bin/bash
# variants.sh: the screened domes, written to runs/ beside this script: each one change to the fitted
# dome (../finding-2026-12-04-lever-friction-fit/fitfrom.yaml), or the skin held at 75° with a
# stiffer membrane (a material value is set in both the calibration's dome_material, which a
# replay reads, and the scenario's physics)
set -e
mkdir -p "$(dirname "$0")/runs" && cd "$(dirname "$0")/runs"
v() { python ../../finding-2026-11-29-pin-posts/variant.py ../../finding-2026-12-04-lever-friction-fit/fitfrom.yaml "$@"; }
cp ../../finding-2026-12-04-lever-friction-fit/fitfrom.yaml base.yaml
held() { echo material.skin_held_deg=$1 physics.skin_held_deg=$1; }
membrane() { echo material.membrane_young_mpa=$1 physics.membrane_young_mpa=$1; }
sway() { echo material.tip_sway_mm_per_n=$1 physics.tip_sway_mm_per_n=$1; }
# what the dome took on after the posts of 2026-11-29, each taken back
v cam26 calibration.camera.focal_px=59.27766 calibration.camera.distortion.k1=-0.07824 \
  calibration.camera.distortion.k2=0.00749 "calibration.camera.offset_mm=[0,0,26.1222]"
v wholenodes physics.edge_within_node=false
v sharp object.edge_radius_mm=null
v lever2 physics.pin_lever_mm=null
v f055 calibration.friction=0.55
v sway014 $(sway 0.1437)
v deep08 "calibration.tcp_offset_mm=[0,0,-0.8]"
v notilt "calibration.tcp_tilt_deg=[0,0]"
# and past it
v lever3 physics.pin_lever_mm=3
v f13 calibration.friction=1.3
# the skin held at 75° with a stiffer membrane (0.22 MPa fitted), and with the sway; one held at 80°
v held75 $(held 75)
for m in 0.5 1.0; do v held75_m$m $(held 75) $(membrane $m); done
for s in 0.15 0.30; do v held75_m0.5_s${s/./} $(held 75) $(membrane 0.5) $(sway $s); done
v held80_m0.5_s015 $(held 80) $(membrane 0.5) $(sway 0.15)
