#!/bin/bash
# sheared.sh: DigiTac-like sheared taps (500, drawn: l in ±5 mm, θ in ±45°, 4 ± 1 mm deep,
# slides and twists up to 5 mm and 5° before each frame) on the paper's rig (the sharp
# rectangle, the shipped sensor) with the fit's dome at its sway (fitted.yaml) and at the
# balancing sway (balancing-sway/fitted.yaml), friction 0.3162; `twin evaluate` prints
# their edge figures → sheared-fit.txt, sheared-balancing.txt; and the fit's on the rectangle
# with its edge rounded 1 mm, as the DigiTac taps' edge is taken → sheared-fit_rounded.txt;
# and the fit's through the camera fitted to the DigiTac recording (digitac-camera.yaml)
# → sheared-fit_digitac_camera.txt. Without `render` (the pins
# projected, not tracked: a 5 mm slide moves them past the tracker's reach between frames
# on this camera). A few minutes on 2 cores.
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
twin=$(realpath "${1:-$(dirname "$0")/../../../.venv/bin/twin}")
here=$(cd "$(dirname "$0")" && pwd)
cd "$here"
mkdir -p runs
for variant in fit:fitted.yaml balancing:balancing-sway/fitted.yaml fit_rounded:fitted.yaml fit_digitac_camera:fitted.yaml; do
  name=${variant%%:*}
  edge=""
  if [ "$name" = fit_rounded ]; then edge=", edge_radius_mm: 1.0"; fi
  {
    echo "name: sheared_$name"
    echo "object: {name: rectangle, friction: 0.3162$edge}"
    echo "placement: {position_mm: [400, 0], yaw_deg: 0}"
    echo "effects: [contact, friction]"
    echo "protocol: {kind: sheared_taps, depth_mm: 4, taps: 500, seed: 0, edge_point_mm: [60, 0], edge_normal_deg: 0}"
    sed "/^#/d" "${variant#*:}"
    if [ "$name" = fit_digitac_camera ]; then sed "/^#/d" digitac-camera.yaml; fi
  } > runs/sheared_$name.yaml
  grep -qs '"status": "completed"' runs/sheared_$name/run.json || {
    rm -rf runs/sheared_$name && "$twin" run runs/sheared_$name.yaml --workers 2 --quiet --out runs/sheared_$name
  }
  "$twin" evaluate --train runs/sheared_$name --test runs/sheared_$name --out runs/eval_sheared_$name > sheared-$name.txt
done
