"""The conventions module (twin.core.poses): Euler order, transforms, quaternion order,
angle wrap and the object <-> work flip, each checked against an independent construction."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from twin.core.poses import (
    Pose,
    angle_between_rotations_deg,
    invert_transform,
    object_to_work_deg,
    object_to_work_xy,
    quat_wxyz_to_matrix,
    transform_points,
    work_to_object_xy,
    wrap_deg,
)


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


POSES = [
    Pose(10, -20, 3, 0, 0, 0),
    Pose(0, 0, 0, 30, 0, 0),
    Pose(1, 2, 3, 10, -20, 135),
    Pose(-5, 7, -2, -15, 25, -170),
]


@pytest.mark.parametrize("pose", POSES)
def test_pose_matrix_is_extrinsic_xyz_in_mm(pose: Pose) -> None:
    r = _rz(math.radians(pose.gamma)) @ _ry(math.radians(pose.beta)) @ _rx(math.radians(pose.alpha))
    m = pose.to_matrix()
    np.testing.assert_allclose(m[:3, :3], r, atol=1e-12)
    np.testing.assert_allclose(m[:3, 3], [pose.x / 1e3, pose.y / 1e3, pose.z / 1e3], atol=1e-15)
    np.testing.assert_allclose(Pose.from_matrix(m).as_array(), pose.as_array(), atol=1e-9)


@pytest.mark.parametrize("pose", POSES)
def test_quaternion_is_w_first_like_mujoco(pose: Pose) -> None:
    expected = np.zeros(4)
    mujoco.mju_mat2Quat(expected, pose.rotation.ravel())
    q = pose.quat_wxyz()
    assert np.allclose(q, expected, atol=1e-12) or np.allclose(q, -expected, atol=1e-12)
    np.testing.assert_allclose(quat_wxyz_to_matrix(q), pose.rotation, atol=1e-12)


def test_inverse_transform_and_point_mapping() -> None:
    a2b = Pose(10, 20, 30, 15, -30, 60).to_matrix()
    points = np.array([[0.01, 0.0, 0.0], [0.0, -0.02, 0.005]])
    in_b = transform_points(a2b, points)
    np.testing.assert_allclose(in_b, (a2b @ np.c_[points, np.ones(2)].T).T[:, :3], atol=1e-15)
    np.testing.assert_allclose(transform_points(invert_transform(a2b), in_b), points, atol=1e-15)
    assert angle_between_rotations_deg(np.eye(3), _rz(math.radians(40))) == pytest.approx(40)


def test_wrap_is_half_open_minus_180_to_180() -> None:
    np.testing.assert_array_equal(wrap_deg([180, -180, 540, 179.5, -181, 0, 360]), [-180, -180, -180, 179.5, 179, 0, 0])


def test_object_work_flip_is_its_own_inverse_and_keeps_directions_consistent() -> None:
    rng = np.random.default_rng(0)
    p = rng.uniform(-50, 50, (20, 2))
    np.testing.assert_array_equal(work_to_object_xy(object_to_work_xy(p)), p)
    d = p[1:] - p[:-1]
    angle_object = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    w = object_to_work_xy(p)
    dw = w[1:] - w[:-1]
    np.testing.assert_allclose(np.degrees(np.arctan2(dw[:, 1], dw[:, 0])), object_to_work_deg(angle_object), atol=1e-9)
