"""Arm dynamics (effect `arm_dynamics`): the IRB120's joints track the commanded
straight-line move through their position servos, and the sensor follows the arm's
*actual* flange, not the commanded pose.

The arm is simulated in its own MuJoCo model (assets/irb120/scene.xml, 2 ms steps,
gravity compensated like the real controller) in lockstep with the dome physics: the
trajectory generator streams IK joint targets along the Cartesian line at the commanded
speed (as RAPID's MoveL does), the servos lag, and every dome step receives the arm's
actual tool pose. The contact forces on the 40 mm dome (a few N) are not fed back: at
the IRB120's servo stiffness they would move the TCP by micrometres.
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from twin.core.errors import PhysicsError
from twin.core.poses import make_transform
from twin.core.resources import asset_path
from twin.world.kinematics import Irb120Kinematics

ARM_SCENE = asset_path("irb120", "scene.xml")
TOOL_MASS_KG = 0.35  # TacTip + adapter, added at the flange
SETTLE_JOINT_SPEED = 1e-4  # rad/s: the move has finished when every joint is slower
MAX_SETTLE_S = 2.0


class ArmDynamics:
    """Streams a Cartesian line to the arm's servos and reports the actual tool poses."""

    def __init__(self, kinematics: Irb120Kinematics, tool2flange: np.ndarray, q_start: np.ndarray) -> None:
        spec = mujoco.MjSpec.from_file(str(ARM_SCENE))
        flange = spec.body("flange")
        flange.gravcomp = 1.0  # the controller compensates the tool load, as the links
        flange.add_geom(
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[0.02],
            pos=tool2flange[:3, 3] / 2,
            mass=TOOL_MASS_KG,
            contype=0,
            conaffinity=0,
            group=3,
        )
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.kinematics = kinematics
        self.tool2flange = tool2flange
        self._flange = self.model.body("flange").id
        self._qadr = np.array([self.model.jnt_qposadr[self.model.joint(f"joint{i}").id] for i in range(1, 7)])
        self._dadr = np.array([self.model.jnt_dofadr[self.model.joint(f"joint{i}").id] for i in range(1, 7)])
        self.data.qpos[self._qadr] = q_start
        self.data.ctrl[:6] = q_start
        mujoco.mj_forward(self.model, self.data)

    @property
    def q(self) -> np.ndarray:
        return self.data.qpos[self._qadr].copy()

    def tool2world(self) -> np.ndarray:
        flange2world = make_transform(self.data.xmat[self._flange].reshape(3, 3), self.data.xpos[self._flange])
        return flange2world @ self.tool2flange

    def _advance(self, seconds: float) -> None:
        for _ in range(max(1, int(round(seconds / self.model.opt.timestep)))):
            mujoco.mj_step(self.model, self.data)
        if not np.all(np.isfinite(self.data.qpos)):
            raise PhysicsError(f"arm dynamics diverged (qpos {self.q})")

    def move(
        self,
        start: np.ndarray,
        target: np.ndarray,
        speed_mm_s: float,
        sample_dt: float,
        angular_speed_deg_s: float = 45.0,
    ) -> list[np.ndarray]:
        """Actual tool poses (4×4, m) every `sample_dt` s while the arm executes the line
        from `start` to `target` at `speed_mm_s` (rotating at most `angular_speed_deg_s`)
        and then settles."""

        distance = np.linalg.norm(target[:3, 3] - start[:3, 3])
        angle = Rotation.from_matrix(start[:3, :3].T @ target[:3, :3]).magnitude()
        duration = max(distance / (speed_mm_s * 1e-3), angle / np.radians(angular_speed_deg_s), sample_dt)
        n = int(np.ceil(duration / sample_dt))
        slerp = Slerp([0.0, 1.0], Rotation.from_matrix([start[:3, :3], target[:3, :3]]))
        poses = []
        q_seed = self.q
        for k in range(1, n + 1):
            s = k / n
            waypoint = make_transform(slerp(s).as_matrix(), start[:3, 3] + s * (target[:3, 3] - start[:3, 3]))
            q_seed = self.kinematics.inverse(waypoint, self.tool2flange, q_seed)
            self.data.ctrl[:6] = q_seed
            self._advance(sample_dt)
            poses.append(self.tool2world())
        waited = 0.0
        while np.max(np.abs(self.data.qvel[self._dadr])) > SETTLE_JOINT_SPEED:
            if waited > MAX_SETTLE_S:
                raise PhysicsError(
                    f"arm did not settle within {MAX_SETTLE_S} s after the move "
                    f"(joint speeds {self.data.qvel[self._dadr]} rad/s)"
                )
            self._advance(sample_dt)
            waited += sample_dt
            poses.append(self.tool2world())
        return poses
