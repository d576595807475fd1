"""The compliant dome (twin.world.dome.flex) and its quasi-static stepping (twin.world.dome.flex.physics).

Scene: a box "rectangle" whose top face is z = 0 with a straight edge along y at x = 0
(box at x < 0), the TacTip pointing down (twin.world.dome.testbed.edge_scene). No mocks.

Pixel scale: CameraModel focal ≈ 451 px; pin tips lie 30–45 mm from the camera, so
1 µm lateral ≈ 0.010–0.015 px and the 2 µm rest tolerance ≈ 0.02–0.03 px (< 0.05 px).
"""

from __future__ import annotations

import numpy as np
import pytest

from twin.core.errors import PhysicsError
from twin.core.sensor import CameraModel
from twin.world.dome.flex import FIDELITY_LEVELS, DomeParams
from twin.world.dome.flex.clearance import CLEARANCE_SAFETY
from twin.world.dome.testbed import edge_scene, sensor_down

SPEED = 15.0  # mm/s, the paper's robot
REST_TOL = 2e-6  # m


def _press(params: DomeParams, x: float, y: float, depth: float, gamma: float = 0.0, friction: bool = True):
    _, _, _, physics = edge_scene(params, friction=friction, start_tool2world=sensor_down(x, y, -1.0, gamma))
    physics.move(sensor_down(x, y, depth, gamma), SPEED)
    return physics, physics.settle()


def test_px_conversion_of_rest_tolerance():
    cam = CameraModel()
    assert 440 < cam.focal_px < 460
    px_per_um = cam.focal_px * 1e-6 / 0.030  # worst case: nearest pins, 30 mm depth
    assert REST_TOL * 1e6 * px_per_um <= 0.05


def test_press_depth_changes_pins_and_indents():
    p = FIDELITY_LEVELS["default"]
    physics, f2 = _press(p, 0, 0, 2)
    _, f4 = _press(p, 0, 0, 4)
    rms = np.sqrt(np.mean(np.sum((f4.pins_tool - f2.pins_tool) ** 2, axis=1)))
    assert rms > 200e-6  # ≫ numerical noise (bit-identical reruns; settle floor ~1 µm)
    d4 = f4.pins_tool - physics.rest_pins
    # pins near the contact move up in the world = towards the camera = −z in the tool frame
    assert d4[0, 2] < -3e-3
    assert 1.0 < f2.contact_force < f4.contact_force < 8.0  # a few N at 4 mm


def _displacement_direction(frame, rest) -> float:
    """Angle (deg) in the tool xy plane of the indentation centroid (|dz|-weighted pins)."""
    w = np.abs(frame.pins_tool[:, 2] - rest[:, 2])
    c = (rest[:, :2] * w[:, None]).sum(0) / w.sum()
    return float(np.degrees(np.arctan2(c[1], c[0])))


def test_edge_orientation_readable_from_pins():
    p = FIDELITY_LEVELS["default"]
    ph0, f0 = _press(p, 0, 0, 3, gamma=0)
    ph90, f90 = _press(p, 0, 0, 3, gamma=90)
    a0 = _displacement_direction(f0, ph0.rest_pins)
    a90 = _displacement_direction(f90, ph90.rest_pins)
    assert abs(abs(a0) - 180) < 10  # object at world x < 0 = tool −x
    assert abs(((a90 - a0 + 180) % 360 - 180) + 90) < 10  # rotating the sensor +90° turns the pattern −90°


def test_slide_direction_flips_shear():
    p = FIDELITY_LEVELS["default"]
    shifts = []
    for dy in (+3, -3):
        physics, _ = _press(p, 0, 0, 4)
        physics.move(sensor_down(0, dy, 4), SPEED)
        f = physics.settle()
        shifts.append(np.mean(f.pins_tool[:, 1] - physics.rest_pins[:, 1]))
    assert shifts[0] * shifts[1] < 0
    assert min(abs(s) for s in shifts) > 100e-6
    # sensor moving +y_world = −y_tool: the skin lags behind, pins shift +y_tool
    assert shifts[0] > 0


