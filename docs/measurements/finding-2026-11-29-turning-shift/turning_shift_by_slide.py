"""Off the object (bins +1..+5): the rigid shift that turns with the edge (px; the θ
gradient's uniform part × 180/π, as a vector in the image, averaged over bins) for taps by
slide size max(|along|, |across|). usage: turning_shift_by_slide.py RUN [RUN...]"""

import sys

import numpy as np

from twin.analysis.edge_imprint import sheared_fits
from twin.runs.record import Run, load_run

for p in sys.argv[1:]:
    run = load_run(p)
    size = np.maximum(np.abs(run.label("slide_along_mm")), np.abs(run.label("slide_lateral_mm")))
    out = []
    for lo, hi in ((0, 2.5), (2.5, 4), (4, 5.01)):
        sub = Run(run.path, run.meta, [s for s, z in zip(run.samples, size) if lo <= z < hi])
        us = [
            f.gradients["theta_deg"].reshape(-1, 2).mean(axis=0) * 180 / np.pi
            for f in sheared_fits(sub, min_samples=40)
            if 1 <= f.lateral_mm <= 5
        ]
        m = np.linalg.norm(np.mean(us, axis=0))
        each = np.linalg.norm(us, axis=1)
        out.append(f"{lo:g}-{min(hi, 5):g} mm: |mean| {m:.2f} (bins {' '.join(f'{e:.2f}' for e in each)})")
    print(p.split("/")[-1][:28].ljust(28), " | ".join(out), flush=True)
