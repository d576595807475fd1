"""Configuration of the real rig (one YAML file), validated with pydantic.

Errors name the file, the field and the offending value and are raised as `UserError`
(the CLI prints them without a traceback). See `hardware/example_config.yaml` and
`hardware/README.md` for every field with its unit.
"""
from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from hardware.safety import SafetyLimits
from twin.core.validation import read_yaml, validate_mapping
from twin.core.poses import Pose

PoseList = Annotated[list[float], Field(min_length=6, max_length=6)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class RobotConfig(_Strict):
    """The IRB120's RAPID server and the frames/speeds it is set up with."""

    host: str = "127.0.0.1"
    port: int = Field(default=5000, ge=1, le=65535)
    client: Literal["cri", "native"] = "cri"
    connect_timeout_s: float = Field(default=3.0, gt=0, le=60)
    reply_timeout_s: float = Field(default=5.0, gt=0, le=120)
    #: TCP (dome apex) in the flange frame tool0: x, y, z mm; α, β, γ deg (extrinsic XYZ).
    #: Default = the twin's mount (twin.world.scene.FLANGE_TO_APEX, 101 mm); measure your rig's.
    tcp_mm_deg: PoseList = [0.0, 0.0, 101.0, 0.0, 0.0, 0.0]
    #: work frame in the robot base frame: x, y, z mm; α, β, γ deg (extrinsic XYZ)
    work_frame_mm_deg: PoseList = [400.0, 0.0, 50.0, 180.0, 0.0, 0.0]
    linear_speed_mm_s: float = Field(default=20.0, gt=0, le=250)
    angular_speed_deg_s: float = Field(default=20.0, gt=0, le=180)
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


class CameraConfig(_Strict):
    """The TacTip camera: a V4L2 index, or a video file / URL standing in for it."""

    source: int | str = 0
    width: int = Field(default=640, ge=64, le=4096)
    height: int = Field(default=480, ge=48, le=4096)
    #: manual exposure in V4L2 units of 100 µs (e.g. 156 = 15.6 ms); null = camera's auto
    exposure: float | None = Field(default=None, gt=0, le=10000)
    warmup: int = Field(default=8, ge=0, le=200)

    @field_validator("source")
    @classmethod
    def _source(cls, v: int | str) -> int | str:
        if isinstance(v, int) and v < 0:
            raise ValueError(f"a device index is ≥ 0, got {v}")
        if isinstance(v, str) and not v.strip():
            raise ValueError("empty camera source")
        return v


class HardwareConfig(_Strict):
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
