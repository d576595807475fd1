"""A Gymnasium wrapper over any `Environment` for learned contour-following policies.

| space        | shape   | unit | meaning                                                   |
|--------------|---------|------|-----------------------------------------------------------|
| observation  | (254,)  | px   | pin displacements from the no-contact pins, (u1, v1, …)   |
| action       | (2,)    | –    | sensor step (Δx, Δy) in the work frame as a fraction of   |
|              |         |      | max_step_mm (each in [−1, 1]; the step is action × max_step_mm) |

Reward per step: progress along the true contour (mm, counter-clockwise) minus
`lateral_weight` × |signed distance to the contour − l_d| (mm). The episode terminates
when the contour is completed (or the sensor strays more than `max_distance_mm` from it)
and is truncated after `max_steps`. Depth and orientation come from the scenario's
contour protocol. Works on the sim and, with care, on the hardware backend.

Registered with Gymnasium as `twin.GYM_ID` (twin.runs.gym_registration):
``gymnasium.make(twin.GYM_ID, scenario="contour_flower")`` (a shipped scenario's name, a
path, or a Scenario).
`reset(seed=…)` seeds the wrapper's `np_random`, which seeds the backend (the simulator's
camera noise): one seed, one run.

Vector envs: ``gymnasium.make_vec(twin.GYM_ID, num_envs=N, scenario=…)`` (no mode) runs
the envs in one worker process per core, several envs each (twin.runs.vector_env): the
mode that keeps the cores busy. ``vectorization_mode="async"`` (with ``vector_kwargs=
{"context": "forkserver"}``) runs each env in its own process; call
`twin.runs.parallel.one_blas_thread` and `one_render_thread` before it, so that each env
process runs one BLAS thread and renders in its own thread. Each vector step waits for
the slowest env (or worker): a step's cost follows the physics steps its contact takes to
settle, so envs stepping different actions wait for each other
(docs/examples/vector_steps.py prints how long).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import shapely

from twin.core.poses import Pose, object_to_work_xy, work_to_object_xy
from twin.core.scenario import Scenario, hover_over, load_scenario
from twin.runs.backends import make_environment
from twin.runs.spec import load_scenario_stimulus
from twin.sensing.pins import PinReader


class ContourFollowingEnv(gym.Env):
    """reset(seed) → (observation, info); step(action) → (obs, reward, terminated, truncated, info)."""

    #: render_fps: frames per second of a video of the env's frames (one per step, 10/s as `twin run`'s videos)
    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        scenario: Scenario | str | Path = "contour_rectangle",
        max_step_mm: float = 5.0,
        lateral_weight: float = 0.5,
        max_distance_mm: float = 15.0,
        render_mode: str | None = None,
    ) -> None:
        if not isinstance(scenario, Scenario):
            scenario = load_scenario(scenario)
        if scenario.protocol.kind != "contour":
            raise ValueError(f"{scenario.source}: the Gymnasium environment needs a contour protocol")
        self.scenario = scenario
        self.protocol = scenario.protocol
        self.stimulus = load_scenario_stimulus(scenario)
        self.env = make_environment(scenario)
        self.max_step_mm = max_step_mm
        self.lateral_weight = lateral_weight
        self.max_distance_mm = max_distance_mm
        self.render_mode = render_mode
        self.observation_space = gym.spaces.Box(-200.0, 200.0, shape=(254,), dtype=np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self._reader = None
        self._last = None

    def _pins(self, obs) -> np.ndarray:
        pins, _, _ = self._reader.read(obs)
        return (pins - self._rest).astype(np.float32).ravel()

    def _arc(self, xy_work: np.ndarray) -> float:
        ring = self.stimulus.outline.exterior

        return float(ring.project(shapely.Point(*work_to_object_xy(xy_work)[0])))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        reference = self.env.reset(seed=int(self.np_random.integers(2**31 - 1)))
        self._reader = PinReader(reference)
        self._rest, _, _ = self._reader.read(reference)
        start = object_to_work_xy(self.stimulus.start_point_mm)[0]
        p = self.protocol
        self.env.move_to(hover_over(start[0], start[1], p.orientation_deg), p.speed_mm_s)
        self._pose = Pose(start[0], start[1], p.depth_mm, 0, 0, p.orientation_deg)
        self.env.move_to(self._pose, p.speed_mm_s)
        self._last = self.env.observe()
        self._progress = 0.0
        self._arc_prev = self._arc(start)
        self._steps = 0
        return self._pins(self._last), {"pose": self._pose}

    def step(self, action):
        a = np.clip(np.asarray(action, float), -1.0, 1.0) * self.max_step_mm
        p = self.protocol
        self._pose = Pose(self._pose.x + a[0], self._pose.y + a[1], self._pose.z, 0, 0, p.orientation_deg)
        self.env.move_to(self._pose, p.speed_mm_s)
        self._last = self.env.observe()
        xy = np.array([self._pose.x, self._pose.y])
        arc = self._arc(xy)
        perimeter = self.stimulus.perimeter_mm
        d_arc = (arc - self._arc_prev + perimeter / 2) % perimeter - perimeter / 2
        self._arc_prev = arc
        self._progress += d_arc
        signed = float(self.stimulus.signed_distance_mm(work_to_object_xy(xy))[0])
        reward = d_arc - self.lateral_weight * abs(signed - p.lateral_target_mm)
        self._steps += 1
        terminated = self._progress >= perimeter or abs(signed) > self.max_distance_mm
        truncated = self._steps >= p.max_steps
        info = {"pose": self._pose, "progress_mm": self._progress, "signed_distance_mm": signed}
        return self._pins(self._last), float(reward), bool(terminated), bool(truncated), info

    def render(self):
        return None if self._last is None else self._last.frame

    def close(self) -> None:
        self.env.close()
