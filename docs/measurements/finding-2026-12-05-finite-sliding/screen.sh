#!/bin/bash
# screen.sh: in a folder holding fit500 (every tenth DigiTac tap, ../finding-2026-12-04-held-skin-paper/README.md):
# the fit's dome (../finding-2026-12-04-coarser-lattice/fitfrom-sp18.yaml at friction 0.773, as fit.yaml) replayed on
# its 500 taps, then with finite sliding, and with finite sliding at sway 0.03 mm/N or friction 0.6; each replay's
# edge figures against the recording's (../finding-2026-12-05-across-fit/screen_summary.py) → screen.txt's first
# table; then finite sliding with adhesion 5 kPa, the pin tips in the gel or a 1 mm lever → its third table; then
# adhesion 7.5, 10 and 15 kPa, and 10 kPa at friction 0.7 or 0.5 → its last table (a replay that stops at a
# PhysicsError leaves the taps before it)
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
here=$(cd "$(dirname "$0")" && pwd)
twin=$here/../../../.venv/bin/twin py=$here/../../../.venv/bin/python
variant="$py $here/../finding-2026-11-29-pin-posts/variant.py"
$variant "$here/../finding-2026-12-04-coarser-lattice/fitfrom-sp18.yaml" fit calibration.friction=0.773
$variant fit.yaml fs physics.finite_sliding=true
$variant fs.yaml fs_s003 material.tip_sway_mm_per_n=0.03 physics.tip_sway_mm_per_n=0.03
$variant fs.yaml fs_f06 calibration.friction=0.6
$variant fs.yaml fs_adh5 physics.adhesion_kpa=5
$variant fs.yaml fs_gel physics.pins_in_gel=true
$variant fs.yaml fs_lev1 physics.pin_lever_mm=1.0
$variant fs.yaml fs_adh7 physics.adhesion_kpa=7.5
$variant fs.yaml fs_adh10 physics.adhesion_kpa=10
$variant fs.yaml fs_adh15 physics.adhesion_kpa=15
$variant fs_adh10.yaml fs_adh10_f07 calibration.friction=0.7
$variant fs_adh10.yaml fs_adh10_f05 calibration.friction=0.5
for v in fit fs fs_s003 fs_f06 fs_adh5 fs_gel fs_lev1 fs_adh7 fs_adh10 fs_adh15 fs_adh10_f07 fs_adh10_f05; do
  [ -f run_$v/run.json ] || { start=$(date +%s); "$twin" run $v.yaml --taps-from fit500 --workers 2 --quiet --out run_$v \
                              || true; echo "$v: $(( $(date +%s) - start )) s"; }
done
"$py" "$here/../finding-2026-12-05-across-fit/screen_summary.py" fit500 run_fit run_fs run_fs_s003 run_fs_f06
"$py" "$here/../finding-2026-12-05-across-fit/screen_summary.py" fit500 run_fs run_fs_adh5 run_fs_gel run_fs_lev1
"$py" "$here/../finding-2026-12-05-across-fit/screen_summary.py" fit500 run_fs run_fs_adh5 run_fs_adh7 run_fs_adh10 \
    run_fs_adh15 run_fs_adh10_f07 run_fs_adh10_f05
