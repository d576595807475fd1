"""`twin view`: run a scenario live in MuJoCo's interactive viewer (mujoco.viewer) — the
rig with the arm following every sample, and the sensor's frame with its pins and their
displacement from rest in an inset (bottom left). Nothing is recorded; `twin run --video`
is the headless way to watch a run.
"""
from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np

from twin.world import gl  # noqa: F401  (must precede the mujoco import)
import mujoco
import mujoco.viewer

from twin.control.contour import ContourFollower
from twin.core.environment import Environment, Observation
from twin.core.errors import UserError
from twin.core.scenario import Scenario
from twin.runs.backends import make_environment
from twin.runs.protocols import protocol_moves
from twin.runs.runner import chunk_moves, chunk_samples
from twin.runs.training import model_for_scenario
from twin.tools.video import percept_text, sensor_panel, write_text
from twin.world.scene import Overview

INSET_HEIGHT = 300  # px: the sensor frame's inset in the viewer window


def has_display() -> bool:
    """Whether a window can be opened (an X11 or Wayland display is named)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def scenario_steps(env: Environment, scenario: Scenario) -> Iterator[tuple[Observation, np.ndarray, np.ndarray | None, dict, np.ndarray]]:
    """(observation, pins px, found, labels, rest pins px) per recorded sample of any
    protocol: contour following closes the loop with the scenario's model; open-loop
    protocols run chunk by chunk from a reset, as `twin run` does."""
    if scenario.protocol.kind == "contour":
        follower = ContourFollower(env, scenario, model_for_scenario(scenario))
        for step in follower:
            yield step.observation, step.pins_px, step.found, step.labels, follower.rest_pins_px
        return
    for chunk in chunk_moves(protocol_moves(scenario.protocol)):
        for s in chunk_samples(env, chunk):
            yield s.observation, s.pins_px, s.found, s.move.labels, s.rest_px


def view_scenario(scenario: Scenario, seed: int | None = None) -> int:
    """Run `scenario` in the interactive viewer until it ends or the window is closed;
    returns the number of samples shown. Raises UserError without a display."""
    if not has_display():
        raise UserError("twin view needs a display, and neither DISPLAY nor WAYLAND_DISPLAY is set "
                        "(headless: `twin run SCENARIO --video` writes an MP4 of the run instead)")
    overview = Overview(scenario)
    env = make_environment(scenario, seed)
    resolution = (env.camera.width, env.camera.height)
    shown = 0
    try:
        with mujoco.viewer.launch_passive(overview.model, overview.data, show_left_ui=False,
                                          show_right_ui=False) as viewer:
            viewer.cam.lookat[:] = overview.object2world[:3, 3] + np.array([-0.15, 0.0, 0.2])
            viewer.cam.distance, viewer.cam.azimuth, viewer.cam.elevation = 1.0, 120.0, -25.0
            for obs, pins, found, labels, rest in scenario_steps(env, scenario):
                if not viewer.is_running():
                    break
                inset = sensor_panel(obs.frame, resolution, pins, rest, found, height=INSET_HEIGHT)
                write_text(inset, [f"t {obs.time:.2f} s", percept_text(labels)])
                with viewer.lock():
                    overview.pose_sensor(obs.pose)
                viewer.set_images((mujoco.MjrRect(0, 0, inset.shape[1], inset.shape[0]), inset))
                viewer.sync()
                shown += 1
    finally:
        env.close()
    return shown
