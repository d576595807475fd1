#!/bin/bash
# run.sh: the paper's taps, slides, held-out taps and contours on the skin held at 75°
# (0.5 MPa membrane, 0.15 mm/N of sway, friction 0.7; ../finding-2026-12-04-yield-carried/)
# on the twin's own rig, written to runs/ from ../finding-2026-12-03-paper-runs/'s scenarios
# with those four values changed; `twin evaluate` → table-i-TAG.txt, heldout-TAG.txt, and
# the contours' figures → contours-TAG.txt.
# usage: [TAG=held] [SWAY=0.15] [FRICTION=0.7] [CONTOURS="rectangle ..."] [EXTRA=sed-expression] bash run.sh [path/to/twin]
# (about 20 minutes on 2 cores with the eight contours)
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
twin=$(realpath "${1:-$(dirname "$0")/../../../.venv/bin/twin}")
py=$(dirname "$twin")/python
tag=${TAG:-held} sway=${SWAY:-0.15} friction=${FRICTION:-0.7} extra=${EXTRA:-}
contours=${CONTOURS:-rectangle large_circle small_circle flower spiral tape_measure rectangle_stl flower_stl}
cd "$(dirname "$0")"
src=../finding-2026-12-03-paper-runs
mkdir -p runs
held() {  # held SCENARIO: the paper-run scenario with the held skin's values, runs/SCENARIO_TAG.yaml
  sed -e "s/skin_held_deg: 90/skin_held_deg: 75/" -e "s/membrane_young_mpa: 0.21829/membrane_young_mpa: 0.5/" \
    -e "s/tip_sway_mm_per_n: 0.012/tip_sway_mm_per_n: $sway/" -e "s/friction: 0.95/friction: $friction/" \
    -e "s/^name: \(.*\)_fit$/name: \1_$tag/" -e "s/the dome fitted to the DigiTac recording/the held skin ($tag)/" \
    -e "s#model: runs/eval/#model: eval_$tag/#" -e "/^#/d" ${extra:+-e "$extra"} "$src/$1_fit.yaml" > "runs/$1_$tag.yaml"
  sed -i "1i # run.sh: $src/$1_fit.yaml with the skin held at 75°, 0.5 MPa, sway $sway mm/N, friction $friction" "runs/$1_$tag.yaml"
  grep -q "skin_held_deg: 75" "runs/$1_$tag.yaml" && grep -q "friction: $friction" "runs/$1_$tag.yaml"
}
run() {  # run NAME WORKERS: twin run runs/NAME.yaml into runs/NAME, unless a completed run is there
  grep -qs '"status": "completed"' runs/$1/run.json && return
  rm -rf runs/$1 && "$twin" run runs/$1.yaml --workers $2 --quiet --out runs/$1
}
for s in taps_rectangle slides_rectangle taps_heldout; do
  held $s
  run ${s}_$tag 2
done
"$twin" evaluate --train runs/taps_rectangle_$tag --test runs/slides_rectangle_$tag --out runs/eval_$tag > table-i-$tag.txt
"$twin" evaluate --train runs/taps_rectangle_$tag --test runs/taps_heldout_$tag --out runs/eval_heldout_$tag > heldout-$tag.txt
"$py" $src/objects_stl.py && cp $src/rectangle_r1.stl $src/flower.stl runs/
for o in $contours; do
  held contour_$o
  run contour_${o}_$tag 1
done
"$py" $src/contours.py $(for o in $contours; do echo runs/contour_${o}_$tag; done) > contours-$tag.txt