def test_skin_membrane_carries_the_drag():
    """Sliding 12 mm along the edge on PLA (μ 0.7): the membrane cuts the skin's common-mode
    drag (21 px → 3.4 px measured); with membrane_young 0 it is not even built."""
    camera = CameraModel()
    drag = {}
    for young in (0.0, FIDELITY_LEVELS["default"].membrane_young):
        model, _, _, physics = edge_scene(
            FIDELITY_LEVELS["default"].with_(membrane_young=young),
            object_friction=0.7,
            start_tool2world=sensor_down(0, -6, -1.0),
        )
        assert model.nflex == (1 if young == 0 else 2)
        physics.move(sensor_down(0, -6, 3), SPEED)
        pressed = camera.project_tool_points(physics.settle().pins_tool)
        physics.move(sensor_down(0, 6, 3), SPEED)
        slid = camera.project_tool_points(physics.settle().pins_tool)
        drag[young] = np.linalg.norm(np.mean(slid - pressed, axis=0))
    gel_only, with_membrane = drag.values()
    assert gel_only > 10.0 and 1.0 < with_membrane < 0.3 * gel_only, drag


def test_frictionless_slide_equals_static_press():
    p = FIDELITY_LEVELS["default"]
    physics, _ = _press(p, 0, -3, 4, friction=False)
    physics.move(sensor_down(0, 0, 4), SPEED)
    slid = physics.settle()
    _, static = _press(p, 0, 0, 4, friction=False)
    assert np.max(np.abs(slid.pins_tool - static.pins_tool)) < 20e-6


@pytest.mark.parametrize("level", ["fast", "default", "reference"])
def test_hard_cases_return_to_rest(level):
    p = FIDELITY_LEVELS[level]
    physics, f = _press(p, 0, 0, 6)  # deep press
    assert f.settled and f.contact_force > 2.0
    physics.move(sensor_down(0, 3, 6), 3 * SPEED)  # 3× nominal speed
    physics.settle()
    physics.move(sensor_down(25, 3, 4), SPEED)  # slide off the edge, leaving the object
    physics.settle()
    physics.move(sensor_down(25, 3, -3), SPEED)  # back to no contact
    f = physics.settle()
    assert f.contact_force == 0.0
    assert np.max(np.abs(f.pins_tool - physics.rest_pins)) < REST_TOL


def _run_sequence():
    physics, _ = _press(FIDELITY_LEVELS["default"], 0, 0, 3)
    physics.move(sensor_down(0, 3, 3), SPEED)
    return physics.settle().pins_tool


def test_deterministic():
    assert np.array_equal(_run_sequence(), _run_sequence())


def test_absurd_stiffness_raises():
    with pytest.raises(PhysicsError, match=r"\[edge\] step \d+"):
        _press(DomeParams(young=5.0e7), 0, 0, 4)  # 1000× too stiff: the press needs kN, the force bound trips


def test_absurd_settling_cap_raises():
    with pytest.raises(PhysicsError, match="did not settle"):
        _press(DomeParams(max_settle_steps=2, settle_px=1e-3), 0, 0, 4)  # 0.001 px in 2 steps


def test_pin_map_is_exact():
    """SensorPhysics reads the pins through a linear map of the node joints (PinMap); it must
    equal MuJoCo's own trilinear interpolation in a deformed state."""
    import mujoco

    from twin.world.dome.flex import pin_tips_tool

    physics, _ = _press(FIDELITY_LEVELS["default"], 0, 0, 4)
    assert physics._pin_map.exact
    mujoco.mj_kinematics(physics.model, physics.data)
    mujoco.mj_flex(physics.model, physics.data)
    exact = pin_tips_tool(physics.model, physics.data, physics.handles)
    assert np.max(np.abs(physics._pin_map(physics.data.qpos) - exact)) < 1e-12


