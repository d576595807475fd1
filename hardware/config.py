"""Configuration of the real rig (one YAML file), validated with pydantic.

Errors name the file, the field and the offending value and are raised as `UserError`
(the CLI prints them without a traceback). See `hardware/example_config.yaml` and
`hardware/README.md` for every field with its unit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, field_validator

from hardware.safety import SafetyLimits
from twin.core.poses import Pose
from twin.core.validation import PoseList, StrictModel, bounded, read_yaml, validate_mapping


class RobotConfig(StrictModel):
    """The IRB120's RAPID server and the frames/speeds it is set up with."""

    host: str = "127.0.0.1"
    port: int = bounded(1, 65535, "TCP port", "RAPID server port", 5000)
    client: Literal["cri", "native"] = "cri"
    connect_timeout_s: float = bounded(0, 60, "s", "connection timeout", 3.0, open_lo=True)
    reply_timeout_s: float = bounded(0, 120, "s", "reply timeout", 5.0, open_lo=True)
    #: TCP (dome apex) in the flange frame tool0: x, y, z mm; α, β, γ deg (extrinsic XYZ).
    #: Default = the twin's mount (twin.world.scene.FLANGE_TO_APEX, 101 mm); measure your rig's.
    tcp_mm_deg: PoseList = [0.0, 0.0, 101.0, 0.0, 0.0, 0.0]
    #: work frame in the robot base frame: x, y, z mm; α, β, γ deg (extrinsic XYZ)
    work_frame_mm_deg: PoseList = [400.0, 0.0, 50.0, 180.0, 0.0, 0.0]
    linear_speed_mm_s: float = bounded(0, 250, "mm/s", "TCP speed", 20.0, open_lo=True)
    angular_speed_deg_s: float = bounded(0, 180, "deg/s", "reorientation speed", 20.0, open_lo=True)
    #: no-contact start pose for `reset()`, work frame (mm/deg)
    start_pose_mm_deg: PoseList = [0.0, 0.0, -10.0, 0.0, 0.0, 0.0]

    @property
    def tcp(self) -> Pose:
        return Pose.from_array(self.tcp_mm_deg)

    @property
    def work_frame(self) -> Pose:
        return Pose.from_array(self.work_frame_mm_deg)

    @property
    def start_pose(self) -> Pose:
        return Pose.from_array(self.start_pose_mm_deg)


class CameraConfig(StrictModel):
    """The TacTip camera: a V4L2 index, or a video file / URL standing in for it."""

    source: Annotated[int, Field(ge=0, le=63, description="V4L2 device index /dev/videoN (index; [0, 63])")] | str = 0
    width: int = bounded(64, 4096, "px", "image width", 640)
    height: int = bounded(48, 4096, "px", "image height", 480)
    #: manual exposure in V4L2 units of 100 µs (e.g. 156 = 15.6 ms); null = camera's auto
    exposure: float | None = bounded(0, 10000, "100 µs", "manual exposure, null = auto", None, open_lo=True)
    warmup: int = bounded(0, 200, "frames", "frames dropped after opening", 8)

    @field_validator("source")
    @classmethod
    def _source(cls, v: int | str) -> int | str:
        if isinstance(v, str) and not v.strip():
            raise ValueError("empty camera source")
        return v


class HardwareConfig(StrictModel):
    """Everything the hardware environment needs."""

    robot: RobotConfig = RobotConfig()
    camera: CameraConfig = CameraConfig()
    safety: SafetyLimits = SafetyLimits()


def hardware_config_from_dict(data, source: str = "<dict>", base_dir: Path | None = None) -> HardwareConfig:
    """Validate a mapping; relative video paths are resolved against `base_dir`."""
    if data is None:
        data = {}
    config = validate_mapping(HardwareConfig, data, source, "hardware config")
    src = config.camera.source
    if base_dir is not None and isinstance(src, str) and "://" not in src and not Path(src).is_absolute():
        camera = config.camera.model_copy(update={"source": str((base_dir / src).resolve())})
        config = config.model_copy(update={"camera": camera})
    return config


def load_hardware_config(path: str | Path) -> HardwareConfig:
    """Read and validate a hardware config YAML file."""
    return hardware_config_from_dict(read_yaml(path, "hardware config"), str(path), Path(path).parent)
