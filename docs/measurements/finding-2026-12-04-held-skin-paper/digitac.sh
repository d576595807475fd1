#!/bin/bash
# digitac.sh: the held skin at 0.063 mm/N of sway (friction 0.7) replayed on the DigiTac
# recording's taps at l = +4, +5 and −4, −5 (real45, realm45: ../finding-2026-12-04-reach-screen/),
# beside the same skin at 0.15 mm/N (../finding-2026-12-04-yield-carried/), into
# cmp-held75_m0.5_s0063_f07-{real45,realm45}.txt and rows-{off,onto}.txt. Run in a folder with
# links real45, realm45 to the imports (about 8 minutes on 2 cores).
set -e
here=$(realpath "$(dirname "$0")")
mkdir -p runs
(cd runs && python "$here/../finding-2026-11-29-pin-posts/variant.py" "$here/../finding-2026-12-04-lever-friction-fit/fitfrom.yaml" \
  held75_m0.5_s0063_f07 material.skin_held_deg=75 physics.skin_held_deg=75 material.membrane_young_mpa=0.5 \
  physics.membrane_young_mpa=0.5 material.tip_sway_mm_per_n=0.063 physics.tip_sway_mm_per_n=0.063 calibration.friction=0.7)
for taps in real45 realm45; do bash "$here/../finding-2026-12-04-skin-held/screen.sh" held75_m0.5_s0063_f07 $taps; done
carried=$here/../finding-2026-12-04-yield-carried
python "$here/../finding-2026-12-04-skin-held/rows.py" "$carried/cmp-held75_m0.5_s015_f07-real45.txt" cmp-held75_m0.5_s0063_f07-real45.txt > rows-off.txt
python "$here/../finding-2026-12-04-skin-held/rows.py" --reach-at -4.5 "$carried/cmp-held75_m0.5_s015_f07-realm45.txt" cmp-held75_m0.5_s0063_f07-realm45.txt > rows-onto.txt
