"""Where the twin's pins miss the real's: the displacement misfit (px RMS, each run from its
own rest frame) in the reach profile's ten bins of the rest pins along the edge normal in
the image (twin.analysis.edge_imprint.normal_bins: far beyond the edge -> object side), per
lateral third, beside the real's mean |displacement| there and the object side's rim (the
last bin) over the largest; a replay of the first N taps
(`twin run --first-taps N`) against the real's first N frames.
usage: misfit_bins.py REAL TWIN..."""

import sys

import numpy as np

from twin.analysis.edge_imprint import REACH_BINS, edge_normal_in_image, normal_bins, usable
from twin.runs.record import Run, load_run

BINS = REACH_BINS
recorded = load_run(sys.argv[1])
normal = edge_normal_in_image(recorded)


def binned(values, bins, ok):
    """(BINS,) mean of per-pin `values` (frames, pins) in each frame's `bins` (frames, pins)."""
    total, count = np.zeros(BINS), np.zeros(BINS)
    for v, i in zip(values[ok], bins[ok]):
        total += np.bincount(i, v, BINS)
        count += np.bincount(i, minlength=BINS)
    return total / count


for p in sys.argv[2:]:
    twin = load_run(p)
    real = Run(recorded.path, recorded.meta, recorded.samples[: len(twin.samples)])
    theta, lateral = real.label("theta_deg"), real.label("lateral_mm")
    dr = real.pins_px - real.rest_pins_px
    ok0 = usable(real) & usable(twin)
    dt = twin.pins_px - twin.rest_pins_px
    bins = np.array([normal_bins(real.rest_pins_px, normal, t, BINS) for t in theta])
    for lo, hi in ((-5.5, -2), (-2, 2), (2, 5.5)):
        ok = ok0 & (lateral >= lo) & (lateral < hi)
        mis = np.sqrt(binned(np.sum((dt - dr) ** 2, axis=-1), bins, ok))
        mag_r = binned(np.linalg.norm(dr, axis=-1), bins, ok)
        mag_t = binned(np.linalg.norm(dt, axis=-1), bins, ok)
        name = p.rstrip("/").split("/")[-1][:16]
        print(f"{name:16s} l [{lo:+.0f},{hi:+.0f}) misfit " + " ".join(f"{v:4.2f}" for v in mis))
        print(f"{'':16s}              |real| " + " ".join(f"{v:4.2f}" for v in mag_r))
        print(f"{'':16s}              |twin| " + " ".join(f"{v:4.2f}" for v in mag_t))
        print(
            f"{'':16s}              rim / largest bin: real {mag_r[-1] / mag_r.max():.2f}, twin {mag_t[-1] / mag_t.max():.2f}"
        )
