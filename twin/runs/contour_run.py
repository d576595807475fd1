"""Contour-following runs: trace an object with the closed loop (twin.control.contour),
record every step (twin.runs.record), then score the run against the true contour
(twin.runs.contour_metrics) and plot it (the paper's Figs. 7–8).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from twin.control.contour import ContourFollower, no_clock
from twin.control.controllers import load_controller
from twin.core.environment import Environment
from twin.core.errors import UserError
from twin.core.files import replace_file
from twin.core.poses import work_to_object_xy
from twin.core.scenario import Scenario
from twin.runs.backends import make_environment
from twin.runs.contour_metrics import contour_metrics
from twin.runs.record import RunRecorder, load_run
from twin.runs.spec import load_scenario_stimulus
from twin.runs.training import model_for_scenario
from twin.world.stimuli import Stimulus


class ScenarioFollower(ContourFollower):
    """The closed loop (twin.control.contour.ContourFollower) of a contour scenario on
    `env`: its protocol, its object (`stimulus`, loaded when not given) and its controller
    (`controller`, an object or a name, replaces the scenario's `protocol.controller`).
    UserError when the scenario's work frame is not the object's."""

    def __init__(
        self,
        env: Environment,
        scenario: Scenario,
        model,
        stimulus: Stimulus | None = None,
        clock=no_clock,
        controller=None,
    ) -> None:
        if scenario.work_frame != "object":
            raise UserError(f"{scenario.source}: contour following needs work_frame: object")
        stimulus = load_scenario_stimulus(scenario) if stimulus is None else stimulus
        protocol = scenario.protocol
        spec = protocol.controller if controller is None else controller
        super().__init__(
            env,
            protocol,
            model,
            stimulus,
            load_controller(spec, protocol, scenario.source_dir),
            clock,
            controller_name=spec if isinstance(spec, str) else None,
        )


def run_contour(
    scenario: Scenario,
    out: Path,
    seed: int | None = None,
    progress: bool = True,
    model=None,
    controller=None,
    resume: bool = False,
) -> Path:
    """Trace the scenario's object and record the run in `out` (with metrics.json and
    contour.png). `model` is a fitted PerceptionModel; default: scenario's `model` file,
    else the cached model trained on the tap set (twin.runs.training). `controller`: an
    object replacing the scenario's `protocol.controller` (twin.control.controllers).
    `resume`: continue the unfinished run in `out`, replaying its recorded steps unrecorded
    (the closed loop is deterministic on the simulator)."""
    seed = scenario.seed if seed is None else seed
    if model is None:
        model = model_for_scenario(scenario)
    stimulus = load_scenario_stimulus(scenario)
    wall0 = time.perf_counter()
    env = make_environment(scenario, seed)
    follower = ScenarioFollower(env, scenario, model, stimulus, controller=controller)
    recorder = (
        RunRecorder.resume(out)
        if resume
        else RunRecorder(
            out,
            scenario,
            seed,
            scenario.backend,
            scenario.camera_model(),
            extra={"model": model.info.get("path", "in memory")},
        )
    )
    try:
        with recorder:
            done = recorder.count
            for i, step in enumerate(
                tqdm(follower, desc=scenario.name, unit="step", total=scenario.protocol.max_steps, disable=not progress)
            ):
                recorder.set_rest_pins(follower.rest_pins_px)
                if i < done:
                    continue
                recorder.add(step.observation, step.target, step.labels, step.pins_px, step.found)
            recorder.meta["stop_reason"] = follower.stop_reason
            recorder.meta["wall_time_s"] = time.perf_counter() - wall0
    finally:
        env.close()
    metrics = contour_metrics(load_run(out), stimulus)
    replace_file(Path(out) / "metrics.json", json.dumps(metrics, indent=1))
    plot_contour(load_run(out), stimulus, Path(out) / "contour.png")
    return Path(out)


def object_path(samples: list[dict]) -> tuple[np.ndarray, np.ndarray | None]:
    """The sensor's measured path (N, 2) mm in the object frame seen from above, and the
    perceived edge normals (N,) deg in that frame (None when the samples carry none:
    open-loop protocols)."""
    xy = work_to_object_xy(np.array([[s["pose"][0], s["pose"][1]] for s in samples]).reshape(-1, 2))
    if not samples or "perceived_normal_deg" not in samples[0]["labels"]:
        return xy, None
    return xy, -np.array([s["labels"]["perceived_normal_deg"] for s in samples])  # work → object angle


def plot_contour(run, stimulus, out: Path) -> Path:
    """The paper's Figs. 7–8: the object's outline, the sensor path and the perceived
    edge normals (grey), in the object frame seen from above (mm)."""

    matplotlib.use("Agg")

    xy, normals = object_path(run.samples)
    fig, ax = plt.subplots(figsize=(5, 5), dpi=120)
    outline = np.asarray(stimulus.outline.exterior.coords)
    ax.fill(outline[:, 0], outline[:, 1], color="0.92", zorder=0)
    ax.plot(outline[:, 0], outline[:, 1], color="0.5", lw=0.8, zorder=1)
    for (x, y), a in zip(xy, np.radians(normals)):
        ax.plot([x, x - 8 * np.cos(a)], [y, y - 8 * np.sin(a)], color="0.6", lw=0.6, zorder=2)
    ax.plot(xy[:, 0], xy[:, 1], color="tab:blue", lw=1.5, zorder=3, label="sensor path")
    ax.plot(*xy[0], "o", color="tab:green", ms=5, zorder=4, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"{stimulus.name}: contour following")
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return out
