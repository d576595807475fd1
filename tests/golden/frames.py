"""The frames under golden-image test, shared by the test and the regeneration script."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.core.scenario import load_scenario
from twin.runs.sim_env import SimEnvironment, first_pose

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def no_contact_frame() -> np.ndarray:
    """The inside-camera frame of the rectangle scenario with the sensor out of contact,
    rendered by GL (the golden images are GL's, one per backend)."""
    base = load_scenario(SCENARIOS / "rectangle_render.yaml")
    camera = base.sensor.camera.model_copy(update={"renderer": "gl"})
    scenario = base.model_copy(update={"sensor": base.sensor.model_copy(update={"camera": camera})})
    with SimEnvironment(scenario) as env:
        env.move_to(first_pose(scenario))
        return env.observe().frame


GOLDEN_FRAMES = {"no_contact": no_contact_frame}
