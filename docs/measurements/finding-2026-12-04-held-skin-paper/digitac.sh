#!/bin/bash
# digitac.sh: the held skin (75°, 0.5 MPa) at the sways and frictions run on the paper's rig,
# replayed on the DigiTac recording's taps at l = +4, +5 and −4, −5 (real45, realm45:
# ../finding-2026-12-04-reach-screen/), into cmp-NAME-{real45,realm45}.txt, and beside the
# same skin at 0.15 mm/N (../finding-2026-12-04-yield-carried/) into rows-{off,onto}.txt.
# Run in a folder with links real45, realm45 to the imports (about 8 minutes a dome on 2 cores).
set -e
here=$(realpath "$(dirname "$0")")
held="material.skin_held_deg=75 physics.skin_held_deg=75 material.membrane_young_mpa=0.5 physics.membrane_young_mpa=0.5"
sway() { echo "material.tip_sway_mm_per_n=$1 physics.tip_sway_mm_per_n=$1"; }
mkdir -p runs
v() { (cd runs && python "$here/../finding-2026-11-29-pin-posts/variant.py" "$here/../finding-2026-12-04-lever-friction-fit/fitfrom.yaml" "$@"); }
v held75_m0.5_s0063_f07 $held $(sway 0.063) calibration.friction=0.7
v held75_m0.5_s0063_f07_whole $held $(sway 0.063) calibration.friction=0.7 physics.edge_within_node=false
v held75_m0.5_s0076_f07_whole $held $(sway 0.076) calibration.friction=0.7 physics.edge_within_node=false
v held75_m0.5_s0076_f09_whole $held $(sway 0.076) calibration.friction=0.9 physics.edge_within_node=false
v held75_m0.5_s0063_f09_whole $held $(sway 0.063) calibration.friction=0.9 physics.edge_within_node=false
v held75_m0.5_s0063_f09_whole_apex20 $held $(sway 0.063) calibration.friction=0.9 physics.edge_within_node=false \
  physics.apex_radius_mm=20
v held75_m0.5_s0063_f09_whole_sp18 $held $(sway 0.063) calibration.friction=0.9 physics.edge_within_node=false \
  physics.surface_spacing_mm=1.8
names="held75_m0.5_s0063_f07 held75_m0.5_s0063_f07_whole held75_m0.5_s0076_f07_whole held75_m0.5_s0076_f09_whole
  held75_m0.5_s0063_f09_whole held75_m0.5_s0063_f09_whole_apex20 held75_m0.5_s0063_f09_whole_sp18"
for n in $names; do for taps in real45 realm45; do
  bash "$here/../finding-2026-12-04-skin-held/screen.sh" $n $taps
done; done
carried=$here/../finding-2026-12-04-yield-carried
python "$here/../finding-2026-12-04-skin-held/rows.py" "$carried/cmp-held75_m0.5_s015_f07-real45.txt" \
  $(for n in $names; do echo cmp-$n-real45.txt; done) > rows-off.txt
python "$here/../finding-2026-12-04-skin-held/rows.py" --reach-at -4.5 "$carried/cmp-held75_m0.5_s015_f07-realm45.txt" \
  $(for n in $names; do echo cmp-$n-realm45.txt; done) > rows-onto.txt
