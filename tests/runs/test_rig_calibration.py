"""What a calibration says about the rig rather than the sensor, in the simulated rig
(twin.runs.sim_env): the arm's yield to the contact force (`arm_yield_mm_per_n`) and the
sensor's roll on its mount (`tcp_roll_deg`).

Scene: the rectangle, whose +x edge is the work line x = 60 mm (tests/world/
test_physics_hard_cases.py)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.core.errors import PhysicsError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment

#: 3 mm deep, well onto the object
PRESSED = Pose(40.0, 0.0, 3.0, 0.0, 0.0, 0.0)


def _env(calibration: dict | None, start: Pose) -> SimEnvironment:
    scenario = scenario_from_dict(
        {
            "name": "rig_calibration",
            "object": {"name": "rectangle"},
            "dome": "compliant",
            "effects": ["contact", "friction"],
            "sensor": {} if calibration is None else {"calibration": calibration},
        }
    )
    env = SimEnvironment(scenario, start_pose=start)
    env.reset()
    return env


def _pressed(calibration: dict | None, pose: Pose = PRESSED):
    """The observation after pressing from 5 mm above `pose` down to it."""
    env = _env(calibration, Pose(pose.x, pose.y, -5.0, 0.0, 0.0, pose.gamma))
    env.move_to(pose, 10.0)
    return env, env.observe()


def test_the_tcp_settles_where_the_arm_yields_to_the_contact_force():
    _, obs = _pressed({"arm_yield_mm_per_n": [0.1, 0.0, 0.0]})
    force = obs.truth["contact_force_n"]
    assert force > 0.5
    # the fixed point x = 40 + 0.1 mm/N × F(x), to a micron
    assert obs.pose.x == pytest.approx(40.0 + 0.1 * force, abs=1e-3)
    assert obs.pose.x - 40.0 > 0.05
    assert abs(obs.pose.y) < 1e-6 and obs.pose.z == pytest.approx(3.0, abs=1e-6)


def test_the_stuck_skin_shears_as_under_the_same_move_in_contact():
    _, yielded = _pressed({"arm_yield_mm_per_n": [0.1, 0.0, 0.0]})
    rigid, unsheared = _pressed(None)
    rigid.move_to(Pose(yielded.pose.x, 0.0, 3.0, 0.0, 0.0, 0.0), 10.0)
    sheared = rigid.observe().pins_px
    assert np.linalg.norm((yielded.pins_px - unsheared.pins_px).mean(axis=0)) > 0.1  # px: the yield is seen
    np.testing.assert_allclose(yielded.pins_px, sheared, atol=0.05)


def test_a_rigid_arm_takes_no_extra_move():
    (_, a), (_, b) = _pressed(None), _pressed({"arm_yield_mm_per_n": [0.0, 0.0, 0.0]})
    assert a.truth["physics_steps"] == b.truth["physics_steps"]
    assert a.pose.x == pytest.approx(40.0, abs=1e-9) and b.pose.x == a.pose.x
    np.testing.assert_array_equal(a.pins_px, b.pins_px)


def test_an_arm_that_yields_into_the_press_raises_naming_the_field():
    env = _env({"arm_yield_mm_per_n": [0.0, 0.0, 2.0]}, Pose(40.0, 0.0, -5.0, 0.0, 0.0, 0.0))  # 2 mm deeper per N
    # 2 mm/N × 3.9 N at the target: the first yield is already past the 5 mm limit, so no move
    with pytest.raises(
        PhysicsError, match=r"after 0 moves, the next 7\.\d mm past the 5\.0 mm limit\): calibration arm_yield_mm_per_n"
    ):
        env.move_to(PRESSED, 10.0)


def test_a_rolled_sensor_presses_as_the_straight_one_turned_by_the_roll():
    """1 mm onto the object, where the edge crosses the contact."""
    _, rolled = _pressed({"tcp_roll_deg": 25.0}, Pose(59.0, 0.0, 3.0, 0.0, 0.0, 10.0))
    _, turned = _pressed(None, Pose(59.0, 0.0, 3.0, 0.0, 0.0, 35.0))
    _, straight = _pressed(None, Pose(59.0, 0.0, 3.0, 0.0, 0.0, 10.0))
    np.testing.assert_allclose(rolled.pins_px, turned.pins_px, atol=1e-6)
    assert np.sqrt(np.mean(np.sum((rolled.pins_px - straight.pins_px) ** 2, axis=1))) > 1.0  # px
    assert rolled.pose.gamma == pytest.approx(10.0, abs=1e-9)  # the TCP's pose, as commanded
