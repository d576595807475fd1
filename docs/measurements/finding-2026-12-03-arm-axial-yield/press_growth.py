"""Mean pin displacement from the no-contact frame (RMS over pins, px; the median over taps)
per octile of the taps' depth offset, recording beside replays, on the taps they share
but those only one of them kept every pin in (as `twin compare` reads them)."""

import sys

import numpy as np

from twin.analysis.comparison import taps_both_kept
from twin.runs.record import load_run


def moves(run):
    return np.sqrt(np.nanmean(np.nansum((run.pins_px - run.rest_pins_px) ** 2, axis=-1), axis=-1))


real = load_run(sys.argv[1])
for path in sys.argv[2:]:
    twin = load_run(path)
    pairs = taps_both_kept(real, twin)
    a, b = real.subset([i for i, _ in pairs]), twin.subset([j for _, j in pairs])
    offset, lateral = a.label("depth_offset_mm"), a.label("lateral_mm")
    edges = np.linspace(-1, 1, 9)
    print(
        f"== {path.split('/')[-1]}: {len(pairs)} shared samples (the no-contact frame and the taps); octiles of the depth offset, centres {np.round((edges[:-1] + edges[1:]) / 2, 2)}"
    )
    for name, run in (("recording", a), ("replay", b)):
        m = moves(run)
        for lo, hi in ((-5.5, -2.5), (-2.5, 2.5), (2.5, 5.5)):
            row = [
                np.nanmedian(m[(offset >= e0) & (offset <= e1) & (lateral >= lo) & (lateral <= hi)])
                for e0, e1 in zip(edges[:-1], edges[1:])
            ]
            print(
                f"  {name:9s} l in [{lo:+},{hi:+}]: "
                + " ".join(f"{v:5.2f}" for v in row)
                + f"   last/first {row[-1] / row[0]:.2f}"
            )
