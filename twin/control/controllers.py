"""Contour-following controllers. The paper's policy (§III-D) and the plug-in point for
a user's own controller.

Angles in the work frame (deg, atan2 of work x, y); positions in mm. The edge's
outward normal as perceived: ψ̂ = γ − θ̂, because the tap set labels θ as the sensor's
orientation γ over an edge whose outward normal is at 0° in the work frame.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from twin.core.errors import UserError
from twin.core.poses import Pose, wrap_deg
from twin.core.validation import no_link_out

#: Travel direction: counter-clockwise seen from above (object on the left). The work
#: frame is the object frame turned 180° about x, so in work coordinates the tangent is
#: the outward normal turned −90°.
TRAVEL_TURN_DEG = -90.0


@dataclass(frozen=True)
class Percept:
    """What the controller sees at one step."""

    theta_deg: float  # θ̂, perceived sensor orientation relative to the edge (deg)
    lateral_mm: float  # l̂, perceived lateral position (mm, + off the object)
    ok: bool  # False: no contact or too many pins missing
    pose: Pose  # measured sensor pose (work frame)


class Controller(Protocol):
    """Anything with these two methods can drive contour following."""

    def reset(self, start: Pose) -> None:
        """Called once with the first contact pose."""

    def next_pose(self, percept: Percept) -> Pose:
        """The next target pose (work frame) given the current percept."""


def normal_from_theta(gamma_deg: float, theta_deg: float) -> float:
    """Perceived outward edge normal ψ̂ (deg, work frame) from the sensor's γ and θ̂."""
    return float(wrap_deg(gamma_deg - theta_deg))


@dataclass
class PaperController:
    """Δu = R(θ̂)·(e, K(l_d − l̂)): a step e along the perceived edge plus a proportional
    correction towards the desired lateral position l_d; orientation and depth fixed.

    When the percept is not ok (no contact), the last normal is kept and l̂ is taken as
    `lost_lateral_mm` (off the object), so the correction steers back onto the edge.
    """

    step_mm: float = 3.0
    gain: float = 0.35
    lateral_target_mm: float = 0.0
    lost_lateral_mm: float = 9.9

    def reset(self, start: Pose) -> None:
        self._normal_deg: float | None = None

    def next_pose(self, percept: Percept) -> Pose:
        pose = percept.pose
        if percept.ok:
            self._normal_deg = normal_from_theta(pose.gamma, percept.theta_deg)
            lateral = percept.lateral_mm
        else:
            lateral = self.lost_lateral_mm
        if self._normal_deg is None:
            raise UserError("contour following: no contact at the start point; check the start pose and depth")
        a = np.radians(self._normal_deg)
        n = np.array([np.cos(a), np.sin(a)])
        t_angle = a + np.radians(TRAVEL_TURN_DEG)
        t = np.array([np.cos(t_angle), np.sin(t_angle)])
        delta = self.step_mm * t + self.gain * (self.lateral_target_mm - lateral) * n
        return Pose(pose.x + delta[0], pose.y + delta[1], pose.z, pose.alpha, pose.beta, pose.gamma)

    @property
    def perceived_normal_deg(self) -> float | None:
        return self._normal_deg


def load_controller(spec: str | Controller, protocol, base_dir: Path | None = None) -> Controller:
    """A controller object (anything with `reset` and `next_pose`) as it is, or one named
    by `paper` or `path/to/file.py:ClassName` (constructed with the contour protocol's
    step_mm, gain and lateral_target_mm as keyword arguments if it accepts them)."""
    if not isinstance(spec, str):
        if not (callable(getattr(spec, "reset", None)) and callable(getattr(spec, "next_pose", None))):
            raise UserError(f"controller {spec!r}: a controller needs reset(start) and next_pose(percept) methods")
        return spec
    kwargs = {"step_mm": protocol.step_mm, "gain": protocol.gain, "lateral_target_mm": protocol.lateral_target_mm}
    if spec == "paper":
        return PaperController(**kwargs)
    if ":" not in spec:
        raise UserError(f"controller {spec!r}: use 'paper' or 'path/to/file.py:ClassName'")
    file, _, cls_name = spec.rpartition(":")
    path = Path(file)
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    path = no_link_out(path, f"controller {spec!r}")
    if not path.is_file():
        raise UserError(f"controller {spec!r}: file {path} not found")
    module_spec = importlib.util.spec_from_file_location(f"user_controller_{path.stem}", path)
    if module_spec is None or path.suffix != ".py":
        raise UserError(f"controller {spec!r}: {path} is not a Python file (.py)")
    module = importlib.util.module_from_spec(module_spec)
    try:
        module_spec.loader.exec_module(module)
    except (Exception, SystemExit) as err:  # noqa: BLE001  (the user's module: its faults are named)
        raise UserError(f"controller {spec!r}: {path} failed to import: {type(err).__name__}: {err}") from None
    cls = getattr(module, cls_name, None)
    if cls is None:
        raise UserError(f"controller {spec!r}: {path} has no {cls_name!r}")
    try:
        try:
            controller = cls(**kwargs)
        except TypeError:
            controller = cls()
    except (Exception, SystemExit) as err:  # noqa: BLE001  (the user's class: its faults are named)
        raise UserError(f"controller {spec!r}: {cls_name}() raised {type(err).__name__}") from None
    for method in ("reset", "next_pose"):
        if not callable(getattr(controller, method, None)):
            raise UserError(f"controller {spec!r}: {cls_name} has no method {method}()")
    return controller
