"""`twin run`: execute any scenario on its backend and record it — open-loop protocols
(twin.runs.runner) and closed-loop contour following (twin.runs.contour)."""
from __future__ import annotations

from pathlib import Path

from twin.core.scenario import Scenario
from twin.runs.contour import run_contour
from twin.runs.runner import record_protocol


def run_scenario(scenario: Scenario, out: Path, seed: int | None = None, workers: int | None = None,
                 cluster: str | None = None, progress: bool = True, controller=None) -> Path:
    """Run and record a scenario into `out`; returns the run directory.

    seed: overrides the scenario's seed; workers / cluster: parallel chunks of open-loop
    protocols (twin.runs.parallel); controller: a contour controller object that replaces
    the scenario's `protocol.controller` (twin.control.controllers.Controller)."""
    if scenario.protocol.kind == "contour":
        return run_contour(scenario, out, seed=seed, progress=progress, controller=controller)
    return record_protocol(scenario, out, seed=seed, workers=workers, cluster=cluster, progress=progress)
