#!/bin/bash
# across_radius.sh: ../finding-2026-12-06-pooled-fit/across-slide-fails.yaml (the paper's
# slides across the sharp rectangle's edge on the pooled fit's dome) with the edge rounded
# by 0.25, 0.5 and 1 mm, and on the sharp edge with isotropic friction 0.75 (the same
# friction across the edge, edge_friction_ratio 1); each run's outcome, its most carried
# skin node (trace_caught.py), into runs/across_*. usage: bash across_radius.sh [path/to/twin]
set -e
export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-egl}
twin=$(realpath "${1:-$(dirname "$0")/../../../.venv/bin/twin}")
py=$(dirname "$twin")/python
here=$(cd "$(dirname "$0")" && pwd)
base=$here/../finding-2026-12-06-pooled-fit/across-slide-fails.yaml
mkdir -p runs
sed "s/^  friction: 0.2562/  friction: 0.2562\n  edge_radius_mm: 0.0/" "$base" > runs/across_r0.yaml
for r in 0.25 0.5 1.0; do sed "s/edge_radius_mm: 0.0/edge_radius_mm: $r/" runs/across_r0.yaml > runs/across_r$r.yaml; done
sed -e "s/^  friction: 0.2562/  friction: 0.75/" -e "s/edge_friction_ratio: 2.928/edge_friction_ratio: 1.0/" \
    runs/across_r0.yaml > runs/across_r0_mu075.yaml
for v in r0 r0.25 r0.5 r1.0 r0_mu075; do
  rm -rf runs/across_$v
  "$py" "$here/trace_caught.py" runs/across_$v.yaml runs/across_$v > runs/trace_$v.txt 2>&1
  failed=$(grep -o 'PhysicsError.*reaches (10 mm)' runs/trace_$v.txt | sed 's/\[across_slide_fails\] //')
  echo "$v: ${failed:-recorded, $(grep -c '"sample_in_slide"' runs/across_$v/samples.jsonl) samples}"
  echo "  most carried: $(tail -n 2 runs/trace_$v.txt | head -n 1)"
done
