"""Orientation signal (RMS over pins of each pin's spread over the edge angles, px) per
lateral position and press depth, on still tap runs; growth = deepest / shallowest."""

import sys

import numpy as np

from twin.runs.record import load_run

for path in sys.argv[1:]:
    run = load_run(path)
    pins = run.pins_px
    lat, dep = run.label("lateral_mm"), run.label("depth_mm")
    rows = []
    for l in sorted(set(np.round(lat, 2)), reverse=True):
        sig = []
        for d in sorted(set(np.round(dep, 2))):
            sel = (np.round(lat, 2) == l) & (np.round(dep, 2) == d)
            p = pins[sel]
            sig.append(np.sqrt(np.nanmean(np.nansum(np.nanvar(p, axis=0), axis=-1))))
        rows.append(f"l {l:+.0f}: " + " ".join(f"{s:.3f}" for s in sig) + f"  growth {sig[-1] / sig[0]:.2f}")
    print(path.split("/")[-1], "|", " | ".join(rows))
