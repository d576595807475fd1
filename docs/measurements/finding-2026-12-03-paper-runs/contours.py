"""The contour runs' figures (their metrics.json, as `twin demo` prints them) and, from their
samples, the mean of the orientation error (perceived − true edge normal, deg) beside its
spread, the true and perceived lateral position's mean (mm).

    python contours.py runs/contour_*_fit
"""

import json
import sys
from pathlib import Path

import numpy as np

from twin.core.poses import wrap_deg

print(
    f"{'run':32s} {'closed':>7s} {'steps':>5s} {'θ RMS °':>8s} {'θ mean °':>9s} {'θ sd °':>7s}"
    f" {'path mean mm':>12s} {'l mean mm':>9s} {'l̂ mean mm':>10s}"
)
rms = []
for run in sys.argv[1:]:
    metrics = json.loads((Path(run) / "metrics.json").read_text())
    rows = [json.loads(line)["labels"] for line in (Path(run) / "samples.jsonl").read_text().splitlines()]
    rows = [r for r in rows if r.get("ok")]
    err = wrap_deg([r["perceived_normal_deg"] - r["true_normal_deg"] for r in rows])
    rms.append(metrics["orientation_rms_deg"])
    print(
        f"{Path(run).name:32s} {str(metrics['completed']):>7s} {metrics['steps']:5d} {metrics['orientation_rms_deg']:8.2f}"
        f" {err.mean():+9.1f} {err.std():7.1f} {metrics['path_distance_mean_mm']:12.2f}"
        f" {np.mean([r['true_lateral_mm'] for r in rows]):+9.2f} {np.mean([r['lateral_hat_mm'] for r in rows]):+10.2f}"
    )
print(f"mean orientation RMS over these runs: {np.mean(rms):.2f}°")
