"""Issue 40's point-4 criteria as `twin calibrate` counts them with `edge_signal: still`:
the twin's signal onto the object (l < 0) from a still replay of the real taps (twin run
--taps-from REAL --without-slides), off it and the other figures from a table of
finding-2026-11-29-all-taps/full.py (the sheared replay); the signal ratio within 0.1 of
the real's, θ_PC23 and drag / signal within a third, with the misses.

usage: criteria_still.py REAL FULL.json VARIANT=STILL_RUN [VARIANT=STILL_RUN ...]
(the repository on PYTHONPATH; VARIANT names a table in FULL.json)"""

import json
import sys

import numpy as np

from twin.analysis.edge_imprint import signal_profile, usable
from twin.runs.record import Run, load_run


def profile(run: Run, keep: np.ndarray) -> dict[float, float]:
    (row,) = signal_profile(Run(run.path, run.meta, [s for s, k in zip(run.samples, keep) if k])).values()
    return row


real = load_run(sys.argv[1])
tables = json.load(open(sys.argv[2]))["tables"]
keep = usable(real)
recorded = profile(real, keep)
for pair in sys.argv[3:]:
    name, path = pair.split("=", 1)
    still = profile(load_run(path), keep & usable(load_run(path)))
    rows = tables[name]
    sheared = {r["lateral_mm"]: r["twin"] for r in rows if r["figure"] == "signal"}
    twin = {l: still[l] if l < 0 else sheared.get(l, float("nan")) for l in recorded if l != 0.0}
    print(name)
    misses = [(l, twin[l], v) for l, v in sorted(recorded.items()) if l != 0.0 and not abs(twin[l] - v) <= 0.1]
    n = sum(1 for l in recorded if l != 0.0)
    print(
        f"  signal         {n - len(misses):2d}/{n}  "
        + ", ".join(f"{l:+.0f}: {t:.2f} vs {r:.2f}" for l, t, r in misses)
    )
    for figure in ("theta_pc23", "drag/signal"):
        cells = [r for r in rows if r["figure"] == figure]
        bad = [r for r in cells if not 2 / 3 <= r["twin"] / r["recorded"] <= 4 / 3]
        print(
            f"  {figure:14s} {len(cells) - len(bad):2d}/{len(cells)}  "
            + ", ".join(f"{r['lateral_mm']:+.0f}: {r['twin']:.2f} vs {r['recorded']:.2f}" for r in bad)
        )
