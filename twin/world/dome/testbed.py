"""A minimal dome scene for tests and benchmarks: the TacTip pressed onto a straight box
edge, built without a scenario (tool frame, m; docs/conventions.md)."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from twin.core.poses import make_transform
from twin.core.sensor import CameraModel
from twin.world.dome.base import DomeModel, DomeParameters
from twin.world.dome.carrier import add_stimulus_carrier
from twin.world.dome.registry import builder_of


def edge_scene(
    params: DomeParameters,
    friction: bool = True,
    object_friction: float = 1.0,
    scenario: str = "edge",
    start_tool2world: np.ndarray | None = None,
) -> tuple[mujoco.MjModel, mujoco.MjData, object, DomeModel]:
    """A minimal scene for tests and benchmarks: a 60 × 60 × 20 mm box whose top face is
    z = 0 with a straight edge along y at x = 0 (box at x < 0), and the TacTip pointing
    down (tool z = −world z). Returns (model, data, handles, physics): the dome model of
    `params` (twin.world.dome.registry.builder_of) running in it, and the handles of what
    it added to the scene (None where it adds nothing)."""

    builder = builder_of(params)
    spec = mujoco.MjSpec()
    carrier = add_stimulus_carrier(spec)
    carrier.add_geom(
        name="rectangle",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.03, 0.03, 0.01],
        pos=[-0.03, 0.0, -0.01],
        friction=[object_friction, 0.005, 0.0001],
    )
    start = sensor_down(0.0, 0.0, -2.0) if start_tool2world is None else start_tool2world
    added = builder.add_to_scene(spec, params, friction)
    model = spec.compile()
    data = mujoco.MjData(model)
    handles = None if added is None else added.resolve(model)
    physics = builder.start(
        model,
        data,
        handles,
        params,
        friction=object_friction if friction else 0.0,
        name=scenario,
        start_tool2world=start,
        stimulus2world=np.eye(4),
        work2world=np.eye(4),
        camera=CameraModel(),
    )
    return model, data, handles, physics


def sensor_down(x_mm: float, y_mm: float, depth_mm: float, gamma_deg: float = 0.0) -> np.ndarray:
    """tool2world of a sensor pointing straight down (tool z = −world z), apex at
    (x, y, −depth) mm, rotated by γ about its own axis (deg)."""
    down = np.diag([1.0, -1.0, -1.0])
    rot = down @ Rotation.from_euler("z", gamma_deg, degrees=True).as_matrix()
    return make_transform(rot, np.array([x_mm, y_mm, -depth_mm]) * 1e-3)
