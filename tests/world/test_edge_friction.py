"""Friction across an edge's round (`physics: {edge_friction_ratio: k}`): the friction disc
stretched into an ellipse, k times as long across the round as along the edge. The solver
is checked against the elliptic Coulomb law itself (the traction inside the ellipse, slip
only on its rim and there along the ellipse's normal), a node dragged along each axis
against k μ p and μ p exactly, and the dome on the rectangle's edge against its isotropic
self: a slide across the edge meets more friction, one along it the same."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.core.sensor import TacTipGeometry
from twin.runs.sim_env import SimEnvironment
from twin.runs.spec import dome_params
from twin.world.dome.compliant.compliance import CapSurface, DomeCompliance
from twin.world.dome.compliant.contact import solve_increment, unknowns_matrix
from twin.world.dome.compliant.physics import EDGE_TILT_DEG, edge_friction_ellipses

MU = 0.5
TOLERANCE = 1e-9  # m


def _ellipses(count: int, ratio: float, seed: int) -> np.ndarray:
    """(count, 2, 2): ellipses `ratio` : 1 turned every which way."""
    turn = np.random.default_rng(seed).uniform(0.0, math.pi, count)
    axis = np.column_stack([np.cos(turn), np.sin(turn)])
    return np.eye(2) + (ratio - 1.0) * np.einsum("ki,kj->kij", axis, axis)


@pytest.mark.parametrize("direction", [(1.0, 0.0), (0.0, 1.0), (0.6, 0.8)])
def test_a_node_dragged_far_slides_on_its_ellipse(direction):
    """One node pressed 1 mm into a flat (its compliance 1 mm/N every way) and dragged 10 mm:
    along the ellipse's long axis (k = 1.5) it slides at 1.5 μ p, along the short one at μ p,
    and obliquely at the point of the ellipse whose normal is its slip."""
    stretch = np.diag([1.5, 1.0])
    drag = 1e-2 * np.array(direction)
    step = solve_increment(
        np.eye(3) * 1e-3, np.array([-1e-3]), np.zeros((1, 2)), drag[None], MU, np.zeros(1), np.zeros((1, 2)),
        1e-13, 200, None, stretch[None],
    )  # fmt: skip
    p, traction = step.pressure[0], step.traction[0]
    assert p == pytest.approx(1.0, rel=1e-12)
    assert np.linalg.norm(np.linalg.solve(stretch, traction)) == pytest.approx(MU * p, rel=1e-9)
    slip = 1e-3 * traction - drag  # the node's tangential motion against the flat (m)
    normal = np.linalg.solve(stretch @ stretch, traction)  # the ellipse's outward normal at the traction
    assert abs(normal[0] * slip[1] - normal[1] * slip[0]) < 1e-9 * np.linalg.norm(normal) * np.linalg.norm(slip)
    assert normal @ slip < 0.0  # the traction opposes the slip
    if direction != (0.6, 0.8):
        assert traction == pytest.approx(MU * p * stretch @ np.array(direction), abs=1e-12)


def _dome_problem(drag_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The skinned dome pressed 1.5 mm by a flat that then drags it `drag_mm` along x:
    (matrix, gap, object shift) in solve_increment's terms, and the nodes' frames."""
    surface = CapSurface(TacTipGeometry(), 0.0025, 65.0)
    dome = DomeCompliance(surface, 2.7e4, 0.5, enclosed=True, membrane_young=6e5)
    nodes = np.flatnonzero(surface.points[:, 2] > -0.002)
    frames = surface.frames[nodes]
    block = dome.block(nodes, nodes).reshape(len(nodes), 3, len(nodes), 3)
    local = np.einsum("iak,ikjl,jbl->iajb", frames, block, frames).reshape(3 * len(nodes), -1)
    gap = (-surface.points[nodes, 2] - 0.0015) * frames[:, 0, 2]
    shift = np.einsum("nij,j->ni", frames[:, 1:], np.array([drag_mm * 1e-3, 0.0, 0.0]))
    return unknowns_matrix(local), gap, shift, frames


