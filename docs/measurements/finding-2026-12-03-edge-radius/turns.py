"""Per replay of every fourth DigiTac tap (`runs/NAME_n4`, beside the recording `real4`), on
the taps both kept: θ_PC23's turn per mm of slide along the edge over the recording's, each
read in its own orientation pair (`rotating_pair`), off the object (l = +5 … +1) and onto it
(−1 … −5); drag / signal over the recording's (`cmp_NAME_n4/comparison.json`, written by
`twin compare`) and the pins' RMS difference.

    python turns.py NAME [NAME ...]
"""

import json
import sys
from dataclasses import replace

from twin.analysis.comparison import taps_both_kept
from twin.analysis.edge_imprint import along_edge_turn_sheared, rotating_pair, tap_pcs
from twin.runs.record import load_run

recording = load_run("real4")
for name in sys.argv[1:]:
    replay = load_run(f"runs/{name}_n4")
    shared = taps_both_kept(recording, replay)
    real, twin = recording.subset([i for i, _ in shared]), replay.subset([j for _, j in shared])
    real_pcs, twin_pcs = (replace(p, pair=rotating_pair(p.explained)) for p in (tap_pcs(real), tap_pcs(twin)))
    real_turn = {l: v["pc23_deg_per_mm"] for l, v in along_edge_turn_sheared(real, real_pcs).items()}
    own_turn = {l: v["pc23_deg_per_mm"] for l, v in along_edge_turn_sheared(twin, twin_pcs).items()}
    ratio = {l: own_turn[l] / real_turn[l] for l in real_turn}
    off = [ratio[l] for l in sorted(ratio, reverse=True) if l > 0]
    onto = [ratio[l] for l in sorted(ratio, reverse=True) if l < 0]
    comparison = json.load(open(f"cmp_{name}_n4/comparison.json"))
    rows = comparison["edge_figure_differences"]["rows"]
    drag = [r["b"] / r["a"] for r in rows if r["figure"] == "drag/signal" and r["a"] and r["b"] is not None]
    print(
        f"{name}: θ turn off "
        + " ".join(f"{v:.2f}" for v in off)
        + " | onto "
        + " ".join(f"{v:.2f}" for v in onto)
        + f"; drag / signal {min(drag):.2f}–{max(drag):.2f}; pins {comparison['pin_rms_difference_px']:.3f} px"
    )
