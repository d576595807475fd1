"""The flex dome as the registry holds it: its scenario `physics` settings (units, bounds,
conversion to DomeParams' SI fields) and its builder (twin.world.dome.base.DomeBuilder)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any

import mujoco
import numpy as np
from pydantic import Field, field_validator

from twin.core.sensor import CameraModel, TacTipGeometry
from twin.core.validation import bounded
from twin.world.dome.base import PhysicsSettings
from twin.world.dome.flex.grid import FIDELITY_LEVELS, DomeParams, TacTipHandles, add_tactip
from twin.world.dome.flex.physics import SensorPhysics
from twin.world.dome.material import apply_dome_material


class FlexSettings(PhysicsSettings):
    """The flex dome's scenario `physics`: overrides of the fidelity level's DomeParams, for sweeps."""

    cellcount: (
        Annotated[
            list[Annotated[int, Field(ge=2, le=12)]],
            Field(min_length=3, max_length=3, description="dome grid cells along x, y, z (cells; each in [2, 12])"),
        ]
        | None
    ) = None
    timestep_s: float | None = bounded(0, 0.05, "s", "physics time step", None, open_lo=True)
    settle_px: float | None = bounded(0, 5, "px", "settle tolerance", None, open_lo=True)
    surface_spacing_mm: float | None = bounded(0.5, 10, "mm", "collision surface spacing", None)
    skin_spacing_mm: float | None = bounded(
        0, 5, "mm", "skin layer node spacing (twin.world.dome.flex.skin), 0 = off, else ≥ 0.5", None
    )
    membrane_young_mpa: float | None = bounded(
        0, 10, "MPa", "skin membrane's Young's modulus (twin.world.dome.flex.grid), 0 = off", None
    )

    @field_validator("skin_spacing_mm")
    @classmethod
    def _skin_spacing(cls, v: float | None) -> float | None:
        if v is not None and v != 0 and not 0.5 <= v <= 5:
            raise ValueError(f"skin_spacing_mm must be 0 (off) or in [0.5, 5] mm, got {v}")
        return v

    def changes(self) -> dict[str, Any]:
        """The settings given, as DomeParams fields (SI)."""
        changes = {
            "cellcount": None if self.cellcount is None else tuple(self.cellcount),
            "timestep": self.timestep_s,
            "settle_px": self.settle_px,
            "surface_spacing": None if self.surface_spacing_mm is None else self.surface_spacing_mm * 1e-3,
            "skin_spacing": None if self.skin_spacing_mm is None else self.skin_spacing_mm * 1e-3,
            "membrane_young": None if self.membrane_young_mpa is None else self.membrane_young_mpa * 1e6,
        }
        return {k: v for k, v in changes.items() if v is not None}


class FlexBuilder:
    """MuJoCo's flex grid (twin.world.dome.flex.grid) stepped by SensorPhysics."""

    name = "flex"
    parameters = DomeParams
    levels: Mapping[str, DomeParams] = FIDELITY_LEVELS
    settings = FlexSettings
    presets: Mapping[str, Mapping[str, Any]] = {}
    quasi_static = False

    def params(self, fidelity: str, settings: FlexSettings, material: Mapping[str, float], source: str) -> DomeParams:
        params = self.levels[fidelity].with_(**settings.changes())
        return apply_dome_material(params, material) if material else params

    def add_to_scene(self, spec: mujoco.MjSpec, params: DomeParams, friction: bool) -> TacTipHandles:
        return add_tactip(spec, spec.worldbody, TacTipGeometry(), params, friction=friction)

    def start(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        handles: TacTipHandles,
        params: DomeParams,
        *,
        friction: float,
        name: str,
        start_tool2world: np.ndarray,
        stimulus2world: np.ndarray,
        work2world: np.ndarray,
        camera: CameraModel,
    ) -> SensorPhysics:
        # friction is in the compiled model's geoms (the object's μ wins the mix)
        return SensorPhysics(
            model,
            data,
            handles,
            params,
            name,
            start_tool2world,
            stimulus2world=stimulus2world,
            work2world=work2world,
            camera=camera,
        )

    def precompute(self, params: DomeParams) -> tuple[float, float]:
        return 0.0, 0.0

    def resolution(self, params: DomeParams) -> dict[str, Any]:
        return {
            "cellcount": "x".join(str(c) for c in params.cellcount),
            "timestep_s": params.timestep,
            "settle_px": params.settle_px,
        }


FLEX = FlexBuilder()
