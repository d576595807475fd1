"""Point 4 counted from replays of a real run's taps, as `twin calibrate` counts it with
edge_signal: still, and with edge_signal_shift kept or apart: per figure, how many of the
real's figures the twin meets within the tolerance alone, and the misses.
usage: count_apart.py REAL NAME=SHEARED_RUN,STILL_RUN ..."""

import sys

import numpy as np

from twin.analysis.calibration_fit.figures import _imprint_values, figure_spread, figure_values, miss
from twin.analysis.edge_imprint import usable
from twin.runs.record import Run, load_run


def frames(run, keep):
    return Run(run.path, run.meta, [s for s, k in zip(run.samples, keep) if k])


real = load_run(sys.argv[1])
keep = usable(real) | np.array([bool(s["labels"].get("no_contact")) for s in real.samples])
real = frames(real, keep)
recorded = {apart: figure_values(real, apart) for apart in (False, True)}
spread = {apart: figure_spread(real, 20, 0, recorded[apart], apart) for apart in (False, True)}
for arg in sys.argv[2:]:
    name, paths = arg.split("=")
    sheared, still = (frames(load_run(p), keep) for p in paths.split(","))
    for apart in (False, True):
        twin = figure_values(sheared, apart)
        twin = {k: v for k, v in twin.items() if not (k[0] in ("signal", "shift") and k[1] < 0)}
        twin |= {k: v for k, v in _imprint_values(still, apart).items() if k[1] < 0}
        counts, misses, chi2 = {}, {}, 0.0
        for (f, l), v in sorted(recorded[apart].items()):
            m = miss(f, twin.get((f, l)), v)
            chi2 += miss(f, twin.get((f, l)), v, spread[apart][f, l]) ** 2
            n, k = counts.get(f, (0, 0))
            counts[f] = (n + (abs(m) <= 1), k + 1)
            if abs(m) > 1:
                misses.setdefault(f, []).append(f"{l:+g}: {twin.get((f, l), float('nan')):.2f} vs {v:.2f}")
        print(
            f"{name:12s} {'apart' if apart else 'kept '}",
            "  ".join(f"{f} {n}/{k}" for f, (n, k) in counts.items()),
            f" chi2 {chi2:.1f}",
        )
        for f, ms in misses.items():
            print(" " * 19, f, "misses:", "; ".join(ms))
    sys.stdout.flush()
