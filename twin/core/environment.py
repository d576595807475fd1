"""The environment interface shared by the simulated and the real rig.

Everything downstream of `Observation` (tracker, perception, controller, recording) is
the same code for both backends. Units follow docs/conventions.md: poses in mm/deg in
the scenario's work frame, pins in px, time in s.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from twin.core.poses import Pose
from twin.core.sensor import CameraModel


@dataclass
class Observation:
    """One sensor reading after a commanded move has finished.

    | field          | type / shape            | unit | meaning                                        |
    |----------------|-------------------------|------|------------------------------------------------|
    | time           | float                   | s    | sim clock (sim) or time.monotonic (hardware)   |
    | pose           | Pose                    | mm/deg | measured sensor pose in the work frame       |
    | frame          | (H, W, 3) uint8 or None | —    | camera image (RGB) when rendered or filmed     |
    | pins_px        | (127, 2) float or None  | px   | pins projected through the camera model when   |
    |                |                         |      | the scene has no rendering; None when `frame` |
    |                |                         |      | is given (the tracker finds them)              |
    | truth          | dict                    | —    | sim-only ground truth (true pins px, contact   |
    |                |                         |      | force N, penetration mm); empty on hardware    |
    """

    time: float
    pose: Pose
    frame: np.ndarray | None = None
    pins_px: np.ndarray | None = None
    truth: dict = field(default_factory=dict)


class Environment(ABC):
    """Move the TacTip, read it. Implemented by `twin.runs.sim_env.SimEnvironment` and
    `hardware.env.HardwareEnvironment`; made from a scenario by `twin.runs.backends.make_environment`."""

    #: camera model of the sensor (intrinsics and resolution of `Observation.frame`)
    camera: CameraModel
    #: work frame pose in the robot base frame (mm/deg)
    work_frame: Pose

    @abstractmethod
    def reset(self, seed: int | None = None) -> Observation:
        """Return to the scenario's no-contact start pose and observe there.

        seed: reseeds the backend's randomness (the simulator's camera noise) for the new
        episode; None keeps the current seed, so every reset replays the same noise. A
        real rig has no seed to set and ignores it."""

    @abstractmethod
    def move_to(self, pose: Pose, speed_mm_s: float | None = None) -> None:
        """Move the sensor in a straight line to `pose` (work frame, mm/deg) and wait
        until the motion has finished (and, in sim, the dome has settled).

        Raises UnreachablePoseError / SafetyError before moving when the pose is refused.
        """

    @abstractmethod
    def observe(self) -> Observation:
        """Read the sensor at the current pose."""

    @abstractmethod
    def close(self) -> None:
        """Release the robot, camera or renderer. Safe to call twice."""

    def step(self, pose: Pose, speed_mm_s: float | None = None) -> Observation:
        """`move_to` then `observe`: one sample of a protocol."""
        self.move_to(pose, speed_mm_s)
        return self.observe()

    def __enter__(self) -> Environment:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
