"""Software safety limits of the real rig, checked before any command leaves the PC.

All limits are in the **work frame** (docs/conventions.md): +z points *into* the object,
so the indentation depth of a pose is its z (mm) and `max_depth_mm` caps z. Bounds are
inclusive: a value equal to a limit passes, anything beyond it (even by one ulp) or not
finite (NaN, ±inf) is refused with a `SafetyError` naming the field, value and limit.

| field                     | unit  | meaning                                                |
|---------------------------|-------|--------------------------------------------------------|
| x_mm, y_mm, z_mm          | mm    | [min, max] workspace box of the TCP in the work frame  |
| max_depth_mm              | mm    | deepest allowed indentation = max z in the work frame  |
| alpha_deg, beta_deg       | deg   | [min, max] of the tilt angles α, β (extrinsic XYZ)     |
| max_linear_speed_mm_s     | mm/s  | highest TCP speed that may be commanded                |
| max_angular_speed_deg_s   | deg/s | highest reorientation speed that may be commanded      |

γ (the sensor's rotation about its own axis, the paper's θ) is free but must be finite.
A straight move between two poses inside the box stays inside it (the box and the depth
limit are convex), but the controller interpolates the orientation (slerp, the short
way), and α, β along that arc are not the linear blend of their end values: a move
between two legal tilts with a large turn of γ can leave the α/β box on the way.
`check_path` checks the whole arc (sampled every 0.25°, extremes near a limit refined to
1e-9 deg) and refuses such a move; split it (turn γ first, then tilt).

These limits are a second line of defence: keep the controller's own world zones (the
RAPID server defines a workspace box) configured as well.
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from pydantic import Field, ValidationInfo, field_validator, model_validator
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation

from hardware.protocol import check_pose_numbers, format_pose, wire_number
from twin.core.errors import SafetyError
from twin.core.poses import EULER_AXES, Pose
from twin.core.validation import StrictModel, bounded

Range = Annotated[
    tuple[Annotated[float, Field(ge=-1000, le=1000)], Annotated[float, Field(ge=-1000, le=1000)]],
    Field(description="[min, max], inclusive (mm or deg; each in [-1000, 1000])"),
]


class SafetyLimits(StrictModel):
    """Limits every command is checked against (see the module table for units)."""

    x_mm: Range = (-80.0, 80.0)
    y_mm: Range = (-80.0, 80.0)
    z_mm: Range = (-60.0, 6.0)
    max_depth_mm: float = bounded(0, 20, "mm", "deepest indentation = max z", 6.0)
    alpha_deg: Range = (-20.0, 20.0)
    beta_deg: Range = (-20.0, 20.0)
    max_linear_speed_mm_s: float = bounded(0, 250, "mm/s", "highest TCP speed", 50.0, open_lo=True)
    max_angular_speed_deg_s: float = bounded(0, 180, "deg/s", "highest reorientation speed", 30.0, open_lo=True)

    @field_validator("x_mm", "y_mm", "z_mm", "alpha_deg", "beta_deg")
    @classmethod
    def _ordered(cls, value: tuple[float, float], info: ValidationInfo) -> tuple[float, float]:
        lo, hi = value
        if not lo <= hi:
            raise ValueError(f"min {lo} is above max {hi}")
        if info.field_name in ("alpha_deg", "beta_deg") and (lo < -90.0 or hi > 90.0):
            raise ValueError(f"tilt range [{lo}, {hi}] must lie within [-90, 90] deg")
        return value

    @model_validator(mode="after")
    def _depth(self) -> SafetyLimits:
        if self.z_mm[0] > self.max_depth_mm:
            raise ValueError(f"z_mm min {self.z_mm[0]} is deeper than max_depth_mm {self.max_depth_mm}")
        return self

    # ------------------------------------------------------------------ checks
    @property
    def z_max_mm(self) -> float:
        """Effective max z (mm): the tighter of the box's top and the depth limit."""
        return min(self.z_mm[1], self.max_depth_mm)

    def check_pose(self, pose: Pose) -> None:
        """Raise SafetyError unless every coordinate of `pose` (work frame, mm/deg) is a
        number the robot's float32 carries (`hardware.protocol.wire_number`: not bool or
        str, finite, within ±3.4e38) and inside the limits."""
        check_pose_numbers(pose)
        self._check_range(pose, "x", pose.x, self.x_mm, "mm", "safety.x_mm")
        self._check_range(pose, "y", pose.y, self.y_mm, "mm", "safety.y_mm")
        if pose.z > self.max_depth_mm:
            raise SafetyError(
                f"pose {format_pose(pose)}: z = {float(pose.z)!r} mm is deeper than the max indentation depth "
                f"{self.max_depth_mm} mm (safety.max_depth_mm; +z points into the object)"
            )
        self._check_range(pose, "z", pose.z, (self.z_mm[0], self.z_mm[1]), "mm", "safety.z_mm")
        self._check_range(pose, "alpha", pose.alpha, self.alpha_deg, "deg", "safety.alpha_deg")
        self._check_range(pose, "beta", pose.beta, self.beta_deg, "deg", "safety.beta_deg")

    def check_speed(self, linear_mm_s: float | None = None, angular_deg_s: float | None = None) -> None:
        """Raise SafetyError unless the given speeds are numbers the robot's float32 carries
        (`hardware.protocol.wire_number`: a speed too small to send is refused), > 0 and
        within the limits."""
        for name, value, limit, unit, field in (
            ("linear speed", linear_mm_s, self.max_linear_speed_mm_s, "mm/s", "safety.max_linear_speed_mm_s"),
            ("angular speed", angular_deg_s, self.max_angular_speed_deg_s, "deg/s", "safety.max_angular_speed_deg_s"),
        ):
            if value is None:
                continue
            wire_number(name, value, unit, refuse_underflow=True)
            if not value > 0.0:
                raise SafetyError(f"{name} = {float(value)!r} {unit} must be > 0")
            if value > limit:
                raise SafetyError(f"{name} = {float(value)!r} {unit} exceeds the limit {limit} {unit} ({field})")

    def check_path(self, start: Pose, end: Pose) -> None:
        """Raise SafetyError unless the straight move start → end stays inside the limits
        all along: both ends (`check_pose`) and every orientation on the slerp between
        them (α, β within their ranges; `PATH_STEP_DEG`, `PATH_TOL_DEG`)."""
        self.check_pose(start)
        self.check_pose(end)
        r0 = Rotation.from_euler(EULER_AXES, [start.alpha, start.beta, start.gamma], degrees=True)
        turn = (Rotation.from_euler(EULER_AXES, [end.alpha, end.beta, end.gamma], degrees=True) * r0.inv()).as_rotvec()
        n = max(2, math.ceil(math.degrees(float(np.linalg.norm(turn))) / PATH_STEP_DEG) + 1)
        s = np.linspace(0.0, 1.0, n)

        def tilt(si) -> np.ndarray:  # (len, 2) α, β (deg) at path fractions si
            return (Rotation.from_rotvec(np.outer(np.atleast_1d(si), turn)) * r0).as_euler(EULER_AXES, degrees=True)[
                :, :2
            ]

        ab = tilt(s)
        for k, (name, (lo, hi)) in enumerate((("alpha", self.alpha_deg), ("beta", self.beta_deg))):
            for sign, bound in ((1.0, hi), (-1.0, lo)):
                i = int(np.argmax(sign * ab[:, k]))
                worst = float(ab[i, k])
                if sign * (worst - bound) > -PATH_REFINE_DEG:  # near the limit: refine between the neighbours
                    found = minimize_scalar(
                        lambda x, sign=sign, k=k: -sign * tilt(x)[0, k],
                        bounds=(s[max(i - 1, 0)], s[min(i + 1, n - 1)]),
                        method="bounded",
                        options={"xatol": 1e-12},
                    )
                    worst = float(tilt(found.x)[0, k]) if sign * tilt(found.x)[0, k] > sign * worst else worst
                if sign * (worst - bound) > PATH_TOL_DEG:
                    field = f"safety.{name}_deg"
                    raise SafetyError(
                        f"move {format_pose(start)} → {format_pose(end)}: {name} reaches {worst:.6g} deg on the way "
                        f"(the controller slerps the orientation), beyond the limit {bound} deg ({field}); "
                        "split the move: turn γ first, then tilt"
                    )

    def allows(self, pose: Pose) -> bool:
        """True if `check_pose` would pass."""
        try:
            self.check_pose(pose)
        except SafetyError:
            return False
        return True

    @staticmethod
    def _check_range(pose: Pose, name: str, value: float, bounds: tuple[float, float], unit: str, field: str) -> None:
        lo, hi = bounds
        if value < lo:
            raise SafetyError(
                f"pose {format_pose(pose)}: {name} = {float(value)!r} {unit} is below the limit {lo} {unit} ({field})"
            )
        if value > hi:
            raise SafetyError(
                f"pose {format_pose(pose)}: {name} = {float(value)!r} {unit} is above the limit {hi} {unit} ({field})"
            )


#: path sampling of `check_path`: every PATH_STEP_DEG of rotation; a sampled α/β within
#: PATH_REFINE_DEG of a limit is refined to its true extreme; PATH_TOL_DEG absorbs
#: rounding only (a move whose ends sit on a limit and turns γ keeps α, β to ~1e-13 deg)
PATH_STEP_DEG = 0.25
PATH_REFINE_DEG = 0.01
PATH_TOL_DEG = 1e-9
