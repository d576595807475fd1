#!/bin/bash
# costs.sh: what the held skin's settings cost per frame. `twin bench physics` with a held-skin
# scenario (BASE, default runs/taps_rectangle_held_s0063.yaml, written by run.sh) and that
# scenario with one setting changed each, printed beside the flex default (the other levels
# left out) → OUT (default bench-costs.txt); about a minute on 2 cores. e.g.
#   BASE=runs/taps_rectangle_held_s0076_whole.yaml OUT=bench-costs-whole.txt bash costs.sh
# The whole bench with the paper-run domes:
#   twin bench physics --scenario ../finding-2026-12-03-paper-runs/taps_rectangle_fit.yaml \
#     --scenario runs/taps_rectangle_held.yaml --scenario runs/taps_rectangle_held_s0063.yaml > bench-physics.txt
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
cd "$(dirname "$0")"
base=${BASE:-runs/taps_rectangle_held_s0063.yaml} out=${OUT:-bench-costs.txt}
mkdir -p runs/costs
names=()
one() {  # one NAME SED: the base with SED applied, named NAME, unless SED changes nothing
  sed -e "$2" -e "s/^name: .*/name: $1/" $base > runs/costs/$1.yaml
  if [ "$(sed -e "s/^name: .*//" $base)" != "$(sed -e "s/^name: .*//" runs/costs/$1.yaml)" ]; then names+=($1); fi
}
one no_edge_within_node 's/edge_within_node: true/edge_within_node: false/'
one edge_within_node 's/edge_within_node: false/edge_within_node: true/'
one no_sway 's/tip_sway_mm_per_n: 0.0[0-9]*/tip_sway_mm_per_n: 0/'
one held_90 's/skin_held_deg: 75/skin_held_deg: 90/'
one no_bending 's/skin_bending: true/skin_bending: false/; /skin_bending_mpa/d'
one no_lever 's/pin_lever_mm: 1.55/pin_lever_mm: 0/'
one friction_1 's/friction: 0.7/friction: 1.0/'
one apex_default '/apex_radius_mm/d'
one pins_in_gel 's/pins_in_gel: false/pins_in_gel: true/'
one shell_preset 's/membrane_young_mpa: 0.5/membrane_young_mpa: 0.6/; s/gel_young_kpa: 40.0/gel_young_kpa: 34.1/; /skin_bending_mpa/d; /skin_held_deg/d'
twin bench physics --scenario $base $(for n in "${names[@]}"; do echo --scenario runs/costs/$n.yaml; done) \
  | grep -v "^physics  compliant  default+\|reference\|fast" > $out
