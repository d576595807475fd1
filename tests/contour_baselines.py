"""Per-shape contour-following baselines: what the regression tests compare against.

Regenerate (after a change that is meant to move the figures, and say why in the commit):

    .venv/bin/python -m tests.contour_baselines

It traces the six objects exactly as the tests do (the tap model from the cache,
twin.runs.training; one process) and writes tests/baselines/contours.json.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from twin.core.resources import scenario_path
from twin.core.scenario import load_scenario
from twin.runs.training import cached_tap_model
from twin.tools.demo import OBJECTS, trace_contour

BASELINE_FILE = Path(__file__).resolve().parent / "baselines" / "contours.json"
#: the figures a baseline holds per object (metrics.json keys, twin.control.contour)
KEYS = (
    "completed",
    "stop_reason",
    "steps",
    "orientation_rms_deg",
    "lateral_rms_mm",
    "path_distance_mean_mm",
    "path_distance_max_mm",
    "coverage",
)


def trace_all(out: Path) -> dict[str, dict]:
    """metrics.json of each of the six objects' contour runs (default fidelity, seed 0)."""
    scenarios = {name: load_scenario(scenario_path(f"contour_{name}")) for name in OBJECTS}
    model = cached_tap_model(scenarios["rectangle"], progress=False)
    return {name: trace_contour(s, out / s.name, model) for name, s in scenarios.items()}


def main() -> int:
    with tempfile.TemporaryDirectory() as out:
        metrics = trace_all(Path(out))
    baselines = {name: {k: m[k] for k in KEYS} for name, m in metrics.items()}
    BASELINE_FILE.parent.mkdir(parents=True, exist_ok=True)
    BASELINE_FILE.write_text(json.dumps(baselines, indent=1) + "\n")
    for name, b in baselines.items():
        print(
            f"{name:13s} completed={b['completed']!s:5s} steps={b['steps']:4d} "
            f"θ RMS {b['orientation_rms_deg']:6.1f}°  path {b['path_distance_mean_mm']:6.2f} mm  ({b['stop_reason']})"
        )
    print(f"wrote {BASELINE_FILE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
