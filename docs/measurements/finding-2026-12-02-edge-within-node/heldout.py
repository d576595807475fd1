"""The held-out taps of tests/analysis/test_evaluation.py on the compliant default, within
nodes (1) or at whole nodes (0): θ and l RMS by lateral position.

    python heldout.py 1|0 OUT_DIR
"""

import sys
from pathlib import Path

from twin.analysis.evaluation import evaluate
from twin.core.resources import scenario_path
from twin.core.scenario import load_scenario
from twin.runs.run import run_scenario

within = sys.argv[1] == "1"
out = Path(sys.argv[2])


def record(name, **protocol):
    s = load_scenario(scenario_path(name))
    s = s.with_changes(
        dome="compliant",
        effects=["contact", "friction"],
        protocol=s.protocol.model_dump() | protocol,
        physics={"edge_within_node": within},
    )
    return run_scenario(s, out / name, workers=1, progress=False)


train = record("taps_rectangle")
held = record("taps_heldout", orientations_deg=[-170, -110, -50, 10, 70, 130], lateral_mm=[5, 3, 1, -1, -3, -5])
r = evaluate(train, held, out / "eval")
for l, row in r["heldout_by_lateral_mm"]["PCA + GP"].items():
    print(l, round(row["theta_rms_deg"], 2), round(row["lateral_rms_mm"], 3))
