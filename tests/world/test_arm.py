"""Arm dynamics: off, the sensor is exactly where it was commanded; on, the IRB120's
servos lag the commanded line while moving and settle onto the target."""

from __future__ import annotations

import numpy as np

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment
from twin.world.arm import ArmDynamics
from twin.world.scene import TOOL2FLANGE, kinematics


def _scenario(effects: list[str]):
    return scenario_from_dict({"name": "arm", "object": {"name": "rectangle"}, "fidelity": "fast", "effects": effects})


def test_without_arm_dynamics_the_pose_is_exact() -> None:
    with SimEnvironment(_scenario(["contact", "friction"])) as env:
        env.reset()
        assert env.arm is None
        obs = env.step(Pose(60, 4, 3, 0, 0, 30))
    assert np.allclose(obs.pose.as_array(), [60, 4, 3, 0, 0, 30], atol=1e-9)


def test_with_arm_dynamics_the_arm_lags_then_settles() -> None:
    with SimEnvironment(_scenario(["contact", "friction", "arm_dynamics"])) as env:
        env.reset()
        obs = env.step(Pose(60, 4, 3, 0, 0, 30))
        assert env.arm is not None
    error = np.abs(obs.pose.as_array() - [60, 4, 3, 0, 0, 30])
    assert error[:3].max() < 0.01 and error[3:].max() < 0.01  # settled on the target (mm, deg)
    assert error.max() > 0  # but measured, not copied


def test_servo_lag_during_a_move() -> None:
    k = kinematics()
    start = Pose(400, 0, 150, 180, 0, 0).to_matrix()
    target = Pose(460, 0, 150, 180, 0, 0).to_matrix()
    arm = ArmDynamics(k, TOOL2FLANGE, k.inverse(start, TOOL2FLANGE))
    poses = arm.move(start, target, speed_mm_s=100.0, sample_dt=0.02)
    n = 30  # 60 mm at 100 mm/s in 20 ms samples; settling samples follow
    assert len(poses) > n
    commanded_mid = start[:3, 3] + 0.5 * (target[:3, 3] - start[:3, 3])
    lag_mm = np.linalg.norm(poses[n // 2 - 1][:3, 3] - commanded_mid) * 1e3
    assert 0.01 < lag_mm < 5.0
    assert np.linalg.norm(poses[-1][:3, 3] - target[:3, 3]) * 1e3 < 0.01
