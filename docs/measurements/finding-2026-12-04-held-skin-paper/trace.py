"""The first steps of contour runs: per step the perceived edge normal's error (deg; the
perceived normal minus the true one), the perceived and the true lateral position (mm;
negative = onto the object). usage: python trace.py RUN... [--steps N] (N = 14)"""

import json
import sys
from pathlib import Path

args = sys.argv[1:]
steps = int(args[args.index("--steps") + 1]) if "--steps" in args else 14
runs = [a for a in args if a != "--steps" and not a.isdigit()]
for run in runs:
    print(run)
    print("  step  normal error °  l̂ mm   l mm")
    for line in Path(run, "samples.jsonl").read_text().splitlines()[:steps]:
        labels = json.loads(line)["labels"]
        error = (labels["perceived_normal_deg"] - labels["true_normal_deg"] + 180) % 360 - 180
        print(
            f"  {labels['step']:4d}  {error:+13.1f}  {labels['lateral_hat_mm']:+5.2f}  {labels['true_lateral_mm']:+5.2f}"
        )
