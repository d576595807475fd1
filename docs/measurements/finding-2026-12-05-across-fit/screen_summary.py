"""Per replay of a recording's taps: its edge figures against the recording's, as
twin calibrate counts them (θ_PC23 turns in the recording's plane): geometric-mean
twin / recording of the along- and across-edge turns onto (l < 0) and off (l > 0) the
object, and of drag / signal; the signal ratios' mean difference; figures within tolerance.

    python screen_summary.py REAL_RUN REPLAY_RUN [...]
"""

import math
import sys

import numpy as np

from twin.analysis.calibration_fit.figures import figure_values, miss
from twin.analysis.comparison import taps_both_kept
from twin.analysis.edge_imprint import carried_pcs, tap_pcs
from twin.runs.record import load_run


def ratios(twin: dict, recorded: dict, figure: str, sign: int) -> list[float]:
    """twin / recorded of one figure at the l on one side of the edge (sign −1: onto the object)."""
    return [
        twin[k] / recorded[k]
        for k in recorded
        if k[0] == figure and k in twin and np.sign(k[1]) == sign and recorded[k] > 0
    ]


def gm(values: list[float]) -> float:
    return math.exp(np.mean(np.log(values))) if values else math.nan


real = load_run(sys.argv[1])
print(
    f"{'replay':28s} {'along -':>8s} {'along +':>8s} {'across -':>9s} {'across +':>9s} {'ratio -':>8s} {'drag/sig':>9s} {'signal Δ':>9s} {'within':>7s}"
)
for path in sys.argv[2:]:
    replay = load_run(path)
    shared = taps_both_kept(real, replay)
    r, t = real.subset([i for i, _ in shared]), replay.subset([j for _, j in shared])
    vr = figure_values(r)
    vt = figure_values(t, pcs=carried_pcs(tap_pcs(r), r, t))

    onto_a, off_a = ratios(vt, vr, "theta_pc23", -1), ratios(vt, vr, "theta_pc23", 1)
    onto_x, off_x = ratios(vt, vr, "theta_pc23_across", -1), ratios(vt, vr, "theta_pc23_across", 1)
    ds = [vt[k] / vr[k] for k in vr if k[0] == "drag/signal" and k in vt]
    sig = [vt[k] - vr[k] for k in vr if k[0] == "signal" and k in vt]
    within = sum(abs(miss(k[0], vt.get(k), vr[k])) <= 1.0 for k in vr)
    print(
        f"{path.rstrip('/').split('/')[-1]:28s} {gm(onto_a):8.2f} {gm(off_a):8.2f} {gm(onto_x):9.2f} {gm(off_x):9.2f} "
        f"{gm(onto_x) / gm(onto_a):8.2f} {gm(ds):9.2f} {np.mean(sig):+9.2f} {within:4d}/{len(vr)}"
    )
print("(ratio −: the across / along turn onto the object over the recording's; 1 = the recording's anisotropy)")
