"""Finite sliding on the compliant dome (`physics: {finite_sliding: true}`): each node meets
the object where friction has dragged it. On a face that changes nothing, since a plane's
gap does not depend on where along it a point is; over an edge it releases the nodes the
drag carries past it, which small sliding holds on the face's plane extended."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from twin.core.errors import UserError
from twin.core.poses import Pose, invert_transform
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment
from twin.runs.spec import dome_params
from twin.world.dome.compliant import CompliantPhysics
from twin.world.dome.compliant.closest import PROBE

#: the rectangle's edge the poses below meet, x in its own frame (mm): 120 mm wide, centred
EDGE_X_MM = 60.0


def _slid(finite_sliding: bool, poses: list[Pose]) -> tuple[np.ndarray, CompliantPhysics]:
    """The pins (frames, 127, 3) m after each of `poses` on the sharp rectangle, and the dome."""
    spec = {
        "name": "finite_sliding_case",
        "object": {"name": "rectangle"},
        "dome": "compliant",
        "effects": ["contact", "friction"],
        "physics": {"finite_sliding": finite_sliding},
    }
    env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(60, 0, -2, 0, 0, 0))
    env.reset()
    pins = []
    for pose in poses:
        env.move_to(pose, 20.0)
        pins.append(env.observe_frame().pins_tool.copy())
    return np.array(pins), env.physics


def test_on_a_face_finite_sliding_is_small_sliding():
    """Pressed 1.5 mm 15 mm onto the object, slid 3 mm along the edge and 3 mm away from
    it, the contact patch stays on the top face: the pins are those of small sliding to
    1 nm, and no increment settles at a switch of the contact set. Nor is any solved
    twice: where the solve moved the nodes along the face, their gaps and frames are the
    ones it was solved with, so each increment takes the one solve small sliding takes."""
    poses = [Pose(45, 0, -1, 0, 0, 0), Pose(45, 0, 1.5, 0, 0, 0), Pose(45, 3, 1.5, 0, 0, 0), Pose(42, 3, 1.5, 0, 0, 0)]
    small, plain = _slid(False, poses)
    finite, physics = _slid(True, poses)
    assert np.abs(small[1:] - small[0]).max() > 1e-4  # the pins did move
    assert np.abs(finite - small).max() < 1e-9
    assert physics.contact_switches == 0
    assert physics.solves == plain.solves and physics.geometry_kept > 0


def _loaded_points_mm(physics: CompliantPhysics) -> np.ndarray:
    """(k, 3) mm: the displaced points of the nodes carrying force, in the object's frame."""
    points = physics._rest_points + physics.displacement
    loaded = np.any(physics.forces != 0.0, axis=1)
    to_object = invert_transform(physics._object2tool)
    return (points[loaded] @ to_object[:3, :3].T + to_object[:3, 3]) * 1e3


def test_a_node_dragged_over_an_edge_leaves_the_face():
    """Pressed 3 mm deep 3 mm onto the object, then slid 3 mm further onto it: the skin
    stuck to the top face is dragged towards the edge. Small sliding keeps nodes dragged
    3 mm past the edge pressed on the face's plane extended; finite sliding releases them,
    and the nodes still pressed lie on the face or at the edge (within 0.2 mm: there a node
    meets the edge's tangent plane, which the corner's point only approximates)."""
    poses = [Pose(57, 0, -1, 0, 0, 0), Pose(57, 0, 3, 0, 0, 0), Pose(54, 0, 3, 0, 0, 0)]
    _, small = _slid(False, poses)
    _, finite = _slid(True, poses)
    assert _loaded_points_mm(small)[:, 0].max() > EDGE_X_MM + 1.0
    held = _loaded_points_mm(finite)
    assert len(held) > 50 and held[:, 0].max() < EDGE_X_MM + 0.2


