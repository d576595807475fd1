"""The frictional contact solver (twin.world.dome.compliant.contact) on the skinned dome, whose
skin couples normal and tangential motion, checked against Signorini's and Coulomb's
conditions themselves: no penetration and no pull, no gap where pressed, the traction
inside the friction disc, no slip where it is inside, slip against the traction where it
is on the rim. The two algorithms (semismooth Newton, the alternation) must agree, and
Newton's step must be the one its residual's Jacobian gives (by finite differences)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.core.sensor import TacTipGeometry
from twin.world.dome.compliant.compliance import CapSurface, DomeCompliance
from twin.world.dome.compliant.contact import (
    _alart_curnier,
    _alart_curnier_residual,
    _newton_step,
    alternation_pass,
    friction_bound,
    own_stiffness,
    solve_coulomb,
    unknowns_matrix,
)

TOLERANCE = 1e-8  # m
MU = 0.7


def _problem(membrane_young: float, shift_mm: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat pressed 1.5 mm onto the dome, which then drags the nodes by `shift_mm`
    along a random direction: (M, offset) in solve_coulomb's convention."""
    surface = CapSurface(TacTipGeometry(), 0.0025, 65.0)
    dome = DomeCompliance(surface, 2.7e4, 0.5, enclosed=True, membrane_young=membrane_young)
    nodes = np.flatnonzero(surface.points[:, 2] > -0.002)
    frames = surface.frames[nodes]
    block = dome.block(nodes, nodes).reshape(len(nodes), 3, len(nodes), 3)
    local = np.einsum("iak,ikjl,jbl->iajb", frames, block, frames).reshape(3 * len(nodes), -1)
    matrix = unknowns_matrix(local)
    gap = (-surface.points[nodes, 2] - 0.0015) * frames[:, 0, 2]  # the flat at z = −1.5 mm, along each normal
    direction = np.random.default_rng(seed).normal(size=3) * np.array([1.0, 1.0, 0.0])
    drag = shift_mm * 1e-3 * direction / np.linalg.norm(direction)
    offset = np.column_stack([gap, -np.einsum("nij,j->ni", frames[:, 1:], drag)]).ravel()
    return matrix, offset


