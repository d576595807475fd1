#!/bin/bash
# taps3.sh FOLDER...: the taps of FOLDER/runs/taps_rectangle.yaml (written by
# ../finding-2026-12-05-shipped-scenarios/run.sh) at the slides' depth, 3 mm, into
# FOLDER/runs/taps3: the still frames plane_geometry.py sets each slide sample against.
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
here=$(cd "$(dirname "$0")" && pwd)
bin=$(realpath "$here/../../../.venv/bin")
for f in "$@"; do
  sed -e 's/^name: .*/name: taps3/' "$f/runs/taps_rectangle.yaml" | "$bin/python" -c "
import sys, yaml
d = yaml.safe_load(sys.stdin); d['protocol']['depths_mm'] = [3]; yaml.safe_dump(d, sys.stdout, sort_keys=False)" > "$f/runs/taps3.yaml"
  grep -qs '"status": "completed"' "$f/runs/taps3/run.json" || {
    rm -rf "$f/runs/taps3"; "$bin/twin" run "$f/runs/taps3.yaml" --workers 2 --quiet --out "$f/runs/taps3"; }
done
