#!/bin/bash
# variant_table.sh NAME KEY=VALUE...: the shipped taps and slides with one dome change, and Table I.
# Run in a folder holding finding-2026-12-02-apex-profile/paper's taps.yaml and slides.yaml.
# KEY: friction, physics.NAME (the scenario's physics) or a dome_material key of its calibration.
set -e
export MUJOCO_GL=egl PYOPENGL_PLATFORM=egl
T=${TWIN_VENV:-.venv}/bin
name=$1; shift
mkdir -p "v/$name"
for s in taps slides; do
  "$T/python" - "$s" "$name" "$@" <<'PY'
import sys, yaml
src, name, changes = sys.argv[1], sys.argv[2], sys.argv[3:]
s = yaml.safe_load(open(f'{src}.yaml'))
mat = s['sensor']['calibration']['dome_material']
for c in changes:
    k, v = c.split('=', 1)
    if k == 'friction': s['sensor']['calibration']['friction'] = float(v)
    elif k.startswith('physics.'): s['physics'][k[8:]] = yaml.safe_load(v)
    else: mat[k] = float(v)
yaml.safe_dump(s, open(f'v/{name}/{src}.yaml', 'w'), sort_keys=False)
PY
  "$T/twin" run "v/$name/$s.yaml" --out "v/$name/runs_$s" --workers 2 --quiet > /dev/null 2>&1
done
"$T/twin" evaluate --train "v/$name/runs_taps" --test "v/$name/runs_slides" --out "v/$name/eval" > "v/$name/table-i.txt" 2>&1
echo "== $name $*"; head -1 "v/$name/table-i.txt"; sed -n 2p "v/$name/table-i.txt"; sed -n 4p "v/$name/table-i.txt"; grep 'drag\|sliding' "v/$name/table-i.txt"
