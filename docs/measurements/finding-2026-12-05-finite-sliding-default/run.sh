#!/bin/bash
# run.sh: the shipped scenarios on the dome fitted with finite sliding and adhesion
# (fitted.yaml over the default dome), every object's friction its material's times
# 0.3162 / 0.7 (the fit's skin friction on a printed edge over the handbook figure for
# PLA): ../finding-2026-12-05-shipped-scenarios/run.sh with FITTED and FRICTION_SCALE.
# About half an hour on 2 cores; runs/ is not kept.
set -e
here=$(cd "$(dirname "$0")" && pwd)
FITTED="$here/fitted.yaml" FRICTION_SCALE=0.4517 OUT="$here" bash "$here/../finding-2026-12-05-shipped-scenarios/run.sh" "$@"
# The same taps, slides and held-out taps with the default's sway (default-sway/fitted.yaml),
# their tables in default-sway/: what the fit's sway does to Table I.
FITTED="$here/default-sway/fitted.yaml" FRICTION_SCALE=0.4517 OUT="$here/default-sway" TABLES_ONLY=1 \
  bash "$here/../finding-2026-12-05-shipped-scenarios/run.sh" "$@"
# And with the sway that balances the drag on this rig (balancing-sway/fitted.yaml), contours too.
FITTED="$here/balancing-sway/fitted.yaml" FRICTION_SCALE=0.4517 OUT="$here/balancing-sway" \
  bash "$here/../finding-2026-12-05-shipped-scenarios/run.sh" "$@"
