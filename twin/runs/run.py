"""`twin run`: execute any scenario on its backend and record it — open-loop protocols
(twin.runs.runner) and closed-loop contour following (twin.runs.contour_run)."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

from twin.core.errors import UserError
from twin.core.scenario import Scenario, scenario_from_dict
from twin.runs.record import jsonable, load_run
from twin.runs.runner import record_protocol


def run_scenario(
    scenario: Scenario,
    out: Path,
    seed: int | None = None,
    workers: int | None = None,
    cluster: str | None = None,
    progress: bool = True,
    controller=None,
) -> Path:
    """Run and record a scenario into `out`; returns the run directory.

    seed: overrides the scenario's seed; workers / cluster: parallel chunks of open-loop
    protocols (twin.runs.parallel); controller: a contour controller object that replaces
    the scenario's `protocol.controller` (twin.control.controllers.Controller)."""
    if scenario.protocol.kind == "contour":
        return importlib.import_module("twin.runs.contour_run").run_contour(
            scenario, out, seed=seed, progress=progress, controller=controller
        )
    return record_protocol(scenario, out, seed=seed, workers=workers, cluster=cluster, progress=progress)


def resume_run(
    out: Path,
    scenario: Scenario | None = None,
    seed: int | None = None,
    workers: int | None = None,
    cluster: str | None = None,
    progress: bool = True,
) -> Path:
    """Continue an interrupted or killed run in `out` after its last complete sample.

    The protocol is replayed from the start of the unfinished chunk (contour following:
    from its first step) without recording, so the simulator's path-dependent dome state
    and camera-noise generator are where they were: the finished run is bit-identical to
    an uninterrupted one. `scenario` and `seed`, when given, must be the run's own
    (UserError otherwise); by default both are read from the run's run.json."""
    run = load_run(out)
    recorded = run.meta["scenario"]
    if scenario is not None:
        given = json.loads(json.dumps(jsonable(scenario.model_dump())))
        changed = sorted(k for k in set(given) | set(recorded) if given.get(k) != recorded.get(k))
        if changed:
            raise UserError(
                f"{out}: recorded with a different scenario ({run.meta.get('scenario_file')}); "
                f"fields that differ: {', '.join(changed)}; resume it without a scenario or with that one"
            )
    if seed is not None and seed != run.meta["seed"]:
        raise UserError(f"{out}: recorded with seed {run.meta['seed']}, not {seed}; resume it with the same seed")
    scenario = scenario_from_dict(recorded, run.meta.get("scenario_file", str(out / "run.json")))
    seed = run.meta["seed"]
    if scenario.protocol.kind == "contour":
        return importlib.import_module("twin.runs.contour_run").run_contour(
            scenario, out, seed=seed, progress=progress, resume=True
        )
    return record_protocol(scenario, out, seed=seed, workers=workers, cluster=cluster, progress=progress, resume=True)
