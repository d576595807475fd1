"""The orientation signal's rigid-shift share per bin and weighted by the signal's energy
over l -5..+5 (what a turn of taps over those l would put in PC2-PC3), with a bootstrap sd
(30 resamplings within bins). usage: shift_share.py RUN [RUN...]"""

import sys

import numpy as np

from twin.analysis.edge_imprint import sheared_fits, usable
from twin.runs.record import Run, load_run

rng = np.random.default_rng(0)


def figs(run):
    fits = [f for f in sheared_fits(run) if -5 <= f.lateral_mm <= 5]
    w = np.array([f.spread_px["theta_deg"] ** 2 for f in fits])
    s = np.array([f.signal_shift_share for f in fits])
    return {f.lateral_mm: v for f, v in zip(fits, s)}, float(w @ s / w.sum())


for p in sys.argv[1:]:
    run = load_run(p)
    per, wt = figs(run)
    ok = np.flatnonzero(usable(run))
    lat = np.round(run.label("lateral_mm")[ok])
    boots = []
    for _ in range(30):
        idx = np.concatenate([rng.choice(ok[lat == c], (lat == c).sum()) for c in np.unique(lat)])
        b = Run(run.path, run.meta, [run.samples[i] for i in idx])
        boots.append(figs(b))
    sd = {l: np.std([b[0].get(l, np.nan) for b in boots]) for l in per}
    print(
        p.split("/")[-1][:30].ljust(30),
        f"weighted {wt:.3f}±{np.std([b[1] for b in boots]):.3f} |",
        " ".join(f"{l:+.0f}:{v:.2f}±{sd[l]:.2f}" for l, v in sorted(per.items())),
        flush=True,
    )
