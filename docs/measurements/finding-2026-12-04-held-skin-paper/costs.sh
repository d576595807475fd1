#!/bin/bash
# costs.sh: what the held skin's settings cost per frame. `twin bench physics` with the held
# skin at 0.063 mm/N (runs/taps_rectangle_held_s0063.yaml, run.sh) and that scenario with one
# setting changed each, printed beside the flex default (the other levels left out) →
# bench-costs.txt (about a minute on 2 cores). The whole bench with the paper-run domes:
#   twin bench physics --scenario ../finding-2026-12-03-paper-runs/taps_rectangle_fit.yaml \
#     --scenario runs/taps_rectangle_held.yaml --scenario runs/taps_rectangle_held_s0063.yaml > bench-physics.txt
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
cd "$(dirname "$0")"
base=runs/taps_rectangle_held_s0063.yaml
mkdir -p runs/costs
one() {  # one NAME SED: the base with SED applied, named NAME
  sed -e "$2" -e "s/^name: .*/name: $1/" $base > runs/costs/$1.yaml
}
one no_edge_within_node 's/edge_within_node: true/edge_within_node: false/'
one no_sway 's/tip_sway_mm_per_n: 0.063/tip_sway_mm_per_n: 0/'
one held_90 's/skin_held_deg: 75/skin_held_deg: 90/'
one no_bending 's/skin_bending: true/skin_bending: false/; /skin_bending_mpa/d'
one no_lever 's/pin_lever_mm: 1.55/pin_lever_mm: 0/'
one friction_1 's/friction: 0.7/friction: 1.0/'
twin bench physics --scenario $base $(for n in no_edge_within_node no_sway held_90 no_bending no_lever friction_1; do
  echo --scenario runs/costs/$n.yaml; done) | grep -v "^physics  compliant  default+\|reference\|fast" > bench-costs.txt
