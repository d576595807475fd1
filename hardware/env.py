"""The real rig behind the `twin.core.environment.Environment` interface.

| Observation field | hardware meaning                                                      |
|-------------------|-----------------------------------------------------------------------|
| time              | s, time.monotonic() when the frame was read (`hardware.camera.Frame`) |
| pose              | TCP pose measured by the controller (GET_POSE), work frame, mm / deg  |
| frame             | (H, W, 3) uint8 RGB from `TactipCamera.read_fresh()` (after the move) |
| pins_px           | None (the tracker finds the pins in `frame`)                           |
| truth             | {} (no ground truth on the real rig)                                  |

Every move is checked against the safety limits *before* anything is sent, its whole
path included (`SafetyLimits.check_path`, from the last pose commanded, or the measured
one); a refused pose, path or speed raises `SafetyError` and the robot receives nothing.
One exception, logged: a robot found outside the limits (parked elsewhere when the run
starts) may only be sent to the config's start pose, and that approach is not covered by
the limits — keep the controller's own world zones set.
"""

from __future__ import annotations

import logging

import numpy as np

from hardware.camera import TactipCamera
from hardware.config import HardwareConfig, load_hardware_config
from hardware.robot import RobotCommandRefused, RobotDriver
from twin.core.environment import Environment, Observation
from twin.core.errors import SafetyError, UserError
from twin.core.poses import Pose
from twin.core.sensor import CameraModel

log = logging.getLogger(__name__)


class HardwareEnvironment(Environment):
    """IRB120 + TacTip camera. Opens both in the constructor (robot first), configures
    the robot's tool, work frame, speeds and fine-point zone, and releases both on
    `close()` (idempotent)."""

    def __init__(
        self,
        config: HardwareConfig,
        camera_model: CameraModel | None = None,
        *,
        robot: RobotDriver | None = None,
        camera: TactipCamera | None = None,
    ) -> None:
        self.config = config
        self.camera = (
            camera_model if camera_model is not None else CameraModel(config.camera.width, config.camera.height)
        )
        if (self.camera.width, self.camera.height) != (config.camera.width, config.camera.height):
            raise UserError(
                f"camera model is {self.camera.width}×{self.camera.height} but the hardware config's camera "
                f"is {config.camera.width}×{config.camera.height} (camera.width/height)"
            )
        self.work_frame = config.robot.work_frame
        self.safety = config.safety
        r = config.robot
        self.safety.check_speed(r.linear_speed_mm_s, r.angular_speed_deg_s)
        self.safety.check_pose(r.start_pose)
        self.robot: RobotDriver | None = None
        self.sensor: TactipCamera | None = None
        try:
            self.robot = robot or RobotDriver(
                r.host,
                r.port,
                client=r.client,
                connect_timeout_s=r.connect_timeout_s,
                reply_timeout_s=r.reply_timeout_s,
            )
            self.robot.configure(r.tcp, r.work_frame, r.linear_speed_mm_s, r.angular_speed_deg_s)
            c = config.camera
            self.sensor = camera or TactipCamera(c.source, c.width, c.height, c.exposure, c.warmup)
        except BaseException:
            self.close()
            raise
        self._speed_mm_s = r.linear_speed_mm_s
        self._at: Pose | None = None  # the pose last reached by a move (work frame), None = ask the robot

    @classmethod
    def from_scenario(cls, scenario, config_path: str | None = None) -> HardwareEnvironment:
        """The rig for a scenario: its `hardware_config` file (or `config_path`), with the
        scenario's camera resolution."""
        name = config_path or scenario.hardware_config
        if name is None:
            raise UserError(
                f"{scenario.source}: the hardware backend needs a config file: set field "
                "'hardware_config' or pass --hardware-config (see hardware/example_config.yaml)"
            )
        config = load_hardware_config(scenario.resolve(name))
        calibration = scenario.calibration()
        if calibration is not None and not np.array_equal(calibration.tcp2apex, np.eye(4)):
            # the dome apex is calibration.tcp2apex from the configured TCP (tool frame): command the apex itself
            tcp = Pose.from_matrix(config.robot.tcp.to_matrix() @ calibration.tcp2apex)
            robot = config.robot.model_copy(update={"tcp_mm_deg": [float(v) for v in tcp.as_array()]})
            config = config.model_copy(update={"robot": robot})
        return cls(config, scenario.camera_model())

    def reset(self, seed: int | None = None) -> Observation:
        """Move (straight line) to the config's no-contact start pose and observe. The rig
        has no randomness of its own to seed: `seed` is accepted and ignored."""
        self.move_to(self.config.robot.start_pose)
        return self.observe()

    def move_to(self, pose: Pose, speed_mm_s: float | None = None) -> None:
        """Safety check, then a linear move to `pose` (work frame, mm/deg) at `speed_mm_s`
        (default: the config's linear speed); returns when the robot has stopped."""
        self.safety.check_pose(pose)
        speed = self.config.robot.linear_speed_mm_s if speed_mm_s is None else speed_mm_s
        self.safety.check_speed(speed)
        robot = self._robot()
        start = self._at if self._at is not None else robot.get_pose()
        if self.safety.allows(start):
            self.safety.check_path(start, pose)
        elif pose != self.config.robot.start_pose:
            raise SafetyError(
                f"the robot is at {start}, outside the safety limits: from there it may only be sent "
                f"to the start pose (robot.start_pose_mm_deg; reset())"
            )
        else:
            log.warning(
                "the robot is at %s, outside the safety limits: approaching the start pose %s in a straight "
                "line, a path the limits do not cover",
                start,
                pose,
            )
        if speed != self._speed_mm_s:
            robot.set_speed(speed, self.config.robot.angular_speed_deg_s)
            self._speed_mm_s = speed
        try:
            robot.move_linear(pose)
        except RobotCommandRefused:
            raise  # refused before moving: the robot is where it was
        except BaseException:
            self._at = None  # where the robot stopped is unknown: ask it next time
            raise
        self._at = pose

    def observe(self) -> Observation:
        """Measured pose (controller) and a frame captured after this call."""
        pose = self._robot().get_pose()
        if self.sensor is None:
            raise UserError("the hardware environment is closed")
        frame = self.sensor.read_fresh()
        return Observation(time=frame.time, pose=pose, frame=frame.image, pins_px=None, truth={})

    def _robot(self) -> RobotDriver:
        if self.robot is None:
            raise UserError("the hardware environment is closed")
        return self.robot

    def close(self) -> None:
        """Release camera and robot connection. Safe to call twice."""
        sensor, self.sensor = self.sensor, None
        robot, self.robot = self.robot, None
        if sensor is not None:
            sensor.close()
        if robot is not None:
            robot.close()
