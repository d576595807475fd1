#!/bin/bash
# angles.sh: angles.py on the solid (the default) and the lab-fit dome, 1.5 / 1.0 mm nodes,
# within nodes and at whole nodes
export MUJOCO_GL=egl
here=$(dirname "$0")
LAB='{"membrane_young_mpa":0.21829,"gel_young_kpa":40,"skin_bending":true,"skin_bending_mpa":0.2888,"tip_sway_mm_per_n":0.085,"apex_radius_mm":30}'
for dome in solid lab; do
  physics='{}'; [ $dome = lab ] && physics=$LAB
  for spacing in 1.5 1.0 ${EXTRA_SPACING:-}; do
    for within in 1 0; do
      echo "== $dome, $spacing mm nodes, edge within nodes: $within"
      python "$here/angles.py" $spacing $within "$physics"
    done
  done
done
