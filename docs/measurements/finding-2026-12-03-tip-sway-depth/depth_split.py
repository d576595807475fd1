"""depth_split.py RECORDED REPLAY …: the edge's orientation signal (px) per third of the taps'
depth offset (the ranges `twin compare` splits them into), the recording beside each replay
on the taps they share, ± one standard deviation over 30 paired resamples (each a draw with
replacement, its distinct taps kept once; seed 0)."""

import sys

import numpy as np

from twin.analysis.edge_imprint import DEPTH_BANDS, sheared_fits
from twin.runs.pairing import shared_taps
from twin.runs.record import Run, load_run

RESAMPLES = 30


def signal_px(run: Run, mask: np.ndarray) -> dict[float, float]:
    return {f.lateral_mm: f.spread_px["theta_deg"] for f in sheared_fits(run.subset(mask))}


def main(recorded: str, *replays: str) -> None:
    real = load_run(recorded)
    rng = np.random.default_rng(0)
    for path in replays:
        twin = load_run(path)
        pairs = shared_taps(real, twin)
        a, b = real.subset([i for i, _ in pairs]), twin.subset([j for _, j in pairs])
        print(f"== {path}: {len(pairs)} shared taps; l = +5 … −5 mm")
        offset = a.label("depth_offset_mm")
        edges = np.linspace(np.nanmin(offset), np.nanmax(offset), DEPTH_BANDS + 1)
        band = np.searchsorted(edges[1:-1], offset, side="right")  # as signal_by_depth splits them
        for k in range(DEPTH_BANDS):
            inside = (band == k) & np.isfinite(offset)
            rows = {name: signal_px(run, inside) for name, run in (("recording", a), ("replay", b))}
            draws = {name: [] for name in rows}
            idx = np.flatnonzero(inside)
            for _ in range(RESAMPLES):
                pick = np.zeros(len(inside), bool)
                pick[rng.choice(idx, len(idx))] = True
                for name, run in (("recording", a), ("replay", b)):
                    draws[name].append(signal_px(run, pick))
            print(f" depth offset {edges[k]:+.2f} … {edges[k + 1]:+.2f} mm ({inside.sum()} taps)")
            for name, row in rows.items():
                ls = sorted(row, reverse=True)
                sd = {l: np.nanstd([d.get(l, np.nan) for d in draws[name]]) for l in ls}
                print(f"   {name:10s} " + " ".join(f"{row[l]:.2f}±{sd[l]:.2f}" for l in ls))


if __name__ == "__main__":
    main(*sys.argv[1:])
