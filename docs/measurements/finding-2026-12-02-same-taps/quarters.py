"""The signal ratio of a recording's sheared taps by which taps are taken: all of them,
with each ratio's bootstrap standard deviation (twin.analysis.calibration_fit.figures.
figure_spread, 50 resamples, seed 0), and each quarter of them (every fourth tap from the
1st, 2nd, 3rd and 4th).

    python quarters.py RUN   (an imported lab recording: twin import-lab)"""

import sys

from twin.analysis.calibration_fit.figures import figure_spread, figure_values
from twin.runs.record import Run, load_run

run = load_run(sys.argv[1])
rest = [s for s in run.samples if s["labels"].get("no_contact")]
taps = [s for s in run.samples if not s["labels"].get("no_contact")]
values = figure_values(run)
spread = figure_spread(run, 50, 0, values)
laterals = sorted((l for f, l in values if f == "signal"), reverse=True)
print("signal / l = 0's by lateral bin (mm): " + "  ".join(f"{l:+.0f}" for l in laterals))
print("all taps      " + "  ".join(f"{values['signal', l]:.2f} ± {spread['signal', l]:.2f}" for l in laterals))
for start in range(4):
    quarter = figure_values(Run(run.path, run.meta, rest + taps[start::4]))
    cells = [f"{quarter['signal', l]:.2f}" if ("signal", l) in quarter else "—" for l in laterals]
    print(f"every 4th from tap {start + 1}  " + "  ".join(cells))