def test_pin_map_is_measured_once_per_model_and_holds_from_any_state():
    """Every episode builds a SensorPhysics; the map is measured once per compiled model,
    from whatever state it first sees. Built again on the same model just after a 4 mm
    press was lifted off (the dome still springing back, not at rest), it is the same
    map, and still MuJoCo's own interpolation after a new press."""
    import mujoco

    from twin.world.dome.flex import pin_tips_tool
    from twin.world.dome.flex.physics import SensorPhysics

    first, _ = _press(FIDELITY_LEVELS["fast"], -3, 0, 4)
    first.move(sensor_down(-3, 0, -1), SPEED)
    nodes = first._pin_map.qadr
    assert np.abs(first.data.qpos[nodes] - first._pin_map.q0).max() > 1e-5  # not at rest
    again = SensorPhysics(
        first.model, first.data, first.handles, first.params, "edge", first._commanded, camera=first.camera
    )
    assert again._pin_map is first._pin_map
    again.move(sensor_down(-2, 0, 3), SPEED)
    again.settle()
    mujoco.mj_kinematics(again.model, again.data)
    mujoco.mj_flex(again.model, again.data)
    exact = pin_tips_tool(again.model, again.data, again.handles)
    assert np.max(np.abs(again._pin_map(again.data.qpos) - exact)) < 1e-12
    other, _ = _press(FIDELITY_LEVELS["fast"], -3, 0, 4)  # a model of its own: a map of its own
    assert other._pin_map is not first._pin_map


def test_clear_stretches_are_jumped_not_lost():
    """jump_clear_moves carries the box over the stretch of a move where nothing can touch
    the dome, in closed form: the collision surface lies `margin` behind the apex and the
    gap is that margin, one step's travel and CLEARANCE_SAFETY, so a pose is clear while
    the box's top is more than a step + CLEARANCE_SAFETY above the apex. The settled press
    is the one that stepping every step gives, within the settling band, on the same clock."""
    stepped_params = FIDELITY_LEVELS["fast"].with_(jump_clear_moves=False)
    jumped_params = stepped_params.with_(jump_clear_moves=True)
    frames, steps = [], []
    for params in (stepped_params, jumped_params):
        _, _, _, physics = edge_scene(params, start_tool2world=sensor_down(-10, 0, -20))
        steps.append(physics.move(sensor_down(-10, 0, 3), SPEED))  # 23 mm down, the last 3 into the box
        frames.append(physics.settle())
    n = int(np.ceil(23.0 / (SPEED * stepped_params.timestep)))
    step_mm = 23.0 / n
    clear_poses = int(
        np.ceil((20.0 - step_mm - CLEARANCE_SAFETY * 1e3) / step_mm)
    )  # heights 20 − k·step > step + safety
    assert steps == [n, n - (clear_poses - 1)]
    camera = CameraModel()
    by_steps, by_jump = (camera.project_tool_points(f.pins_tool) for f in frames)
    assert frames[1].contact_force > 1.0
    assert np.abs(by_jump - by_steps).max() < stepped_params.settle_px
    assert frames[1].time - frames[0].time == pytest.approx(
        (frames[1].settle_steps - frames[0].settle_steps) * stepped_params.timestep
    )


def test_a_move_through_the_object_is_stepped_where_it_touches():
    """A move that starts and ends clear of the box but cuts its edge 1 mm deep on the way
    is stepped there, and the skin comes back to the rest it comes to when every step is
    stepped."""
    stepped_params = FIDELITY_LEVELS["fast"].with_(jump_clear_moves=False)
    rests, steps = [], []
    for params in (stepped_params, stepped_params.with_(jump_clear_moves=True)):
        _, _, _, physics = edge_scene(params, start_tool2world=sensor_down(-25, 0, -5))
        steps.append(physics.move(sensor_down(25, 0, 7), SPEED))  # at x = 0 the apex is 1 mm deep
        rests.append(physics.settle())
    total = int(np.ceil(np.hypot(50.0, 12.0) / (SPEED * stepped_params.timestep)))
    assert steps[0] == total
    assert 10 <= steps[1] < total
    assert rests[1].contact_force == 0.0
    assert np.abs(rests[1].pins_tool - rests[0].pins_tool).max() < REST_TOL
