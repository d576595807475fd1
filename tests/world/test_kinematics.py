"""IRB120 model and kinematics: FK against ABB's numbers, IK round trips, errors, scenes."""

from __future__ import annotations

import time

import mujoco
import numpy as np
import pytest

from twin.core.errors import UnreachablePoseError
from twin.core.poses import Pose, angle_between_rotations_deg, make_transform
from twin.core.resources import asset_path
from twin.world.kinematics import FLANGE_BODY, JOINT_NAMES, Irb120Kinematics

TOOL2FLANGE = make_transform(np.eye(3), [0.0, 0.0, 0.1])  # a 100 mm tool along tool0 z
POS_TOL_MM = 0.01
ANGLE_TOL_DEG = 0.01


@pytest.fixture(scope="module")
def kin() -> Irb120Kinematics:
    return Irb120Kinematics()


def _random_q(kin: Irb120Kinematics, rng: np.random.Generator, n: int) -> np.ndarray:
    lim = kin.joint_limits_rad
    return rng.uniform(lim[:, 0], lim[:, 1], size=(n, 6))


def _errors(a2w: np.ndarray, b2w: np.ndarray) -> tuple[float, float]:
    """Position (mm) and angle (deg) between two poses."""
    return float(np.linalg.norm(a2w[:3, 3] - b2w[:3, 3]) * 1e3), angle_between_rotations_deg(a2w[:3, :3], b2w[:3, :3])


def _within_limits(kin: Irb120Kinematics, q: np.ndarray) -> bool:
    lim = kin.joint_limits_rad
    return bool(np.all(q >= lim[:, 0]) and np.all(q <= lim[:, 1]))


def test_zero_configuration_is_abbs_calibration_pose(kin: Irb120Kinematics) -> None:
    # ABB IRB120 at q = 0: tool0 at (374, 0, 630) mm with quaternion (0.70711, 0, 0.70711, 0).
    flange2world = kin.forward(np.zeros(6))
    np.testing.assert_allclose(flange2world[:3, 3] * 1e3, [374.0, 0.0, 630.0], atol=1e-9)
    # tool0 z = base +x, tool0 x = base -z: a 90° turn about y, quaternion (0.70711, 0, 0.70711, 0).
    np.testing.assert_allclose(flange2world[:3, :3], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-9)
    assert kin.max_reach_m * 1e3 == pytest.approx(580.0, abs=0.01)


def test_joint_limits_match_the_product_specification(kin: Irb120Kinematics) -> None:
    expected = [(-165, 165), (-110, 110), (-110, 70), (-160, 160), (-120, 120), (-400, 400)]
    np.testing.assert_allclose(np.degrees(kin.joint_limits_rad), expected, atol=1e-6)


def test_home_keyframe_is_within_limits_with_flange_pointing_down(kin: Irb120Kinematics) -> None:
    home = kin.home_q
    assert _within_limits(kin, home)
    flange2world = kin.forward(home)
    np.testing.assert_allclose(flange2world[:3, 2], [0.0, 0.0, -1.0], atol=1e-9)
    assert flange2world[0, 3] > 0.2 and flange2world[2, 3] > 0.2  # in front of and above the base


def test_ik_round_trip_random_reachable_poses_with_tool(kin: Irb120Kinematics) -> None:
    rng = np.random.default_rng(20190520)
    worst_mm, worst_deg = 0.0, 0.0
    for q_true in _random_q(kin, rng, 250):
        tool2world = kin.forward(q_true) @ TOOL2FLANGE
        for seed in (None, q_true):
            q = kin.inverse(tool2world, TOOL2FLANGE, seed)
            assert _within_limits(kin, q)
            mm, deg = _errors(kin.forward(q) @ TOOL2FLANGE, tool2world)
            worst_mm, worst_deg = max(worst_mm, mm), max(worst_deg, deg)
        # Seeded with the true joints, the IK must return them (the closest solution).
        np.testing.assert_allclose(q, q_true, atol=1e-7)
    assert worst_mm < POS_TOL_MM and worst_deg < ANGLE_TOL_DEG, (worst_mm, worst_deg)


def test_ik_with_rotated_tool_and_user_pose(kin: Irb120Kinematics) -> None:
    tool2flange = Pose(5.0, -3.0, 120.0, 0.0, 0.0, 45.0).to_matrix()
    target = Pose(400.0, 50.0, 150.0, 180.0, 10.0, -30.0).to_matrix()  # pointing down, tilted
    q = kin.inverse(target, tool2flange)
    mm, deg = _errors(kin.forward(q) @ tool2flange, target)
    assert mm < POS_TOL_MM and deg < ANGLE_TOL_DEG


