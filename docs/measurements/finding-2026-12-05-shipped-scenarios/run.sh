#!/bin/bash
# run.sh: the shipped scenarios (scenarios/*.yaml) as they are (sharp edges, each object's
# own material friction) but for the dome: the fitted compliant dome of
# ../finding-2026-12-05-across-fit/ (sway 0.063 mm/N; its friction is the objects' own here)
# added as `dome: compliant` and `physics:` (fitted.yaml, on the fit's 1.8 mm nodes). The
# paper's taps, slides and held-out taps → `twin evaluate` → table-i.txt, heldout.txt; the
# six contours and two of them as user STL objects, on the model trained on those taps →
# contours.txt. About 15 minutes on 2 cores.
# usage: bash run.sh [path/to/twin]
# With AS_SHIPPED=1 and OUT=DIR (../finding-2026-12-05-default-dome/run.sh) it adds no
# `dome:` or `physics:` and writes runs/ and its tables into DIR instead. With FITTED=FILE
# it appends that file's entries instead of fitted.yaml's; with FRICTION_SCALE=s every
# object's friction is its material's times s (../finding-2026-12-05-finite-sliding-default/run.sh);
# with TABLES_ONLY=1 it stops after table-i.txt and heldout.txt; with EDGE_RADIUS_MM=r the
# rectangle of the taps, slides and held-out taps has its top edges rounded by r mm, as
# shipped or on a fitted dome (../finding-2026-12-06-rounded-paper-edge/); with
# CONTOUR_EDGE_RADIUS_MM=r so are the six contours' objects and the two STL objects
# (../finding-2026-12-06-rounded-contours/).
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
twin=$(realpath "${1:-$(dirname "$0")/../../../.venv/bin/twin}")
py=$(dirname "$twin")/python
here=$(cd "$(dirname "$0")" && pwd)
cd "${OUT:-$here}"
S="$here/../../../scenarios"
mkdir -p runs
fitted() {  # fitted SCENARIO NAME [OBJECT [EDGE_RADIUS_MM]]: the shipped scenario on the fitted dome, runs/NAME.yaml
  sed -e "s/^name: .*/name: $2/" -e "s#^  controller: paper.*#  controller: paper\n  model: eval/model_pca.npz#" \
    ${3:+-e "s#^object: .*#object: {stl: $3}#"} "$S/$1.yaml" > "runs/$2.yaml"
  if [ -z "$AS_SHIPPED" ]; then
    sed "/^#/d" "${FITTED:-$here/fitted.yaml}" >> "runs/$2.yaml"
    echo "  surface_spacing_mm: 1.8" >> "runs/$2.yaml"
  fi
  [ -z "$FRICTION_SCALE$4" ] && return
  "$py" - "runs/$2.yaml" "${FRICTION_SCALE:-1}" "${4:-0}" <<'PY'
import sys
import yaml
from twin.core.scenario import load_scenario
from twin.runs.spec import load_scenario_stimulus
path, scale, radius = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
entries = yaml.safe_load(open(path))
entries["object"]["friction"] = round(load_scenario_stimulus(load_scenario(path)).friction * scale, 4)
if radius:
    entries["object"]["edge_radius_mm"] = radius
yaml.safe_dump(entries, open(path, "w"), sort_keys=False)
PY
}
run() {  # run NAME WORKERS: twin run runs/NAME.yaml into runs/NAME, unless a completed run is there
  grep -qs '"status": "completed"' runs/$1/run.json && return
  rm -rf runs/$1 && "$twin" run runs/$1.yaml --workers $2 --quiet --out runs/$1
}
for s in taps_rectangle slides_rectangle taps_heldout; do
  fitted $s $s "" $EDGE_RADIUS_MM
  run $s 2
done
"$twin" evaluate --train runs/taps_rectangle --test runs/slides_rectangle --out runs/eval > table-i.txt
"$twin" evaluate --train runs/taps_rectangle --test runs/taps_heldout --out runs/eval_heldout > heldout.txt
[ -n "$TABLES_ONLY" ] && exit 0
"$py" - <<'PY'
from twin.world.stimuli.objects import builtin_stimulus
for name in ("rectangle", "flower"):
    mesh = builtin_stimulus(name).mesh.copy()
    mesh.apply_scale(1000.0)  # the object's mesh is in metres
    mesh.export(f"runs/{name}.stl")
PY
contours="rectangle large_circle small_circle flower spiral tape_measure rectangle_stl flower_stl"
for o in $contours; do
  base=${o%_stl}
  fitted contour_$base contour_$o "$([ "$o" != "$base" ] && echo $base.stl)" $CONTOUR_EDGE_RADIUS_MM
  run contour_$o 1
done
"$py" "$here/../finding-2026-12-03-paper-runs/contours.py" $(for o in $contours; do echo runs/contour_$o; done) > contours.txt
