"""Sensor poses in the lab convention and their conversion to SI transforms.

A pose is (x, y, z, α, β, γ): position in mm and extrinsic XYZ Euler angles in degrees
(R = Rz(γ)·Ry(β)·Rx(α)), of the tool frame (TCP at the dome apex) in a named work
frame. See docs/conventions.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

EULER_AXES = "xyz"  # scipy lower case = extrinsic (fixed-axis) rotations


@dataclass(frozen=True)
class Pose:
    """Sensor pose: x, y, z (mm), alpha, beta, gamma (deg), extrinsic XYZ."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    alpha: float = 0.0
    beta: float = 0.0
    gamma: float = 0.0

    @classmethod
    def from_array(cls, values) -> Pose:
        v = [float(a) for a in np.asarray(values, dtype=float).ravel()]
        if len(v) != 6:
            raise ValueError(f"a pose has 6 values (x, y, z mm; α, β, γ deg), got {len(v)}")
        return cls(*v)

    def __str__(self) -> str:
        return (
            f"x={self.x:.3f} y={self.y:.3f} z={self.z:.3f} mm, "
            f"α={self.alpha:.2f} β={self.beta:.2f} γ={self.gamma:.2f} deg"
        )

    def as_array(self) -> np.ndarray:
        """(6,) array: mm and degrees."""
        return np.array([self.x, self.y, self.z, self.alpha, self.beta, self.gamma])

    @property
    def position_m(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z]) * 1e-3

    @property
    def rotation(self) -> np.ndarray:
        """3×3 rotation matrix of the tool frame in the work frame."""
        return Rotation.from_euler(EULER_AXES, [self.alpha, self.beta, self.gamma], degrees=True).as_matrix()

    def to_matrix(self) -> np.ndarray:
        """4×4 homogeneous transform tool2work in metres."""
        return make_transform(self.rotation, self.position_m)

    @classmethod
    def from_matrix(cls, tool2work: np.ndarray) -> Pose:
        """Inverse of `to_matrix` (metres in, mm/deg out)."""
        xyz = tool2work[:3, 3] * 1e3
        abg = Rotation.from_matrix(tool2work[:3, :3]).as_euler(EULER_AXES, degrees=True)
        return cls(*xyz, *abg)

    def quat_wxyz(self) -> np.ndarray:
        """Orientation as a w-first unit quaternion (MuJoCo and ABB RAPID order)."""
        return matrix_to_quat_wxyz(self.rotation)

    def __add__(self, other: Pose) -> Pose:
        return Pose.from_array(self.as_array() + other.as_array())


def make_transform(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """4×4 homogeneous transform from a 3×3 rotation and a 3-vector (m)."""
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


def invert_transform(a2b: np.ndarray) -> np.ndarray:
    """b2a from a2b, for rigid 4×4 transforms."""
    r = a2b[:3, :3]
    return make_transform(r.T, -r.T @ a2b[:3, 3])


def transform_points(a2b: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map (N, 3) points from frame a into frame b."""
    return points @ a2b[:3, :3].T + a2b[:3, 3]


def quat_xyzw_to_wxyz(q: np.ndarray) -> np.ndarray:
    return np.array([q[3], q[0], q[1], q[2]])


def matrix_to_quat_wxyz(rotation: np.ndarray) -> np.ndarray:
    """w-first unit quaternion of a 3×3 rotation matrix."""
    return quat_xyzw_to_wxyz(Rotation.from_matrix(rotation).as_quat())


def quat_wxyz_to_matrix(q: np.ndarray) -> np.ndarray:
    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()


def angle_between_rotations_deg(r_a: np.ndarray, r_b: np.ndarray) -> float:
    """Geodesic angle between two rotation matrices (deg)."""
    return float(np.degrees(Rotation.from_matrix(r_a.T @ r_b).magnitude()))


def wrap_deg(angle) -> np.ndarray:
    """Wrap angles (deg) into [-180, 180)."""
    return (np.asarray(angle, float) + 180.0) % 360.0 - 180.0


def object_to_work_xy(points_mm: np.ndarray) -> np.ndarray:
    """Object-frame (x, y) mm → work-frame (x, y) mm. The default work frame is the object
    frame turned 180° about x (docs/conventions.md), so y flips; the flip is its own inverse."""
    p = np.atleast_2d(np.asarray(points_mm, float))
    return np.column_stack([p[:, 0], -p[:, 1]])


work_to_object_xy = object_to_work_xy


def object_to_work_deg(angle_deg) -> np.ndarray:
    """An in-plane direction (deg, atan2 of x, y) in the object frame → the work frame (and back)."""
    return -np.asarray(angle_deg, float)
