#!/bin/bash
# screen.sh: in a folder holding fit500 (every tenth DigiTac tap, ../finding-2026-12-04-held-skin-paper/README.md):
# the fit's dome (../finding-2026-12-04-coarser-lattice/fitfrom-sp18.yaml at friction 0.773, as fit.yaml) replayed on
# its 500 taps, then with finite sliding, and with finite sliding at sway 0.03 mm/N or friction 0.6; each replay's
# edge figures against the recording's (../finding-2026-12-05-across-fit/screen_summary.py) → screen.txt's table
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
here=$(cd "$(dirname "$0")" && pwd)
twin=$here/../../../.venv/bin/twin py=$here/../../../.venv/bin/python
variant="$py $here/../finding-2026-11-29-pin-posts/variant.py"
$variant "$here/../finding-2026-12-04-coarser-lattice/fitfrom-sp18.yaml" fit calibration.friction=0.773
$variant fit.yaml fs physics.finite_sliding=true
$variant fs.yaml fs_s003 material.tip_sway_mm_per_n=0.03 physics.tip_sway_mm_per_n=0.03
$variant fs.yaml fs_f06 calibration.friction=0.6
for v in fit fs fs_s003 fs_f06; do
  [ -f run_$v/run.json ] || { start=$(date +%s); "$twin" run $v.yaml --taps-from fit500 --workers 2 --quiet --out run_$v;
                              echo "$v: $(( $(date +%s) - start )) s"; }
done
"$py" "$here/../finding-2026-12-05-across-fit/screen_summary.py" fit500 run_fit run_fs run_fs_s003 run_fs_f06
