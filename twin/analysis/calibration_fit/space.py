"""The fitted parameters of a calibration: their defaults (the scenario's values), bounds and
priors, the unit cube the search runs in, and the calibration file and physics scenario a
point of it maps to."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pydantic import ValidationError

from twin.analysis.calibration_fit.settings import CAMERA, PARAMETERS, PHYSICS, CalibrationSettings
from twin.core.calibration import Calibration, CameraCalibration
from twin.core.errors import UserError
from twin.core.scenario import Scenario
from twin.runs.spec import dome_params, load_scenario_stimulus
from twin.world.dome.material import dome_material_of

RENDER_EFFECTS = {"render", "camera_noise", "lighting"}
#: the mount's tilt about the tool's x and y (Calibration.tcp_tilt_deg)
TCP_TILT = ("tcp.tilt_x_deg", "tcp.tilt_y_deg")
#: the arm's yield per newton of contact normal force, work frame (Calibration.arm_yield_mm_per_n)
ARM_YIELD = ("arm.x_mm_per_n", "arm.y_mm_per_n", "arm.z_mm_per_n")


def scenario_values(scenario: Scenario) -> dict[str, float]:
    """Every parameter's current value in `scenario` (its camera, dome, stimulus, calibration)."""
    cam = scenario.camera_model()
    k = cam.intrinsics
    calibration = scenario.calibration() or Calibration()
    values = {"camera.focal_px": cam.focal_px, "camera.cx_px": k[0, 2], "camera.cy_px": k[1, 2]}
    values.update(zip(("camera.k1", "camera.k2", "camera.p1", "camera.p2"), cam.distortion))
    values.update(zip(("camera.x_mm", "camera.y_mm", "camera.z_mm"), cam.offset_mm))
    values.update(zip(("camera.rx_deg", "camera.ry_deg", "camera.rz_deg"), cam.rotation_deg))
    values.update({f"material.{n}": v for n, v in dome_material_of(dome_params(scenario)).items()})
    values["friction"] = load_scenario_stimulus(scenario).friction
    values.update(zip(("tcp.x_mm", "tcp.y_mm", "tcp.z_mm"), calibration.tcp_offset_mm))
    values["tcp.roll_deg"] = calibration.tcp_roll_deg
    values.update(zip(TCP_TILT, calibration.tcp_tilt_deg))
    values.update(zip(ARM_YIELD, calibration.arm_yield_mm_per_n))
    return {n: float(v) for n, v in values.items()}


