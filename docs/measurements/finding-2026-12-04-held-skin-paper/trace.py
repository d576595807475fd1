"""The first steps of contour runs: per step the perceived edge normal's error (deg; the
perceived normal minus the true one), the perceived and the true lateral position (mm;
negative = onto the object). usage: python trace.py RUN... [--steps N] (N = 14)"""

import argparse
import json
from pathlib import Path

parser = argparse.ArgumentParser()
parser.add_argument("runs", nargs="+", type=Path)
parser.add_argument("--steps", type=int, default=14)
args = parser.parse_args()
for run in args.runs:
    print(run)
    print("  step  normal error °  l̂ mm   l mm")
    for line in (run / "samples.jsonl").read_text().splitlines()[: args.steps]:
        labels = json.loads(line)["labels"]
        error = (labels["perceived_normal_deg"] - labels["true_normal_deg"] + 180) % 360 - 180
        print(
            f"  {labels['step']:4d}  {error:+13.1f}  {labels['lateral_hat_mm']:+5.2f}  {labels['true_lateral_mm']:+5.2f}"
        )
