#!/bin/bash
# Table I (twin evaluate) of the shipped taps and slides on the held-at-65° dome of
# taps_held65.yaml / slides_held65.yaml with another friction and tip sway.
# usage: tablei.sh NAME FRICTION SWAY_MM_PER_N OUTDIR
set -e
here=$(cd "$(dirname "$0")" && pwd)
name=$1 mu=$2 sway=$3 out=$4
mkdir -p "$out"
for k in taps slides; do
  sed -e "s/friction: 0.5491/friction: $mu/" -e "s/tip_sway_mm_per_n: 0.1437/tip_sway_mm_per_n: $sway/" \
      -e "s/_held65$/_held65_$name/" "$here/${k}_held65.yaml" > "$out/${k}_$name.yaml"
done
twin run "$out/taps_$name.yaml" --out "$out/taps_$name" --workers 2 --quiet
twin run "$out/slides_$name.yaml" --out "$out/slides_$name" --workers 2 --quiet
twin evaluate --train "$out/taps_$name" --test "$out/slides_$name" --out "$out/eval_$name"