@dataclass
class Space:
    """The fitted parameters, their defaults, bounds and priors; maps values to calibrations."""

    scenario: Scenario
    settings: CalibrationSettings
    defaults: dict[str, float] = field(init=False)

    def __post_init__(self) -> None:
        values = scenario_values(self.scenario)
        self.defaults = {}
        for name in PARAMETERS:
            s = self.settings.parameters.get(name)
            if name not in values:  # a material parameter this dome model does not have
                if s is not None and s.fit:
                    raise UserError(
                        f"calibration settings: field 'parameters.{name}': the {self.scenario.dome} dome "
                        "has no such parameter; set fit: false"
                    )
                self.defaults[name] = math.nan
                continue
            value = values[name] if s is None or s.default is None else s.default
            if s is not None and s.fit and not s.lower <= value <= s.upper:
                raise UserError(
                    f"calibration settings: field 'parameters.{name}': default {value:.6g} lies outside "
                    f"the bounds [{s.lower:g}, {s.upper:g}]"
                )
            self.defaults[name] = float(value)
        #: the physics parameters this scenario's dome model has (the others' defaults are NaN)
        self.modelled = [n for n in PHYSICS if not math.isnan(self.defaults[n])]
        self.fitted = self.settings.fitted
        self.camera = [n for n in self.fitted if n in CAMERA]
        self.physics = [n for n in self.fitted if n in PHYSICS]
        p = self.settings.parameters
        #: every bounded parameter's, fitted or not (camera_from_rest may start one the search keeps fixed)
        self.lower = {n: s.lower for n, s in p.items()}
        self.range = {n: s.upper - s.lower for n, s in p.items()}
        self._bounds_fit_a_calibration()

    def _bounds_fit_a_calibration(self) -> None:
        """UserError naming the parameter where a bound of one the fit moves (fitted, or started
        from the no-contact frames) lies outside what a calibration file holds: found here, not as
        an internal error when the search first reaches it."""
        for name in dict.fromkeys([*self.fitted, *self.settings.camera_from_rest]):
            s = self.settings.parameters[name]
            for bound in (s.lower, s.upper):
                try:
                    self.calibration({name: bound})
                except ValidationError as err:
                    why = err.errors()[0]["msg"]
                    raise UserError(
                        f"calibration settings: field 'parameters.{name}': the bound {bound:g} lies outside what "
                        f"a calibration file holds ({why})"
                    ) from None

    def at_bound(self, name: str, value: float) -> bool:
        """Whether `value` lies within a millionth of the range from one of the parameter's bounds."""
        unit = (value - self.lower[name]) / self.range[name]
        return bool(min(unit, 1.0 - unit) < 1e-6)

    def to_unit(self, names: list[str], values: dict[str, float]) -> np.ndarray:
        return np.array([(values[n] - self.lower[n]) / self.range[n] for n in names])

    def from_unit(self, names: list[str], unit: np.ndarray) -> dict[str, float]:
        return {n: float(self.lower[n] + u * self.range[n]) for n, u in zip(names, unit)}

    def prior_residuals(self, values: dict[str, float]) -> np.ndarray:
        p = self.settings.parameters
        return np.array([(values[n] - self.defaults[n]) / p[n].prior_std for n in self.fitted if p[n].prior_std])

    def calibration(self, values: dict[str, float], rest_offsets: np.ndarray | None = None) -> Calibration:
        """The calibration file for `values` (fitted ones; the rest at their defaults)."""
        v = {**self.defaults, **values}
        cam = self.scenario.sensor.camera
        base = self.scenario.calibration() or Calibration()
        camera = CameraCalibration(
            width=cam.width,
            height=cam.height,
            focal_px=v["camera.focal_px"],
            principal_point_px=[v["camera.cx_px"], v["camera.cy_px"]],
            distortion={k: v[f"camera.{k}"] for k in ("k1", "k2", "p1", "p2")},
            offset_mm=[v["camera.x_mm"], v["camera.y_mm"], v["camera.z_mm"]],
            rotation_deg=[v["camera.rx_deg"], v["camera.ry_deg"], v["camera.rz_deg"]],
        )
        material = {n.split(".", 1)[1]: v[n] for n in self.modelled if n.startswith("material.")}
        offsets = base.rest_pin_offsets_px if rest_offsets is None else np.round(rest_offsets, 4).tolist()
        return Calibration(
            camera=camera,
            rest_pin_offsets_px=offsets,
            dome_material=material,
            friction=v["friction"],
            tcp_offset_mm=[v["tcp.x_mm"], v["tcp.y_mm"], v["tcp.z_mm"]],
            tcp_roll_deg=v["tcp.roll_deg"],
            tcp_tilt_deg=[v[n] for n in TCP_TILT],
            arm_yield_mm_per_n=[v[n] for n in ARM_YIELD],
            notes=base.notes,
        )

    def physics_scenario(self, values: dict[str, float]) -> Scenario:
        """The calibration scenario simulating `values`' physics, pins projected (no rendering)."""
        cal = self.calibration(values)
        cam = self.scenario.sensor.camera  # the nominal camera at the scenario's resolution (a 256×256 lab camera too)
        physics_only = Calibration(
            camera=CameraCalibration(width=cam.width, height=cam.height),
            dome_material=cal.dome_material,
            friction=cal.friction,
            tcp_offset_mm=cal.tcp_offset_mm,
            tcp_roll_deg=cal.tcp_roll_deg,
            tcp_tilt_deg=cal.tcp_tilt_deg,
            arm_yield_mm_per_n=cal.arm_yield_mm_per_n,
        )
        effects = [e for e in self.scenario.effects if e not in RENDER_EFFECTS]
        sensor = {"camera": self.scenario.sensor.camera.model_dump(), "calibration": physics_only}
        return self.scenario.with_changes(effects=effects, sensor=sensor, backend="sim")
