"""The signal profile (the edge's orientation signal at each l over its value at l = 0,
twin.analysis.edge_imprint.signal_profile) of a real sheared run and of twin replays of
its taps (twin run --taps-from REAL [--without-slides]), on the taps the real run tracked
fully, with each bin's spread over 30 resamplings of its taps (seeded).

usage: paired_still.py REAL TWIN [TWIN ...]   (the repository on PYTHONPATH)"""

import sys

import numpy as np

from twin.analysis.edge_imprint import signal_profile, usable
from twin.runs.record import Run, load_run


def profile(run: Run, rows: np.ndarray) -> dict[float, float]:
    """The profile of the samples at indices `rows` (repeats allowed)."""
    (row,) = signal_profile(Run(run.path, run.meta, [run.samples[i] for i in rows])).values()
    return row


real = load_run(sys.argv[1])
keep = usable(real)
rows = {}
for path in sys.argv[1:]:
    run = load_run(path)
    mask = keep & usable(run)
    point = profile(run, np.flatnonzero(mask))
    lateral = np.round(run.label("lateral_mm"))
    rng = np.random.default_rng(0)
    draws = []
    for _ in range(30):
        bins = [np.flatnonzero(mask & (lateral == c)) for c in sorted(set(lateral[mask].tolist()))]
        draws.append(profile(run, np.concatenate([rng.choice(idx, len(idx)) for idx in bins])))
    rows[path] = {l: (v, np.std([d.get(l, np.nan) for d in draws])) for l, v in point.items()}
laterals = sorted(set().union(*rows.values()))
print("signal / at l = 0 (± sd over 30 resamplings)")
print(" " * 30 + "".join(f"{l:+12.0f}" for l in laterals))
for path, row in rows.items():
    print(
        f"{path[-30:]:30s}" + "".join(f"{row[l][0]:7.2f}±{row[l][1]:4.2f}" if l in row else " " * 12 for l in laterals)
    )
