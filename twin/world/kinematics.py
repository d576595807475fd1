"""Forward and inverse kinematics of the ABB IRB120 (assets/irb120/irb120.xml).

Frames and units follow docs/conventions.md: `world` is the robot base frame (+z up,
+x forward), lengths in m, angles in rad, transforms 4×4 named `a2b`. The flange frame is
ABB's tool0 (body `flange`: +z out of the flange).

The inverse is analytic (the IRB120 has a spherical wrist and no shoulder offset): it
enumerates the up to 8 solutions (shoulder front/back × elbow up/down × wrist flip), keeps
those inside the joint limits and returns the one closest to the seed, taking joint 6's
±400° range into account. The link lengths are read from the MuJoCo model, and the
answer is checked against MuJoCo's own forward kinematics (and polished by Newton steps
on MuJoCo's Jacobian if ever needed), so the model and the IK agree to ~1e-12.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import mujoco
import numpy as np

from twin.core.errors import UnreachablePoseError
from twin.core.poses import Pose, invert_transform, make_transform
from twin.core.resources import asset_path

IRB120_XML = asset_path("irb120", "irb120.xml")

JOINT_NAMES = tuple(f"joint{i}" for i in range(1, 7))
FLANGE_BODY = "flange"
TWO_PI = 2.0 * math.pi

# Acceptance of an IK answer, checked against MuJoCo's forward kinematics.
_POS_TOL_M = 1e-9
_ROT_TOL_RAD = 1e-9
_ACCEPT_POS_M = 1e-7  # anything worse raises
_ACCEPT_ROT_RAD = 1e-7
_LIMIT_SLACK_RAD = 1e-9  # numerical slack when testing joint limits
_MAX_POLISH_STEPS = 5
_WRIST_SINGULAR_SIN = 1e-9  # |sin q5| below this: joints 4 and 6 are coupled


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rotation_error(r_target: np.ndarray, r_actual: np.ndarray) -> np.ndarray:
    """Rotation vector (rad, world axes) that takes r_actual to r_target."""
    r = r_target @ r_actual.T
    cos_angle = max(-1.0, min(1.0, 0.5 * (r[0, 0] + r[1, 1] + r[2, 2] - 1.0)))
    angle = math.acos(cos_angle)
    axis_sin = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    if angle < 1e-6:
        return 0.5 * axis_sin
    if angle > math.pi - 1e-6:  # near 180°: axis from the symmetric part
        k = int(np.argmax(np.diag(r)))
        axis = (r[:, k] + np.eye(3)[:, k]) / math.sqrt(2.0 * (1.0 + r[k, k]))
        return angle * axis
    return angle / (2.0 * math.sin(angle)) * axis_sin


class Irb120Kinematics:
    """Kinematics of the IRB120 model: flange2world from joint angles and back.

    Joint angles are (6,) arrays in rad, ordered joint1..joint6 (ABB axes 1–6, same
    signs as the robot's own joint readings). Not thread-safe (one MjData inside).
    """

    def __init__(self, xml_path: Path | str = IRB120_XML) -> None:
        self.model = mujoco.MjModel.from_xml_path(str(xml_path))
        self._data = mujoco.MjData(self.model)
        self._qadr = np.array([self.model.jnt_qposadr[self.model.joint(n).id] for n in JOINT_NAMES])
        self._dofadr = np.array([self.model.jnt_dofadr[self.model.joint(n).id] for n in JOINT_NAMES])
        self._flange_id = self.model.body(FLANGE_BODY).id
        self._limits = np.array([self.model.jnt_range[self.model.joint(n).id] for n in JOINT_NAMES])
        self._home = self.model.key("home").qpos[self._qadr].copy()
        self._read_geometry(Path(xml_path).name)
        self._jacp = np.zeros((3, self.model.nv))
        self._jacr = np.zeros((3, self.model.nv))

    # ------------------------------------------------------------------ model facts
    @property
    def joint_limits_rad(self) -> np.ndarray:
        """(6, 2) lower/upper joint limits (rad), joint1..joint6."""
        return self._limits.copy()

    @property
    def home_q(self) -> np.ndarray:
        """(6,) joint angles (rad) of the model's `home` keyframe (flange pointing down)."""
        return self._home.copy()

    @property
    def max_reach_m(self) -> float:
        """Largest distance (m) from the shoulder (joint 2 axis) to the wrist centre."""
        return self._a2 + self._l3

    def _read_geometry(self, source: str) -> None:
        """Read link lengths from the model at q = 0 and check the structure IK assumes."""
        m, d = self.model, self._data
        d.qpos[:] = 0.0
        mujoco.mj_kinematics(m, d)
        anchors = np.array([d.xanchor[m.joint(n).id] for n in JOINT_NAMES])
        axes = np.array([d.xaxis[m.joint(n).id] for n in JOINT_NAMES])
        expected_axes = np.array([[0, 0, 1], [0, 1, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0]], float)
        wrist = anchors[4]
        ok = (
            np.allclose(axes, expected_axes, atol=1e-12)
            and np.allclose(anchors[0][:2], 0.0, atol=1e-12)
            and np.allclose(anchors[1][:2], 0.0, atol=1e-12)  # no shoulder offset
            and np.allclose(anchors[2][:2], 0.0, atol=1e-12)
            and np.allclose(anchors[3][1:], wrist[1:], atol=1e-12)  # joint 4 axis through wrist centre
            and np.allclose(anchors[5][1:], wrist[1:], atol=1e-12)  # joint 6 axis through wrist centre
            and abs(wrist[1]) < 1e-12
        )
        if not ok:
            raise ValueError(f"{source}: joint layout is not the IRB120's (axes {axes.tolist()})")
        self._d1 = float(anchors[1][2])  # base to shoulder, 0.290
        self._a2 = float(anchors[2][2] - anchors[1][2])  # upper arm, 0.270
        self._a3 = float(wrist[2] - anchors[2][2])  # elbow offset, 0.070
        self._d4 = float(wrist[0] - anchors[2][0])  # forearm, 0.302
        self._l3 = math.hypot(self._a3, self._d4)  # elbow to wrist centre
        self._phi3 = math.atan2(self._a3, self._d4)
        flange2world0 = self._flange_from_data()
        self._flange_rot0 = flange2world0[:3, :3]
        # Wrist centre → flange origin, in flange coordinates (0, 0, 0.072).
        self._wrist2flange_offset = self._flange_rot0.T @ (flange2world0[:3, 3] - wrist)

    # ------------------------------------------------------------------ forward
    def _flange_from_data(self) -> np.ndarray:
        f = self._flange_id
        return make_transform(self._data.xmat[f].reshape(3, 3), self._data.xpos[f])

    def forward(self, q_rad: np.ndarray) -> np.ndarray:
        """flange2world (4×4, m) for joint angles q (6,) in rad, computed by MuJoCo."""
        self._data.qpos[self._qadr] = np.asarray(q_rad, dtype=float)
        mujoco.mj_kinematics(self.model, self._data)
        return self._flange_from_data()

    # ------------------------------------------------------------------ inverse
    def inverse(
        self,
        tool2world: np.ndarray,
        tool2flange: np.ndarray,
        q_seed: np.ndarray | None = None,
    ) -> np.ndarray:
        """Joint angles (6,) in rad that put the tool frame at tool2world (4×4, m).

        tool2flange (4×4, m) is the tool frame in the flange (tool0) frame. Of all
        solutions inside the joint limits, returns the one closest to q_seed (rad;
        default: home), using for joint 6 the 2π-equivalent nearest the seed.
        Raises UnreachablePoseError when the pose is out of reach or every solution
        violates a joint limit.
        """
        seed = self._home if q_seed is None else np.asarray(q_seed, dtype=float)
        flange2world = np.asarray(tool2world, float) @ invert_transform(np.asarray(tool2flange, float))
        r_target = flange2world[:3, :3]
        p_target = flange2world[:3, 3]
        wrist = p_target - r_target @ self._wrist2flange_offset

        candidates = self._analytic_candidates(wrist, r_target, seed, tool2world)
        valid: list[np.ndarray] = []
        rejected: list[tuple[float, list[tuple[int, float, float]]]] = []
        for q in candidates:
            q, violations = self._fit_limits(q, seed)
            if violations:
                rejected.append((sum(v[2] for v in violations), violations))
            else:
                valid.append(q)
        if not valid:
            _, violations = min(rejected, key=lambda item: item[0])  # the least-violating solution
            text = "; ".join(
                f"joint {j + 1} would be {math.degrees(value):.1f}°, limit "
                f"{math.degrees(self._limits[j, 0]):.0f}…{math.degrees(self._limits[j, 1]):.0f}°"
                for j, value, _ in violations
            )
            raise UnreachablePoseError(
                f"tool pose {self._pose_text(tool2world)} in world is reachable only outside the joint limits ({text})"
            )
        best = min(valid, key=lambda q: float(np.sum((q - seed) ** 2)))
        return self._polish(best, flange2world, tool2world)

    def _analytic_candidates(
        self, wrist: np.ndarray, r_target: np.ndarray, seed: np.ndarray, tool2world: np.ndarray
    ) -> list[np.ndarray]:
        """Up to 8 joint vectors (rad, unwrapped) reaching the flange pose."""
        x, y, z = wrist
        rho = math.hypot(x, y)
        zs = z - self._d1
        dist = math.hypot(rho, zs)
        a2, l3 = self._a2, self._l3
        reach_max, reach_min = a2 + l3, abs(a2 - l3)
        tol = 1e-9
        if dist > reach_max + tol:
            raise UnreachablePoseError(
                f"tool pose {self._pose_text(tool2world)} in world is out of reach (wrist centre "
                f"{dist * 1e3:.1f} mm from shoulder, max {reach_max * 1e3:.1f} mm)"
            )
        if dist < reach_min - tol:
            raise UnreachablePoseError(
                f"tool pose {self._pose_text(tool2world)} in world is too close to the shoulder (wrist centre "
                f"{dist * 1e3:.1f} mm from shoulder, min {reach_min * 1e3:.1f} mm)"
            )
        # Shoulder: face the wrist centre, or face away and lean back over the base.
        if rho < 1e-9:  # wrist centre on the joint-1 axis: joint 1 is free, keep the seed's
            q1_options = [(float(seed[0]), 0.0), (float(seed[0]) + math.pi, 0.0)]
        else:
            q1 = math.atan2(y, x)
            q1_options = [(q1, rho), (q1 + math.pi, -rho)]
        cos_delta = (dist * dist - a2 * a2 - l3 * l3) / (2.0 * a2 * l3)
        delta0 = math.acos(max(-1.0, min(1.0, cos_delta)))
        candidates: list[np.ndarray] = []
        for q1, r in q1_options:
            beta = math.atan2(r, zs)  # direction of the wrist centre from vertical, in the arm plane
            for delta in (delta0, -delta0) if delta0 > 1e-12 else (delta0,):
                q2 = beta - math.atan2(l3 * math.sin(delta), a2 + l3 * math.cos(delta))
                q3 = delta + self._phi3 - 0.5 * math.pi
                # Wrist: Rx(q4)·Ry(q5)·Rx(q6) = R03ᵀ · R · R0ᵀ.
                m = (_rot_z(q1) @ _rot_y(q2 + q3)).T @ r_target @ self._flange_rot0.T
                s5 = math.hypot(m[1, 0], m[2, 0])
                if s5 < _WRIST_SINGULAR_SIN:  # q5 ≈ 0: only q4 + q6 matters; keep the seed's q4
                    q4 = float(seed[3])
                    q6 = math.atan2(m[2, 1], m[1, 1]) - q4
                    wrists = [(q4, 0.0, q6)]
                else:
                    q5 = math.atan2(s5, m[0, 0])
                    q4 = math.atan2(m[1, 0], -m[2, 0])
                    q6 = math.atan2(m[0, 1], m[0, 2])
                    wrists = [(q4, q5, q6), (q4 + math.pi, -q5, q6 + math.pi)]
                for q4, q5, q6 in wrists:
                    candidates.append(np.array([q1, q2, q3, q4, q5, q6]))
        return candidates

    def _fit_limits(self, q: np.ndarray, seed: np.ndarray) -> tuple[np.ndarray, list[tuple[int, float, float]]]:
        """Shift each joint by 2πk to the value inside its limits nearest the seed.

        Returns the shifted q and the violations (joint index, value rad, excess rad) of
        joints that have no 2π-equivalent inside their limits.
        """
        out = q.copy()
        violations = []
        # Python floats: the same IEEE arithmetic as numpy's scalars at a fraction of the cost
        for j, (qj, seed_j, (lo, hi)) in enumerate(zip(q.tolist(), seed.tolist(), self._limits.tolist())):
            # The 2π-equivalent nearest the seed, then walk into the range if needed.
            v = qj + TWO_PI * round((seed_j - qj) / TWO_PI)
            if v > hi + _LIMIT_SLACK_RAD:
                v -= TWO_PI * math.ceil((v - hi - _LIMIT_SLACK_RAD) / TWO_PI)
            elif v < lo - _LIMIT_SLACK_RAD:
                v += TWO_PI * math.ceil((lo - _LIMIT_SLACK_RAD - v) / TWO_PI)
            if lo - _LIMIT_SLACK_RAD <= v <= hi + _LIMIT_SLACK_RAD:
                out[j] = min(max(v, lo), hi)
            else:
                # Report the equivalent in (-π, π] (the value a user would recognise).
                v = math.remainder(qj, TWO_PI)
                out[j] = v
                violations.append((j, v, max(lo - v, v - hi)))
        return out, violations

    def _polish(self, q: np.ndarray, flange2world: np.ndarray, tool2world: np.ndarray) -> np.ndarray:
        """Check q against MuJoCo's FK; Newton steps on MuJoCo's Jacobian if needed.

        The analytic answer normally passes at once (error ~1e-15 m); the steps only guard
        against a model/IK mismatch. Raises if the result is not within 1e-7 m / 1e-7 rad.
        """
        m, d = self.model, self._data
        for step in range(_MAX_POLISH_STEPS + 1):
            actual = self.forward(q)
            err = np.concatenate(
                [flange2world[:3, 3] - actual[:3, 3], _rotation_error(flange2world[:3, :3], actual[:3, :3])]
            )
            pos_err, rot_err = float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))
            if (pos_err < _POS_TOL_M and rot_err < _ROT_TOL_RAD) or step == _MAX_POLISH_STEPS:
                break
            mujoco.mj_comPos(m, d)  # the Jacobian needs cdof and subtree_com, not just mj_kinematics
            mujoco.mj_jacBody(m, d, self._jacp, self._jacr, self._flange_id)
            jac = np.vstack([self._jacp[:, self._dofadr], self._jacr[:, self._dofadr]])
            q = np.clip(q + np.linalg.lstsq(jac, err, rcond=1e-10)[0], self._limits[:, 0], self._limits[:, 1])
        if pos_err > _ACCEPT_POS_M or rot_err > _ACCEPT_ROT_RAD:
            raise UnreachablePoseError(
                f"tool pose {self._pose_text(tool2world)} in world: IK left {pos_err * 1e3:.4f} mm / "
                f"{math.degrees(rot_err):.4f}° error (at a joint limit or singularity?)"
            )
        return q

    @staticmethod
    def _pose_text(tool2world: np.ndarray) -> str:
        with warnings.catch_warnings():  # scipy warns on gimbal lock (β = ±90°); the angles are still valid
            warnings.simplefilter("ignore", UserWarning)
            p = Pose.from_matrix(np.asarray(tool2world, float))
        return f"({p})"
