"""Per lateral bin: the rigid shift that turns with the edge, px: the fitted θ gradient's
uniform part × 180/π (its direction relative to the edge's normal in brackets: deg).
usage: turning_shift.py RUN [RUN...]"""

import sys

import numpy as np

from twin.analysis.edge_imprint import sheared_fits
from twin.runs.record import load_run

for p in sys.argv[1:]:
    run = load_run(p)
    out = []
    for f in sheared_fits(run):
        u = f.gradients["theta_deg"].reshape(-1, 2).mean(axis=0) * 180 / np.pi
        out.append(f"{f.lateral_mm:+.0f}:{np.hypot(*u):.2f}")
    print(p.split("/")[-1][:28].ljust(28), " ".join(out), flush=True)
