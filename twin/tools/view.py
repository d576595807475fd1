"""`twin view`: run a scenario live in MuJoCo's interactive viewer (mujoco.viewer) — the
rig with the arm following every sample, and the sensor's frame with its pins and their
displacement from rest on a screen standing beside the rig (a texture updated per sample:
the viewer's own image overlay, Handle.set_images, is drawn behind the scene's geometry in
mujoco 4.0.0). Nothing is recorded; `twin run --video` is the headless way to watch a run.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator

import cv2
import mujoco.viewer
import numpy as np

from twin.core.environment import Environment, Observation
from twin.core.errors import UserError
from twin.core.scenario import Scenario
from twin.runs.backends import make_environment
from twin.runs.contour_run import ScenarioFollower
from twin.runs.protocols import protocol_moves
from twin.runs.runner import chunk_moves, chunk_samples
from twin.runs.spec import scene_spec
from twin.runs.training import model_for_scenario
from twin.tools.video import percept_text, sensor_panel, write_text
from twin.world.scene import Overview

SCREEN_PX = (400, 300)  # (width, height) px of the sensor frame on the screen
VIEW_AZIMUTH_DEG = 120.0  # the viewer's initial camera heading; the screen faces it


def has_display() -> bool:
    """Whether a window can be opened (an X11 or Wayland display is named)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def scenario_steps(
    env: Environment, scenario: Scenario
) -> Iterator[tuple[Observation, np.ndarray, np.ndarray | None, dict, np.ndarray]]:
    """(observation, pins px, found, labels, rest pins px) per recorded sample of any
    protocol: contour following closes the loop with the scenario's model; open-loop
    protocols run chunk by chunk from a reset, as `twin run` does."""
    if scenario.protocol.kind == "contour":
        follower = ScenarioFollower(env, scenario, model_for_scenario(scenario))
        for step in follower:
            yield step.observation, step.pins_px, step.found, step.labels, follower.rest_pins_px
        return
    for chunk in chunk_moves(protocol_moves(scenario.protocol)):
        for s in chunk_samples(env, chunk):
            yield s.observation, s.pins_px, s.found, s.move.labels, s.rest_px


def view_scenario(scenario: Scenario, seed: int | None = None, wait: bool = True) -> int:
    """Run `scenario` in the interactive viewer until it ends (then, with `wait`, until
    the window is closed) or the window is closed; returns the number of samples shown.
    Raises UserError without a display."""
    if not has_display():
        raise UserError(
            "twin view needs a display, and neither DISPLAY nor WAYLAND_DISPLAY is set "
            "(headless: `twin run SCENARIO --video` writes an MP4 of the run instead)"
        )
    overview = Overview(scene_spec(scenario), screen_px=SCREEN_PX, screen_azimuth_deg=VIEW_AZIMUTH_DEG)
    env = make_environment(scenario, seed)
    resolution = (env.camera.width, env.camera.height)
    shown = 0
    before = set(threading.enumerate())
    try:
        with mujoco.viewer.launch_passive(
            overview.model, overview.data, show_left_ui=False, show_right_ui=False
        ) as viewer:
            viewer.cam.lookat[:] = overview.object2world[:3, 3] + np.array([0.0, 0.1, 0.2])
            viewer.cam.distance, viewer.cam.azimuth, viewer.cam.elevation = 1.4, VIEW_AZIMUTH_DEG, -25.0
            for obs, pins, found, labels, rest in scenario_steps(env, scenario):
                if not viewer.is_running():
                    break
                screen = sensor_panel(obs.frame, resolution, pins, rest, found, height=SCREEN_PX[1])
                screen = cv2.resize(screen, SCREEN_PX) if screen.shape[1] != SCREEN_PX[0] else screen
                write_text(screen, [f"t {obs.time:.2f} s", percept_text(labels)])
                with viewer.lock():
                    overview.pose_sensor(obs.pose)
                    overview.screen_texture(screen)
                viewer.update_texture(overview.screen_texture_id)
                viewer.sync()
                shown += 1
            if wait and viewer.is_running():
                print(f"{scenario.name}: finished after {shown} samples; close the window to exit")
            while wait and viewer.is_running():
                viewer.sync()
                time.sleep(0.05)
    finally:
        env.close()
        for thread in set(threading.enumerate()) - before:  # the viewer's: let it close its window
            thread.join(timeout=5.0)
    return shown