def _adhesion(matrix: np.ndarray, strength: float, ramp: float) -> np.ndarray:
    """(m, 2) N: every node's adhesive strength and ramp (`friction_bound`)."""
    return np.tile([strength, ramp], (len(matrix) // 3, 1))


def _coulomb_violation(
    matrix: np.ndarray, offset: np.ndarray, forces: np.ndarray, adhesion: np.ndarray | None = None
) -> float:
    """The largest violation (m) of Signorini's and Coulomb's conditions at `forces`, the
    friction disc's radius μ p + s (1 − e^(−p/c)) with `adhesion` (s, c per node)."""
    w = (matrix @ forces + offset).reshape(-1, 3)
    f = forces.reshape(-1, 3)
    p, h, q, v = f[:, 0], w[:, 0], f[:, 1:], w[:, 1:]
    bound = MU * p
    if adhesion is not None:
        bound = bound + np.where(p > 0, adhesion[:, 0] * (1.0 - np.exp(-np.maximum(p, 0) / adhesion[:, 1])), 0.0)
    scale = 1.0 / np.diag(matrix)[0::3]  # N per m of the node's own motion
    worst = [
        np.max(-p / scale),
        np.max(-h),
        np.max(np.abs(h[p > 0]), initial=0.0),
        np.max((np.linalg.norm(q, axis=1) - bound) / scale),
    ]
    rim = np.linalg.norm(q, axis=1) > bound - 1e-9 * scale
    worst.append(np.max(np.linalg.norm(v[~rim], axis=1), initial=0.0))
    if rim.any():
        along = q[rim] / np.maximum(np.linalg.norm(q[rim], axis=1), 1e-300)[:, None]
        worst.append(np.max(np.einsum("ij,ij->i", v[rim], along)))  # slip opposes q
        worst.append(np.max(np.abs(v[rim, 0] * along[:, 1] - v[rim, 1] * along[:, 0])))  # and is parallel to it
    return float(max(worst))


@pytest.mark.parametrize("membrane_young", [0.0, 6e5])
@pytest.mark.parametrize("shift_mm", [0.05, 1.0])
@pytest.mark.parametrize("strength", [None, 0.02])
def test_coulomb_conditions_hold_and_both_algorithms_agree(membrane_young, shift_mm, strength):
    """With adhesion (`strength` N per node, ramp 0.01 N: the nodes here carry 0.02–0.06 N)
    the disc's radius is μ p + s (1 − e^(−p/c)) and the same conditions hold."""
    matrix, offset = _problem(membrane_young, shift_mm, seed=1)
    adhesion = None if strength is None else _adhesion(matrix, strength, 0.01)
    newton, iterations, residual = solve_coulomb(matrix, offset, MU, np.zeros_like(offset), TOLERANCE, 20000, adhesion)
    assert residual < TOLERANCE
    assert iterations < 20  # Newton alone takes 3-5 here; where it stalls, the alternation's passes count too
    assert _coulomb_violation(matrix, offset, newton, adhesion) < 10 * TOLERANCE
    pressed = newton[0::3] > 0
    assert pressed.sum() > 10
    alternated = np.zeros_like(offset)
    for _ in range(5000):
        moved = alternation_pass(matrix, offset, MU, alternated, 0.1 * TOLERANCE, 20000, adhesion=adhesion)
        done = np.max(np.abs(matrix @ (moved - alternated))) < 0.1 * TOLERANCE
        alternated = moved
        if done:
            break
    assert _coulomb_violation(matrix, offset, alternated, adhesion) < 10 * TOLERANCE
    assert np.max(np.abs(newton - alternated)) < 1e-3 * np.max(newton[0::3])


def test_adhesion_raises_the_sliding_traction_by_its_bound():
    """Dragged 5 mm, every pressed node slides at the rim of its disc: with adhesion its
    traction is μ p + s (1 − e^(−p/c)) (`friction_bound`), larger than without."""
    matrix, offset = _problem(0.0, 5.0, seed=1)
    adhesion = _adhesion(matrix, 0.02, 0.01)
    plain, _, _ = solve_coulomb(matrix, offset, MU, np.zeros_like(offset), TOLERANCE, 20000)
    held, _, _ = solve_coulomb(matrix, offset, MU, np.zeros_like(offset), TOLERANCE, 20000, adhesion)
    p, q = held.reshape(-1, 3)[:, 0], np.linalg.norm(held.reshape(-1, 3)[:, 1:], axis=1)
    sliding = p > 0
    expected = MU * p + 0.02 * (1.0 - np.exp(-p / 0.01))
    assert np.abs(q[sliding] - expected[sliding]).max() < 1e-6 * expected.max()  # the residual is 1e-8 m
    assert np.allclose(friction_bound(p, MU, adhesion)[sliding], expected[sliding], rtol=1e-12)
    assert q.sum() > 1.5 * np.linalg.norm(plain.reshape(-1, 3)[:, 1:], axis=1).sum()


@pytest.mark.parametrize("membrane_young", [0.0, 6e5])
@pytest.mark.parametrize("strength", [None, 0.02])
def test_newtons_step_is_the_jacobians(membrane_young, strength):
    """The condensed step (`_newton_step`: free rows explicit, a sliding node's step along
    its slip eliminated) solves the same system as the full Jacobian of Φ/r, taken here by
    central differences, at the next increment's start: the last solution under a 20 %
    longer drag. On the solid that state mixes stuck, sliding and free nodes; under the
    membrane every pressed node slides. With adhesion (the friction bound's slope then
    differs from μ and from node to node) likewise."""
    matrix, offset = _problem(membrane_young, 0.02, seed=2)
    adhesion = _adhesion(matrix, 0.0 if strength is None else strength, 0.01)
    forces, _, _ = solve_coulomb(matrix, offset, MU, np.zeros_like(offset), 1e-10, 20000, adhesion)
    matrix, offset = _problem(membrane_young, 0.024, seed=2)
    r_n, r_t = own_stiffness(matrix)
    n, m = len(forces), len(forces) // 3
    phi, contact, slip = np.empty(n), np.zeros(m, bool), np.zeros(m, bool)
    z, size, radius, slope = np.empty((m, 2)), np.empty(m), np.empty(m), np.empty(m)
    _alart_curnier(matrix, offset, MU, adhesion, forces, r_n, r_t, phi, contact, slip, z, size, radius, slope)
    stuck, sliding = (contact & ~slip).sum(), (contact & slip).sum()
    if strength is None:
        assert sliding > 0 and (~contact).sum() > 0 and (stuck > 0) == (membrane_young == 0.0)
    else:
        assert sliding > 0 and (~contact).sum() > 0 and np.ptp(slope[contact & slip]) > 0.1 * MU
    step = np.empty(n)
    assert _newton_step(matrix, slope, forces, phi, contact, slip, z, size, radius, r_n, r_t, step)
    h = 1e-6 * np.abs(forces).max()  # N; no node changes state within it
    jacobian = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        jacobian[:, j] = (
            _alart_curnier_residual(matrix, offset, MU, adhesion, forces + e, r_n, r_t)
            - _alart_curnier_residual(matrix, offset, MU, adhesion, forces - e, r_n, r_t)
        ) / (2 * h)
    full = -np.linalg.solve(jacobian, phi)
    assert np.abs(step - full).max() < 1e-6 * np.abs(full).max()