def test_a_node_thrown_over_a_sharp_edge_settles_on_the_nearest_solve():
    """Pressed 3.5 mm deep 6 mm onto the sharp rectangle, turned −100°, the dome swaying
    0.2965 mm/N with 2.59 kPa of adhesion (the fit with finite sliding on the default's
    stiffness scale), μ 0.3162: at one increment a node at the edge is held where its
    point lies on one side of the corner and thrown about 0.1 mm clear where it lies on
    the other. The points stop where the contact set switches with that node 105 µm from
    where the last solve puts it; the increment takes the solve that came nearest its
    points (21 µm) and counts as a switch. (With switches held to 0.1 mm and the last
    solve taken, it raised PhysicsError.) The pins stay continuous through the press."""
    spec = {
        "name": "sharp_switch_case",
        "object": {"name": "rectangle", "friction": 0.3162},
        "dome": "compliant",
        "effects": ["contact", "friction"],
        "physics": {"finite_sliding": True, "tip_sway_mm_per_n": 0.2965, "adhesion_kpa": 2.59},
    }
    env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(54, 0, -2, 0, 0, -100))
    env.reset()
    pins = []
    for depth in (3.0, 3.25, 3.5, 3.75, 4.0):
        env.move_to(Pose(54, 0, depth, 0, 0, -100), 20.0)
        pins.append(env.observe_frame().pins_tool.copy())
    assert env.physics.contact_switches >= 1
    assert 1e-5 < env.physics.switch_drift < 3e-5  # the nearest solve's 21 µm, not the last one's 105
    steps = np.linalg.norm(np.diff(pins, axis=0), axis=2).max(axis=1)  # m, the largest pin step per 0.25 mm
    assert np.all(steps < 3 * np.median(steps))


def test_finite_sliding_is_a_scenario_setting_that_needs_whole_nodes():
    """`physics: {finite_sliding: true}` turns it on and adds the probe it measures
    distances with to the scene; off (the default) the scene has no probe. With edges
    placed within nodes it is refused, naming both fields."""
    on = {"name": "fs", "object": {"name": "rectangle"}, "dome": "compliant", "physics": {"finite_sliding": True}}
    assert dome_params(scenario_from_dict(on)).finite_sliding
    _, physics = _slid(True, [Pose(57, 0, -1, 0, 0, 0)])
    assert physics.model.geom(PROBE).contype == 0
    _, physics = _slid(False, [Pose(57, 0, -1, 0, 0, 0)])
    with pytest.raises(KeyError):
        physics.model.geom(PROBE)
    both = {**on, "physics": {"finite_sliding": True, "edge_within_node": True}}
    with pytest.raises(UserError, match=r"physics\.finite_sliding.*physics\.edge_within_node"):
        dome_params(scenario_from_dict(both))


def test_the_face_planes_find_mujocos_closest_points():
    """The closest points found from a piece's face planes (all points at once) are
    mj_geomDistance's, point by point, on the rectangle rounded 1 mm (a mesh of 268 faces)
    for 300 points scattered 1 mm about the dome's nodes pressed onto its edge: the same
    points and distances to 1 nm (mj_geomDistance's to the probe sphere's 1 µm radius more),
    and the direction into the piece (a face's normal where the point is over a face) the
    one from the point to mj_geomDistance's closest point, over points whose closest point
    lies within a face and points where it does not."""
    spec = {
        "name": "closest_case",
        "object": {"name": "rectangle", "edge_radius_mm": 1.0},
        "dome": "compliant",
        "physics": {"finite_sliding": True},
    }
    env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(59, 0, -2, 0, 0, 0))
    env.reset()
    env.move_to(Pose(59, 0, 2, 0, 0, 0), 20.0)
    physics: CompliantPhysics = env.physics
    closest_points, model, data = physics._closest, physics.model, physics.data
    rng = np.random.default_rng(0)
    points = physics._rest_points[rng.choice(physics.surface.count, 300)] + rng.normal(0.0, 1e-3, (300, 3))
    reach = 0.01
    distance, closest, inward = closest_points(data, points, reach)
    (piece,) = closest_points.geoms
    planes = closest_points.planes[0]
    fromto, compared, by_planes = np.empty(6), 0, 0  # by_planes: within a face
    for k, point in enumerate(points):
        data.geom_xpos[closest_points.probe] = point
        expected = mujoco.mj_geomDistance(model, data, int(piece), closest_points.probe, reach, fromto) + 1e-6
        if 0.0 < expected < reach:
            compared += 1
            assert distance[k] == pytest.approx(expected, abs=1e-9)
            assert np.linalg.norm(closest[k] - fromto[:3]) < 1e-9
            assert np.linalg.norm(inward[k] - (fromto[:3] - point) / np.linalg.norm(fromto[:3] - point)) < 1e-6
            local = (point - data.geom_xpos[piece]) @ data.geom_xmat[piece].reshape(3, 3)
            heights = local @ planes[:, :3].T + planes[:, 3]
            by_planes += bool(np.isclose(heights.max(), expected, atol=1e-9))  # a face's foot is the closest point
    assert compared > 150 and 0 < by_planes < compared


