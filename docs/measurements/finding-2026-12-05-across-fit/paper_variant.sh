#!/bin/bash
# paper_variant.sh TAG HELD_DEG BENDING_MPA: the paper's protocol (../finding-2026-12-04-held-skin-paper/run.sh's
# runs) for the fit's dome (TAG held_s0063_f077_whole_sp18 there) with the skin held at HELD_DEG and its bending
# modulus BENDING_MPA; writes table-i-TAG.txt, heldout-TAG.txt, contours-TAG.txt beside run.sh's.
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
tag=$1 held=$2 bending=$3 base=held_s0063_f077_whole_sp18
here=$(cd "$(dirname "$0")" && pwd)
twin=$here/../../../.venv/bin/twin py=$here/../../../.venv/bin/python
cd "$here/../finding-2026-12-04-held-skin-paper"
src=../finding-2026-12-03-paper-runs
contours="rectangle large_circle small_circle flower spiral tape_measure rectangle_stl flower_stl"
for s in taps_rectangle slides_rectangle taps_heldout $(for o in $contours; do echo contour_$o; done); do
  sed -e "s/skin_held_deg: 75$/skin_held_deg: $held/" -e "s/skin_bending_mpa: 0.8664$/skin_bending_mpa: $bending/" \
    -e "s/$base/$tag/g" -e "1s/\$/; skin held at $held°, bending $bending MPa (paper_variant.sh)/" \
    runs/${s}_$base.yaml > runs/${s}_$tag.yaml
  grep -q "skin_held_deg: $held$" runs/${s}_$tag.yaml && grep -q "skin_bending_mpa: $bending$" runs/${s}_$tag.yaml
done
run() { grep -qs '"status": "completed"' runs/$1/run.json || { rm -rf runs/$1 && "$twin" run runs/$1.yaml --workers $2 --quiet --out runs/$1; }; }
for s in taps_rectangle slides_rectangle taps_heldout; do run ${s}_$tag 2; done
"$twin" evaluate --train runs/taps_rectangle_$tag --test runs/slides_rectangle_$tag --out runs/eval_$tag > table-i-$tag.txt
"$twin" evaluate --train runs/taps_rectangle_$tag --test runs/taps_heldout_$tag --out runs/eval_heldout_$tag > heldout-$tag.txt
for o in $contours; do run contour_${o}_$tag 1; done
"$py" $src/contours.py $(for o in $contours; do echo runs/contour_${o}_$tag; done) > contours-$tag.txt
