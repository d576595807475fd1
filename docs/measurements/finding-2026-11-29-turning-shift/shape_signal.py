"""The orientation signal without its rigid shift, over its value at l = 0: per lateral
bin, signal × √(1 − share) (the tool's signal and its share in a rigid shift), beside the
signal ratio as printed. usage: shape_signal.py RUN [RUN...]"""

import sys

import numpy as np

from twin.analysis.edge_imprint import sheared_fits
from twin.runs.record import load_run

for p in sys.argv[1:]:
    fits = {f.lateral_mm: f for f in sheared_fits(load_run(p))}
    whole = {l: f.spread_px["theta_deg"] for l, f in fits.items()}
    shape = {l: f.spread_px["theta_deg"] * np.sqrt(max(1.0 - f.signal_shift_share, 0.0)) for l, f in fits.items()}
    print(
        p.split("/")[-1][:28].ljust(28),
        "whole",
        " ".join(f"{l:+.0f}:{v / whole[0.0]:.2f}" for l, v in sorted(whole.items())),
    )
    print(" " * 28, "shape", " ".join(f"{l:+.0f}:{v / shape[0.0]:.2f}" for l, v in sorted(shape.items())))