def test_a_pressed_node_sits_on_the_face_at_its_displaced_point():
    """Pressed 1.5 mm onto the top face and slid 3 mm along it: finite sliding measures a
    node's gap from its rest point (g = c · (closest point − rest point)), so the pressed
    nodes' gaps are −0.7 to −1.5 mm, how far they were pushed in. At their displaced points,
    g − c · u, they lie on the plane to 1 nm, as contact requires; that is the depth the
    check against indentation past the dome's reach reads."""
    from twin.world.dome.compliant.physics import gaps_at_displaced_points

    poses = [Pose(45, 0, -1, 0, 0, 0), Pose(45, 0, 1.5, 0, 0, 0), Pose(45, 3, 1.5, 0, 0, 0)]
    _, physics = _slid(True, poses)
    gaps, frames = physics._contact_geometry(physics._object2tool, physics.displacement)
    pressed = np.any(physics.forces != 0.0, axis=1)
    assert pressed.sum() > 30 and gaps[pressed].max() < -0.5e-3 and gaps[pressed].min() < -1.4e-3
    assert np.abs(gaps_at_displaced_points(gaps, frames, physics.displacement)[pressed]).max() < 1e-9


def test_a_node_hooked_on_a_sharp_edge_is_named():
    """Pressed 3 mm at l = +9.9 mm, turned −160°, and slid across the sharp rectangle's
    edge onto it, a dome with friction 0.2562 three times as high across the edge
    (edge_friction_ratio 2.928, sway 0.2288 mm/N, adhesion 2.89 kPa: a fit to the DigiTac
    taps on the default's stiffness scale) hooks a skin node on the edge's corner line:
    friction across it holds the node and the edge carries it. PhysicsError names it once
    it is carried past the model's 10 mm reach (it reads 10.29 mm at x = 55.5 mm); the same
    node's gap at its displaced point is about 0, so it is not reported as an indentation.
    With the ratio at 2 the node slips, and no node is carried more than 4 mm over the same
    slide; with the edge rounded by a quarter millimetre it slips at 2.928 too (5.08 mm)."""
    from twin.core.errors import PhysicsError

    def slide(ratio: float, edge_radius_mm: float = 0.0) -> float:
        """The farthest any node was carried at the slide's stops (m)."""
        spec = {
            "name": "caught_node_case",
            "object": {"name": "rectangle", "friction": 0.2562, "edge_radius_mm": edge_radius_mm},
            "dome": "compliant",
            "effects": ["contact", "friction"],
            "physics": {
                "finite_sliding": True,
                "tip_sway_mm_per_n": 0.2288,
                "adhesion_kpa": 2.89,
                "edge_friction_ratio": ratio,
                "surface_spacing_mm": 1.8,
            },
        }
        env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(69.9, 0, -2, 0, 0, -160))
        env.reset()
        carried = 0.0
        for x in (69.9, 66, 62, 58, 54):
            env.move_to(Pose(x, 0, 3, 0, 0, -160), 20.0)
            carried = max(carried, np.linalg.norm(env.physics.displacement, axis=1).max())
        return carried

    with pytest.raises(PhysicsError, match=r"a skin node carried 10\.\d\d mm by the object") as caught:
        slide(2.928)
    assert "indentation" not in str(caught.value) and "edge_radius_mm" in str(caught.value)
    assert slide(2.0) < 4e-3
    assert slide(2.928, edge_radius_mm=0.25) < 6e-3
