"""The calibration file: what makes the twin a twin of one particular TacTip.

`twin calibrate` (twin.analysis.calibration_fit) writes it; a scenario names it
(`sensor: {calibration: my_sensor.yaml}`, or gives it inline) and both backends use it:

| field                | unit        | sim backend                               | hardware backend            |
|----------------------|-------------|-------------------------------------------|-----------------------------|
| camera               | px, mm, deg | the projection of the pins (CameraModel)  | the camera model recorded   |
|                      |             | and the rendered pins' positions          | with every run              |
| rest_pin_offsets_px  | px (127×2)  | added to every frame's pins               | —  (the real pins are where |
|                      |             |                                           | they are)                   |
| dome_material        | per name    | the dome's material (apply_dome_material) | —                           |
| friction             | –           | skin–stimulus Coulomb coefficient         | —                           |
| tcp_offset_mm        | mm          | the dome apex moved from the commanded    | the robot's TCP corrected   |
|                      |             | TCP (tool frame)                          | by it                       |
| tcp_roll_deg         | deg         | the dome and its camera turned about the  | the robot's TCP corrected   |
|                      |             | TCP's axis (the sensor's mounting roll)   | by it                       |
| tcp_tilt_deg         | deg         | the dome's axis tilted from the TCP's     | the robot's TCP corrected   |
|                      |             | about its x and y (the mount's tilt)      | by it                       |
| arm_yield_mm_per_n   | mm/N        | the TCP yields by it × the contact's      | —  (the real arm yields by  |
|                      |             | normal force (work frame)                 | itself)                     |

Pixels refer to the camera resolution `camera.width × camera.height`; a scenario with
another resolution of the same camera gets them rescaled (CameraModel.rescale_px).
Every numeric field has bounds; errors name the file, the field and the value (exit 2).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import yaml
from pydantic import Field, field_validator

from twin.core.errors import UserError
from twin.core.files import replace_file
from twin.core.poses import Pose
from twin.core.sensor import N_PINS, CameraModel
from twin.core.validation import StrictModel, bounded, bounded_list, read_yaml, validate_mapping

#: Dome material parameters a calibration may set: name -> (unit, lower, upper, meaning).
#: twin.world.dome.material.apply_dome_material maps them onto the dome model.
DOME_MATERIAL: dict[str, tuple[str, float, float, str]] = {
    "young_kpa": ("kPa", 1.0, 2000.0, "effective Young's modulus of the skin + gel solid"),
    "poisson": ("–", 0.0, 0.5, "Poisson's ratio of the skin + gel solid (the flex dome needs ≤ 0.49)"),
    "membrane_young_mpa": ("MPa", 0.0, 10.0, "Young's modulus of the skin membrane (0 = off)"),
    "skin_held_deg": (
        "deg",
        65.0,
        90.0,
        "compliant dome: where the base holds the skin, from the apex (90 = the "
        "equator; at least the contact cap's 65)",
    ),
    "skin_bending_mpa": (
        "MPa",
        0.01,
        50.0,
        "compliant dome with skin_bending: the skin shell's bending modulus (its membrane modulus unless set)",
    ),
    "skin_tension_n_m": (
        "N/m",
        0.0,
        200.0,
        "compliant dome: the skin's pretension over the sealed gel (needs the skin membrane)",
    ),
    "skin_thickening": (
        "–",
        0.25,
        8.0,
        "compliant dome: the skin's thickness where the base holds it over its thickness at the apex "
        "(1 = uniform; needs the skin membrane)",
    ),
    "pin_lever_mm": (
        "mm",
        0.0,
        8.0,
        "compliant dome: the lever the skin's turn swings a pin tip by (2 = the pins' length)",
    ),
    "apex_radius_mm": (
        "mm",
        20.0,
        60.0,
        "compliant dome: the radius of the outer profile the object meets, a sphere through the apex "
        "(20 = the dome's own)",
    ),
    "tip_sway_mm_per_n": (
        "mm/N",
        0.0,
        5.0,
        "compliant dome: how far the tip moves as a whole against the camera per newton of tangential contact force",
    ),
    "adhesion_kpa": (
        "kPa",
        0.0,
        100.0,
        "compliant dome: the skin's adhesive shear strength on the object: with friction a node slips at "
        "μ·pressure + this (0 = Coulomb's law alone)",
    ),
    "edge_friction_ratio": (
        "–",
        1.0,
        5.0,
        "compliant dome: friction across an edge's round (where the object's surface turns from its top) "
        "over friction along it (1 = the same every way)",
    ),
}


class Distortion(StrictModel):
    """OpenCV radial (k1, k2) and tangential (p1, p2) distortion coefficients (–)."""

    k1: float = bounded(-2.0, 2.0, "dimensionless", "radial distortion k1", 0.0)
    k2: float = bounded(-5.0, 5.0, "dimensionless", "radial distortion k2", 0.0)
    p1: float = bounded(-0.2, 0.2, "dimensionless", "tangential distortion p1", 0.0)
    p2: float = bounded(-0.2, 0.2, "dimensionless", "tangential distortion p2", 0.0)


class CameraCalibration(StrictModel):
    """The internal camera: intrinsics (px at width × height), distortion, and where it sits
    in the tool relative to the nominal camera (mm, deg)."""

    width: int = bounded(64, 4096, "px", "the resolution the pixel values refer to", 640)
    height: int = bounded(48, 4096, "px", "image height", 480)
    focal_px: float | None = Field(
        default=None, gt=10.0, le=20000.0, description="focal length (px; (10, 20000]); None = from the field of view"
    )
    principal_point_px: bounded_list(0.0, 4096.0, "px", length=2) | None = None
    distortion: Distortion = Distortion()
    # a real TacTip's camera may sit much nearer the dome than the model's (the DigiTac set's
    # 127-pin TacTip: about 26 mm) and be turned on its axis by any angle (its pin grid: about 30°)
    offset_mm: bounded_list(-30.0, 30.0, "mm", length=3) = [0.0, 0.0, 0.0]
    rotation_deg: bounded_list(-180.0, 180.0, "deg", length=3) = [0.0, 0.0, 0.0]


#: the largest rest-pin offset a calibration holds (px): beyond it the camera or rest layout is wrong, not the pins
REST_OFFSET_LIMIT_PX = 50.0


class Calibration(StrictModel):
    """One sensor's fitted parameters (module docstring). Every field is optional: what is
    not given keeps the twin's nominal value."""

    camera: CameraCalibration = CameraCalibration()
    rest_pin_offsets_px: (
        Annotated[
            list[bounded_list(-REST_OFFSET_LIMIT_PX, REST_OFFSET_LIMIT_PX, "px", length=2)],
            Field(min_length=N_PINS, max_length=N_PINS),
        ]
        | None
    ) = None
    dome_material: dict[str, float] = {}
    friction: float | None = bounded(0.0, 3.0, "dimensionless", "skin–stimulus Coulomb coefficient", None)
    tcp_offset_mm: bounded_list(-20.0, 20.0, "mm", length=3) = [0.0, 0.0, 0.0]
    tcp_roll_deg: float = bounded(-180.0, 180.0, "deg", "the sensor turned about its own axis from the TCP", 0.0)
    # the mount's tilt: the dome's axis turned about the tool's x then y before the roll (Pose's α, β)
    tcp_tilt_deg: bounded_list(-15.0, 15.0, "deg", length=2) = [0.0, 0.0]
    arm_yield_mm_per_n: bounded_list(-2.0, 2.0, "mm/N", length=3) = [0.0, 0.0, 0.0]
    notes: str = ""

    @field_validator("dome_material")
    @classmethod
    def _known_material(cls, material: dict[str, float]) -> dict[str, float]:
        for name, value in material.items():
            if name not in DOME_MATERIAL:
                raise ValueError(f"unknown dome material parameter {name!r}; known: {', '.join(DOME_MATERIAL)}")
            unit, lower, upper, _ = DOME_MATERIAL[name]
            if not lower <= value <= upper:
                raise ValueError(f"{name} = {value} {unit} is outside [{lower}, {upper}] {unit}")
        return material

    def camera_model(self, nominal: CameraModel) -> CameraModel:
        """`nominal` (the scenario's camera: resolution, field of view) with this
        calibration's intrinsics, distortion and pose, rescaled to its resolution."""
        c = self.camera
        scale = nominal.width / c.width
        if abs(nominal.height / c.height - scale) > 1e-9:
            raise UserError(
                f"calibration camera {c.width}×{c.height} and scenario camera {nominal.width}×{nominal.height} "
                "have different aspect ratios: not the same camera"
            )
        focal = None if c.focal_px is None else c.focal_px * scale
        centre = None
        if c.principal_point_px is not None:
            centre = tuple(float(v) for v in (np.asarray(c.principal_point_px) + 0.5) * scale - 0.5)
        d = c.distortion
        return CameraModel(
            nominal.width,
            nominal.height,
            nominal.fov_y_deg,
            nominal.aperture_fraction,
            nominal.geometry,
            focal_override_px=focal,
            principal_point_px=centre,
            distortion=(d.k1, d.k2, d.p1, d.p2),
            offset_mm=tuple(c.offset_mm),
            rotation_deg=tuple(c.rotation_deg),
        )

    def rest_offsets_px(self, width: int) -> np.ndarray:
        """(127, 2) px rest-layout offsets at a camera `width` px wide (zeros when none)."""
        if self.rest_pin_offsets_px is None:
            return np.zeros((N_PINS, 2))
        return np.asarray(self.rest_pin_offsets_px, float) * (width / self.camera.width)

    @property
    def tcp2apex(self) -> np.ndarray:
        """4×4 (m): the dome apex and its camera relative to the commanded TCP (tcp_offset_mm;
        tcp_tilt_deg about the tool's x and y, then tcp_roll_deg about its z: Pose's α, β, γ)."""
        return Pose(*self.tcp_offset_mm, *self.tcp_tilt_deg, self.tcp_roll_deg).to_matrix()

    @property
    def arm_yield_m_per_n(self) -> np.ndarray:
        """(3,) m/N: how far the TCP yields per newton of contact normal force, work frame."""
        return np.asarray(self.arm_yield_mm_per_n, float) * 1e-3


def load_calibration(path: str | Path) -> Calibration:
    """Read and validate a calibration file (YAML or JSON); errors name file, field, value."""
    return validate_mapping(Calibration, read_yaml(path, "calibration"), str(path), "calibration")


def write_calibration(calibration: Calibration, path: Path) -> Path:
    """Write `calibration` as YAML (readable by load_calibration)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    replace_file(path, yaml.safe_dump(calibration.model_dump(), sort_keys=False))
    return path
