"""Which rays can meet the scene's geoms (twin.world.dome.rays), against mj_multiRay itself. No mocks."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from twin.world.dome.rays import rays_into_boxes


def _posed_geoms(with_plane: bool) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """A box, a sphere, a capsule, a cylinder and an ellipsoid at seeded poses 10–30 mm
    around the origin, a mesh (a random point cloud's hull) and optionally a plane, in one
    static world."""
    rng = np.random.default_rng(3)
    spec = mujoco.MjSpec()
    kinds = [
        mujoco.mjtGeom.mjGEOM_BOX,
        mujoco.mjtGeom.mjGEOM_SPHERE,
        mujoco.mjtGeom.mjGEOM_CAPSULE,
        mujoco.mjtGeom.mjGEOM_CYLINDER,
        mujoco.mjtGeom.mjGEOM_ELLIPSOID,
    ]
    for kind in kinds:
        direction = rng.normal(size=3)
        quat = rng.normal(size=4)
        spec.worldbody.add_geom(
            type=kind,
            size=rng.uniform(0.002, 0.008, 3),
            quat=quat / np.linalg.norm(quat),
            pos=direction / np.linalg.norm(direction) * rng.uniform(0.01, 0.03),
        )
    spec.add_mesh(name="rock", uservert=rng.normal(0.0, 0.004, (20, 3)).ravel())
    spec.worldbody.add_geom(
        type=mujoco.mjtGeom.mjGEOM_MESH, meshname="rock", pos=[0.0, 0.012, 0.012], quat=[0.8, 0.6, 0, 0]
    )
    if with_plane:
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1], pos=[0, 0, -0.015])
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


@pytest.mark.parametrize("with_plane", [False, True])
@pytest.mark.parametrize("per_ray", [False, True])
def test_the_rays_left_out_cannot_hit(with_plane, per_ray):
    """The domes cast only the rays that reach a geom's bounding box within their length:
    every ray that mj_multiRay finds a hit on within that length is among them (2,000
    directions; one length for all, or each ray its own, 10–30 mm)."""
    model, data = _posed_geoms(with_plane)
    rng = np.random.default_rng(4)
    dirs = rng.normal(size=(2000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    length = rng.uniform(0.01, 0.03, len(dirs)) if per_ray else 0.02
    geomid, dist = np.empty(len(dirs), np.int32), np.empty(len(dirs))
    mujoco.mj_multiRay(model, data, np.zeros(3), dirs.ravel(), None, 1, -1, geomid, dist, None, len(dirs), 1.0)
    hits = np.flatnonzero((geomid >= 0) & (dist <= length))
    cast = rays_into_boxes(model, data, np.zeros(3), dirs, length, -1)
    assert len(hits) > 50
    assert np.isin(hits, cast).all()
    if with_plane:
        assert len(cast) == len(dirs)  # a plane's box bounds nothing: every ray
    else:
        assert len(cast) < 0.5 * len(dirs)  # and the boxes do leave rays out
        if per_ray:  # each ray by its own length: fewer than all by the longest
            assert len(cast) < len(rays_into_boxes(model, data, np.zeros(3), dirs, 0.03, -1))
