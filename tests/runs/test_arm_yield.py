"""The arm's yield to the contact force (calibration `arm_yield_mm_per_n`): the TCP settles
where the commanded pose moved by the yield × the contact's normal force, the stuck skin
shears by what the arm yields, and a rigid arm (the default) takes no extra move.

Scene: the rectangle, whose +x edge is the work line x = 60 mm (tests/world/
test_physics_hard_cases.py); the sensor presses 3 mm at x = 40, well onto the object."""

from __future__ import annotations

import numpy as np
import pytest

from twin.core.errors import PhysicsError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment

ABOVE = Pose(40.0, 0.0, -5.0, 0.0, 0.0, 0.0)
PRESSED = Pose(40.0, 0.0, 3.0, 0.0, 0.0, 0.0)


def _env(yield_mm_per_n: list[float] | None) -> SimEnvironment:
    sensor = {} if yield_mm_per_n is None else {"calibration": {"arm_yield_mm_per_n": yield_mm_per_n}}
    scenario = scenario_from_dict(
        {
            "name": "arm_yield",
            "object": {"name": "rectangle"},
            "dome": "compliant",
            "effects": ["contact", "friction"],
            "sensor": sensor,
        }
    )
    env = SimEnvironment(scenario, start_pose=ABOVE)
    env.reset()
    return env


def test_the_tcp_settles_where_the_arm_yields_to_the_contact_force():
    env = _env([0.1, 0.0, 0.0])
    env.move_to(PRESSED, 10.0)
    obs = env.observe()
    force = obs.truth["contact_force_n"]
    assert force > 0.5
    # the fixed point x = 40 + 0.1 mm/N × F(x), to a micron
    assert obs.pose.x == pytest.approx(40.0 + 0.1 * force, abs=1e-3)
    assert obs.pose.x - 40.0 > 0.05
    assert abs(obs.pose.y) < 1e-6 and obs.pose.z == pytest.approx(3.0, abs=1e-6)


def test_the_stuck_skin_shears_as_under_the_same_move_in_contact():
    yielding = _env([0.1, 0.0, 0.0])
    yielding.move_to(PRESSED, 10.0)
    obs = yielding.observe()
    rigid = _env(None)
    rigid.move_to(PRESSED, 10.0)
    unsheared = rigid.observe().pins_px
    rigid.move_to(Pose(obs.pose.x, 0.0, 3.0, 0.0, 0.0, 0.0), 10.0)
    sheared = rigid.observe().pins_px
    shift = (obs.pins_px - unsheared).mean(axis=0)
    assert np.linalg.norm(shift) > 0.1  # px: the yield is seen in the pins
    np.testing.assert_allclose(obs.pins_px, sheared, atol=0.05)


def test_a_rigid_arm_takes_no_extra_move():
    rigid, still = _env(None), _env([0.0, 0.0, 0.0])
    for env in (rigid, still):
        env.move_to(PRESSED, 10.0)
    a, b = rigid.observe(), still.observe()
    assert a.truth["physics_steps"] == b.truth["physics_steps"]
    assert a.pose.x == pytest.approx(40.0, abs=1e-9) and b.pose.x == a.pose.x
    np.testing.assert_array_equal(a.pins_px, b.pins_px)


def test_an_arm_that_yields_into_the_press_raises_naming_the_field():
    env = _env([0.0, 0.0, 2.0])  # yields 2 mm deeper per newton: no pose holds
    with pytest.raises(PhysicsError, match="arm_yield_mm_per_n"):
        env.move_to(PRESSED, 10.0)
