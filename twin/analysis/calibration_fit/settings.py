"""What `twin calibrate` fits and how: the parameters' names, the settings' types and ranges
(assets/tactip/calibration_settings.yaml holds their values), and reading a --settings file
over the shipped one."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from twin.core.errors import UserError
from twin.core.resources import asset_path
from twin.core.validation import read_yaml, validate_mapping

CAMERA = (
    "camera.focal_px",
    "camera.cx_px",
    "camera.cy_px",
    "camera.k1",
    "camera.k2",
    "camera.p1",
    "camera.p2",
    "camera.x_mm",
    "camera.y_mm",
    "camera.z_mm",
    "camera.rx_deg",
    "camera.ry_deg",
    "camera.rz_deg",
)
PHYSICS = (
    "material.young_kpa",
    "material.poisson",
    "material.membrane_young_mpa",
    "material.skin_held_deg",
    "material.skin_bending_mpa",
    "material.skin_tension_n_m",
    "material.skin_thickening",
    "material.pin_lever_mm",
    "material.apex_radius_mm",
    "material.tip_sway_mm_per_n",
    "material.adhesion_kpa",
    "material.edge_friction_ratio",
    "friction",
    "tcp.x_mm",
    "tcp.y_mm",
    "tcp.z_mm",
    "tcp.roll_deg",
    "tcp.tilt_x_deg",
    "tcp.tilt_y_deg",
    "arm.x_mm_per_n",
    "arm.y_mm_per_n",
    "arm.z_mm_per_n",
)
PARAMETERS = CAMERA + PHYSICS
SETTINGS_FILE = ("tactip", "calibration_settings.yaml")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ParameterSetting(_Strict):
    """One parameter: fitted or not, default (None = the scenario's value), bounds, prior (its unit)."""

    fit: bool = False
    default: float | None = None
    lower: float
    upper: float
    prior_std: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _ordered(self) -> ParameterSetting:
        if not self.lower < self.upper:
            raise ValueError(f"lower {self.lower} must be below upper {self.upper}")
        return self


# The settings' values live in the shipped file alone (assets/tactip/calibration_settings.yaml,
# which a --settings file is merged over): these models state their types and ranges, not defaults.
class Weights(_Strict):
    rest: float = Field(ge=0)
    contact: float = Field(ge=0)
    sliding: float = Field(ge=0)
    edge_figures: float = Field(
        ge=0,
        description="sheared-tap runs: the weight of the edge figures' misses (twin.analysis.calibration_fit."
        "figures); 0 = not computed",
    )


class OptimiserSettings(_Strict):
    popsize: int | None = Field(ge=4, le=1000)
    sigma0: float = Field(gt=0, le=1, description="fraction of each parameter's range")
    max_generations: int = Field(ge=1, le=10000)
    tol_relative: float = Field(gt=0, lt=1)
    patience: int = Field(ge=1, le=1000)
    tol_bracket: float = Field(
        gt=0, lt=1, description="one physics parameter: the bracket's stop width, fraction of its range"
    )
    seed: int = Field(ge=1)


class CalibrationSettings(_Strict):
    """What `twin calibrate` fits and how (assets/tactip/calibration_settings.yaml)."""

    parameters: dict[str, ParameterSetting]
    rest_pins: bool
    camera_from_rest: list[str] = Field(
        description="camera parameters whose start is first fitted to the no-contact frames' pins (no rest offsets)"
    )
    camera_tied_to_rest: bool = Field(
        description="the camera_from_rest parameters that are not fitted are fitted to the no-contact frames "
        "again wherever the fit moves the fitted camera parameters (tied): a distance the no-contact frames "
        "leave free is then fitted on the taps among the cameras that meet those frames"
    )
    weights: Weights
    edge_figure_resamples: int = Field(
        ge=0, le=1000, description="bootstrap resamples for the recorded edge figures' spread (0 = none)"
    )
    edge_signal: Literal["sheared", "still"] = Field(
        description="where the twin's edge signal figure comes from: its replay of the recorded sheared "
        "taps, or onto the object (l < 0) the same taps replayed without their slides and twists "
        "(twin.analysis.calibration_fit.figures)"
    )
    edge_signal_shift: Literal["kept", "apart"] = Field(
        description="the edge signal figure as the whole signal ('kept'), or without its rigid "
        "shift of the pins with that shift's share as a figure of its own ('apart') "
        "(twin.analysis.calibration_fit.figures)"
    )
    edge_theta_plane: Literal["own", "recorded"] = Field(
        description="the plane the twin's turn of θ_PC23 per mm of along-edge slide is read in: its "
        "own taps' PC2–PC3 ('own'), or the recorded run's ('recorded': a twin whose first PCs are "
        "nearly equal has a plane that jumps between candidates) (twin.analysis.calibration_fit.figures)"
    )
    edge_figure_bins: Literal["each", "pooled"] = Field(
        description="a miss per edge figure and lateral bin ('each'), or per figure and side of the edge, "
        "its bins weighted by the inverse square of their recorded spread ('pooled', as `twin compare` "
        "pools them; needs edge_figure_resamples of 2 or more) (twin.analysis.calibration_fit.figures)"
    )
    noise_px: float = Field(gt=0, le=50)
    identifiable_fraction: float = Field(gt=0, le=10)
    max_variance_inflation: float = Field(ge=1)
    optimiser: OptimiserSettings

    @model_validator(mode="after")
    def _known(self) -> CalibrationSettings:
        unknown = sorted(set(self.parameters) - set(PARAMETERS))
        if unknown:
            raise ValueError(f"unknown parameters {unknown}; known: {', '.join(PARAMETERS)}")
        return self

    @model_validator(mode="after")
    def _pooled_weighable(self) -> CalibrationSettings:
        if self.edge_figure_bins == "pooled" and self.edge_figure_resamples < 2:
            raise ValueError(
                "edge_figure_bins: pooled weighs each lateral bin by its recorded figure's bootstrap spread; "
                f"edge_figure_resamples must be 2 or more (it is {self.edge_figure_resamples})"
            )
        return self

    @field_validator("camera_from_rest")
    @classmethod
    def _camera_only(cls, names: list[str], info: ValidationInfo) -> list[str]:
        wrong = [n for n in names if n not in CAMERA or n not in info.data.get("parameters", {})]
        if wrong:
            raise ValueError(f"{wrong} are not camera parameters with bounds (camera parameters: {', '.join(CAMERA)})")
        return names

    @model_validator(mode="after")
    def _something_tied(self) -> CalibrationSettings:
        if self.camera_tied_to_rest and not self.tied:
            raise ValueError(
                "camera_tied_to_rest ties the camera_from_rest parameters that are not fitted, and there are "
                f"none (camera_from_rest: {self.camera_from_rest or 'empty'})"
            )
        return self

    @property
    def tied(self) -> list[str]:
        """The camera parameters tied to the no-contact frames (camera_tied_to_rest): those of
        camera_from_rest not fitted."""
        if not self.camera_tied_to_rest:
            return []
        return [n for n in self.camera_from_rest if not self.parameters[n].fit]

    @property
    def fitted(self) -> list[str]:
        return [n for n in PARAMETERS if n in self.parameters and self.parameters[n].fit]


def load_settings(path: Path | None) -> CalibrationSettings:
    """The shipped defaults, with `path`'s entries merged over them (per parameter)."""
    data = read_yaml(asset_path(*SETTINGS_FILE), "calibration settings")
    source = str(asset_path(*SETTINGS_FILE))
    if path is not None:
        user = read_yaml(path, "calibration settings") or {}
        if not isinstance(user, dict):
            raise UserError(f"{path}: calibration settings are a mapping of fields")
        for key, value in user.items():
            if key in ("parameters", "weights", "optimiser") and isinstance(value, dict):
                for name, entry in value.items():
                    old = data.get(key, {}).get(name)
                    data.setdefault(key, {})[name] = (
                        {**old, **entry} if isinstance(old, dict) and isinstance(entry, dict) else entry
                    )
            else:
                data[key] = value
        source = str(path)
    return validate_mapping(CalibrationSettings, data, source, "calibration settings")