@pytest.mark.parametrize("drag_mm", [0.05, 1.0])
def test_the_dome_meets_the_elliptic_coulomb_law(drag_mm):
    """Every node with its own ellipse (k = 2, turned at random): no pull, no penetration,
    no gap where pressed, each traction q within its ellipse (|S⁻¹ q| ≤ μ p), no slip where
    it is inside, and on the rim a slip along the ellipse's normal against q: its
    conditions, not the disc's, to the solver's tolerance, in partial (0.05 mm) and full
    slip (1 mm). The same drag with the disc slides at other tractions."""
    matrix, gap, shift, _ = _dome_problem(drag_mm)
    m = len(gap)
    stretch = _ellipses(m, 2.0, seed=3)
    step = solve_increment(matrix, gap, np.zeros((m, 2)), shift, MU, np.zeros(m), np.zeros((m, 2)), TOLERANCE, 20000,
                           None, stretch)  # fmt: skip
    unknowns = np.column_stack([step.pressure, step.traction])
    w = (matrix @ unknowns.ravel()).reshape(m, 3) + np.column_stack([gap, -shift])
    p, h, q, slip = step.pressure, w[:, 0], step.traction, w[:, 1:]
    scale = 1.0 / np.diag(matrix)[0::3]  # N per m of each node's own motion
    within = np.linalg.norm(np.linalg.solve(stretch, q[:, :, None])[:, :, 0], axis=1)
    assert np.min(p) >= -TOLERANCE * scale.max() and np.min(h) >= -10 * TOLERANCE
    assert np.max(np.abs(h[p > 0])) < 10 * TOLERANCE
    assert np.max((within - MU * p) / scale) < 10 * TOLERANCE
    pressed = p > 0
    rim = pressed & (within > MU * p - 1e-7 * scale)
    stuck = pressed & ~rim
    assert rim.any() and np.max(np.linalg.norm(slip[stuck], axis=1), initial=0.0) < 10 * TOLERANCE
    normal = np.linalg.solve(stretch[rim] @ stretch[rim], q[rim][:, :, None])[:, :, 0]
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.max(np.einsum("ij,ij->i", slip[rim], normal)) < 10 * TOLERANCE  # against the traction
    assert np.max(np.abs(slip[rim, 0] * normal[:, 1] - slip[rim, 1] * normal[:, 0])) < 10 * TOLERANCE
    disc = solve_increment(matrix, gap, np.zeros((m, 2)), shift, MU, np.zeros(m), np.zeros((m, 2)), TOLERANCE, 20000)
    assert np.abs(disc.traction - q).max() > 1e-3 * np.abs(q).max()


def test_only_a_node_on_an_edges_round_gets_the_ellipse():
    """The ellipse is stretched up the slope (the top's normal as the tangent plane holds
    it: across the round) where the object's normal turns from its top's by more than
    EDGE_TILT_DEG, and is the disc on the top and short of that turn."""
    top = np.array([0.0, 0.0, 1.0])

    def frame(turn_deg: float) -> np.ndarray:
        a = math.radians(turn_deg)
        c = np.array([math.sin(a), 0.0, -math.cos(a)])  # inward: down, and outwards over the round
        t1 = np.array([0.0, 1.0, 0.0])  # along the edge
        return np.array([c, t1, np.cross(c, t1)])

    frames = np.array([frame(0.0), frame(EDGE_TILT_DEG - 1.0), frame(45.0), frame(90.0)])
    ellipses = edge_friction_ellipses(frames, top, 2.0)
    assert np.array_equal(ellipses[:2], np.broadcast_to(np.eye(2), (2, 2, 2)))
    for k in (2, 3):
        up = frames[k, 1:] @ top / np.linalg.norm(frames[k, 1:] @ top)
        assert ellipses[k] @ up == pytest.approx(2.0 * up, abs=1e-12)  # across the round: twice
        assert ellipses[k] @ np.array([1.0, 0.0]) == pytest.approx([1.0, 0.0], abs=1e-12)  # along the edge: once


def _contact_force(ratio: float, slide: tuple[float, float]) -> np.ndarray:
    """(3,) N, tool frame: the net contact force on the dome pressed 3 mm with its centre
    3 mm off the rectangle's edge (rounded 1 mm; the contact on the round and the top),
    after sliding by `slide` (mm: work x away from the object, y along the edge)."""
    spec = {
        "name": "edge_friction_case",
        "object": {"name": "rectangle", "edge_radius_mm": 1.0, "friction": MU},
        "dome": "compliant",
        "effects": ["contact", "friction"],
        "physics": {"edge_friction_ratio": ratio},
    }
    env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(63, 0, -2, 0, 0, 0))
    env.reset()
    env.move_to(Pose(63, 0, 3, 0, 0, 0), 20.0)
    env.move_to(Pose(63 + slide[0], slide[1], 3, 0, 0, 0), 20.0)
    return env.physics.forces.sum(axis=0)


def test_a_slide_across_the_edge_meets_more_friction_and_one_along_it_the_same():
    """Slid 4 mm along the edge (full slip), the force along it is the same with friction
    twice as large across the round (the ellipse's short axis is μ), to 2 %; slid 2 mm
    across the round, off the object, the force across the edge is over 1.3 times the
    isotropic one's."""
    along = _contact_force(2.0, (0.0, 4.0))[1] / _contact_force(1.0, (0.0, 4.0))[1]
    across = _contact_force(2.0, (2.0, 0.0))[0] / _contact_force(1.0, (2.0, 0.0))[0]
    assert along == pytest.approx(1.0, abs=0.02)
    assert across > 1.3


def test_edge_friction_is_a_compliant_setting_within_its_bounds():
    """`physics: {edge_friction_ratio: k}` sets the compliant dome's ratio (1, the disc, by
    default); below 1 it is refused, naming the field."""
    spec = {"name": "ef", "object": {"name": "rectangle"}, "dome": "compliant"}
    assert dome_params(scenario_from_dict(spec)).edge_friction == 1.0
    assert dome_params(scenario_from_dict({**spec, "physics": {"edge_friction_ratio": 2.0}})).edge_friction == 2.0
    with pytest.raises(UserError, match="edge_friction_ratio"):
        dome_params(scenario_from_dict({**spec, "physics": {"edge_friction_ratio": 0.5}}))
