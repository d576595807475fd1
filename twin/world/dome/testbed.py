"""A minimal dome scene for tests and benchmarks: the TacTip pressed onto a straight box
edge, built without a scenario (tool frame, m; README "Conventions")."""
from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from twin.core.poses import make_transform
from twin.core.sensor import TacTipGeometry
from twin.world.dome.compliant import CompliantParams, CompliantPhysics
from twin.world.dome.flex import DomeParams, add_stimulus_carrier, add_tactip
from twin.world.dome.physics import SensorPhysics


def edge_scene(params: DomeParams | CompliantParams, friction: bool = True, object_friction: float = 1.0,
               scenario: str = "edge", start_tool2world: np.ndarray | None = None):
    """A minimal scene for tests and benchmarks: a 60 × 60 × 20 mm box whose top face is
    z = 0 with a straight edge along y at x = 0 (box at x < 0), and the TacTip pointing
    down (tool z = −world z). Returns (model, data, handles, physics): SensorPhysics for
    the flex dome's DomeParams, CompliantPhysics (handles None) for CompliantParams."""

    spec = mujoco.MjSpec()
    carrier = add_stimulus_carrier(spec)
    carrier.add_geom(name="rectangle", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.03, 0.01],
                     pos=[-0.03, 0.0, -0.01], friction=[object_friction, 0.005, 0.0001])
    start = sensor_down(0.0, 0.0, -2.0) if start_tool2world is None else start_tool2world
    if isinstance(params, CompliantParams):
        model = spec.compile()
        data = mujoco.MjData(model)
        mu = object_friction if friction else 0.0
        return model, data, None, CompliantPhysics(model, data, params, mu, scenario, start)
    handles = add_tactip(spec, spec.worldbody, TacTipGeometry(), params, friction)
    model = spec.compile()
    data = mujoco.MjData(model)
    handles = handles.resolve(model)
    return model, data, handles, SensorPhysics(model, data, handles, params, scenario, start)


def sensor_down(x_mm: float, y_mm: float, depth_mm: float, gamma_deg: float = 0.0) -> np.ndarray:
    """tool2world of a sensor pointing straight down (tool z = −world z), apex at
    (x, y, −depth) mm, rotated by γ about its own axis (deg)."""
    down = np.diag([1.0, -1.0, -1.0])
    rot = down @ Rotation.from_euler("z", gamma_deg, degrees=True).as_matrix()
    return make_transform(rot, np.array([x_mm, y_mm, -depth_mm]) * 1e-3)