def test_ik_is_deterministic(kin: Irb120Kinematics) -> None:
    target = kin.forward(np.radians([20, 10, 15, -30, 50, 100])) @ TOOL2FLANGE
    first = kin.inverse(target, TOOL2FLANGE)
    for _ in range(3):
        np.testing.assert_array_equal(kin.inverse(target, TOOL2FLANGE), first)


def test_joint6_picks_the_turn_closest_to_the_seed(kin: Irb120Kinematics) -> None:
    q_true = np.radians([0, 10, 20, 0, 60, 390])
    target = kin.forward(q_true)
    np.testing.assert_allclose(kin.inverse(target, np.eye(4), q_true), q_true, atol=1e-9)
    seed = q_true.copy()
    seed[5] = np.radians(-340)
    assert np.degrees(kin.inverse(target, np.eye(4), seed)[5]) == pytest.approx(-330.0, abs=1e-6)


def test_wrist_singularity_is_solved(kin: Irb120Kinematics) -> None:
    q_true = np.radians([10, 20, -30, 40, 0, -50])  # q5 = 0: only q4 + q6 is determined
    target = kin.forward(q_true)
    q = kin.inverse(target, np.eye(4), q_true)
    np.testing.assert_allclose(q, q_true, atol=1e-9)


def test_newton_polish_converges_on_the_mujoco_model(kin: Irb120Kinematics) -> None:
    # The fallback that keeps IK and model consistent: start 3° off and converge.
    q_true = np.radians([10, 20, -30, 40, 50, -50])
    target = kin.forward(q_true)
    q = kin._polish(q_true + np.radians(3.0), target, target)
    mm, deg = _errors(kin.forward(q), target)
    assert mm < 1e-6 and deg < 1e-6


def test_unreachable_pose_names_the_distance(kin: Irb120Kinematics) -> None:
    target = Pose(2000.0, 0.0, 300.0, 180.0, 0.0, 0.0).to_matrix()
    with pytest.raises(
        UnreachablePoseError, match=r"out of reach \(wrist centre 2001\.7 mm from shoulder, max 580\.0 mm\)"
    ) as info:
        kin.inverse(target, np.eye(4))
    assert "x=2000.000 y=0.000 z=300.000 mm" in str(info.value)


def test_pose_beyond_joint_limits_names_the_joint(kin: Irb120Kinematics) -> None:
    # Flange pointing straight up, low in front of the robot: needs joint 5 ≈ 173°.
    target = Pose(300.0, 0.0, 100.0, 0.0, 0.0, 0.0).to_matrix()
    with pytest.raises(UnreachablePoseError, match=r"joint 5 would be 173\.\d°, limit -120…120°"):
        kin.inverse(target, np.eye(4))


def test_ik_is_fast(kin: Irb120Kinematics) -> None:
    rng = np.random.default_rng(1)
    targets = [kin.forward(q) @ TOOL2FLANGE for q in _random_q(kin, rng, 200)]
    start = time.perf_counter()
    for target in targets:
        kin.inverse(target, TOOL2FLANGE)
    per_call_ms = (time.perf_counter() - start) / len(targets) * 1e3
    assert per_call_ms < 5.0, f"{per_call_ms:.2f} ms per IK call"  # ≈ 0.2 ms measured


@pytest.mark.parametrize("name", ["irb120.xml", "scene.xml"])
def test_arm_scenes_step_one_second_without_warnings(name: str) -> None:
    model = mujoco.MjModel.from_xml_path(str(asset_path("irb120", name)))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    home = data.qpos.copy()
    for _ in range(round(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    assert [data.warning[i].number for i in range(len(data.warning))] == [0] * len(data.warning)
    np.testing.assert_allclose(data.qpos, home, atol=1e-6)  # servos + gravity compensation hold home
    assert model.body_subtreemass[0] == pytest.approx(25.0, abs=0.5)  # spec: 25 kg


def test_arm_attaches_into_a_bigger_scene_with_a_tool() -> None:
    arm = mujoco.MjSpec.from_file(str(asset_path("irb120", "irb120.xml")))
    tool = arm.body(FLANGE_BODY).add_body(
        name="tool", pos=[0, 0, 0.05], mass=0.3, inertia=[1e-4, 1e-4, 1e-4], gravcomp=1
    )
    tool.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.02, 0.05, 0])
    scene = mujoco.MjSpec()
    scene.worldbody.add_frame().attach_body(arm.body("base"), "arm/", "")
    model = scene.compile()
    assert all(model.joint(f"arm/{n}").id >= 0 for n in JOINT_NAMES)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("arm/home").id)
    mujoco.mj_forward(model, data)
    kin = Irb120Kinematics()
    expected = kin.forward(kin.home_q)
    np.testing.assert_allclose(data.xpos[model.body("arm/flange").id], expected[:3, 3], atol=1e-12)
