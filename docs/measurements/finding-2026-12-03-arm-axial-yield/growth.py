"""Orientation signal (twin.analysis.evaluation.orientation_signal_px: each pin's spread
over the edge angles, RMS over pins, px) per lateral position and press depth, on still tap
runs; growth = deepest / shallowest."""

import sys

from twin.analysis.edge_imprint import usable
from twin.analysis.evaluation import orientation_signal_px
from twin.runs.record import load_run

for path in sys.argv[1:]:
    run = load_run(path)
    by_depth = orientation_signal_px(run.subset(usable(run)))
    depths = sorted(by_depth)
    rows = []
    for l in sorted(by_depth[depths[0]], reverse=True):
        signal = [by_depth[d][l] for d in depths]
        rows.append(f"l {l:+.0f}: " + " ".join(f"{s:.3f}" for s in signal) + f"  growth {signal[-1] / signal[0]:.2f}")
    print(path.split("/")[-1], "|", " | ".join(rows))
