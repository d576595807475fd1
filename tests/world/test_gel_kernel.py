"""The gel's force kernel (twin.world.dome.compliant.compliance.disc_averaged_kernel) against the
closed forms it is built from, written out here in the half-space's own frame: Boussinesq
for a normal point force and Cerruti for a tangential one (K. L. Johnson, *Contact
Mechanics*, 1985, eqs. 3.20 and 3.21). Then the same for any orientation of the surface
(rotating the problem rotates the answer), and the disc average's rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from twin.world.dome.compliant.compliance import DISC_RULE, disc_averaged_kernel

G = 7.0e3  # Pa


def _point_kernel(targets: np.ndarray, sources: np.ndarray, outward: np.ndarray, poisson: float) -> np.ndarray:
    """The point force's kernel: the disc's of radius 0 (its frames' tangents play no part)."""
    frames = np.zeros((len(sources), 3, 3))
    frames[:, 0] = outward
    return disc_averaged_kernel(targets, sources, frames, 0.0, poisson, G)


def _johnson(point: np.ndarray, poisson: float) -> np.ndarray:
    """(3, 3) m/N: displacement [axis] per unit force [axis] at the origin of the half-space
    z ≥ 0 (depth z), in its own frame: forces along x (Cerruti) and along +z into the solid
    (Boussinesq)."""
    x, y, z = point
    rho = math.sqrt(x * x + y * y + z * z)
    c = 1.0 - 2.0 * poisson
    k = 1.0 / (4.0 * math.pi * G)
    cerruti_x = k * np.array(
        [
            1 / rho + x * x / rho**3 + c * (1 / (rho + z) - x * x / (rho * (rho + z) ** 2)),
            x * y / rho**3 - c * x * y / (rho * (rho + z) ** 2),
            x * z / rho**3 + c * x / (rho * (rho + z)),
        ]
    )
    cerruti_y = k * np.array(
        [
            x * y / rho**3 - c * x * y / (rho * (rho + z) ** 2),
            1 / rho + y * y / rho**3 + c * (1 / (rho + z) - y * y / (rho * (rho + z) ** 2)),
            y * z / rho**3 + c * y / (rho * (rho + z)),
        ]
    )
    radial = k * (z / rho**3 - c / (rho * (rho + z)))  # u_r / r
    boussinesq = np.array([radial * x, radial * y, k * (z * z / rho**3 + 2 * (1 - poisson) / rho)])
    return np.column_stack([cerruti_x, cerruti_y, boussinesq])


@pytest.mark.parametrize("poisson", [0.3, 0.5])
def test_the_kernel_is_boussinesq_and_cerruti(poisson: float) -> None:
    """Targets on and under the surface, 0.5–10 mm from the force: the kernel's columns
    are Johnson's to 1e-12. The twin's frame has the solid below an outward normal, so the
    half-space's depth axis is −z there."""
    rng = np.random.default_rng(4)
    lateral = rng.uniform(-0.01, 0.01, (40, 2))
    depth = np.concatenate([np.zeros(10), rng.uniform(0.0, 0.003, 30)])
    targets = np.column_stack([lateral, -depth])
    kernel = _point_kernel(targets, np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), poisson)[:, :, 0, :]
    flip = np.diag([1.0, 1.0, -1.0])  # the twin's frame ↔ the half-space's
    for target, got in zip(targets, kernel):
        expected = flip @ _johnson(flip @ target, poisson) @ flip
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


def test_the_kernel_turns_with_the_surface() -> None:
    """A source on a tilted surface (the dome's nodes face every way): rotating the
    targets, the source and its normal by R gives R K Rᵀ; a target that is the source
    itself is left NaN for the caller (the singular self term)."""
    rng = np.random.default_rng(5)
    targets = np.column_stack([rng.uniform(-0.01, 0.01, (20, 2)), -rng.uniform(0.0, 0.003, 20)])
    sources, outward = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    flat = _point_kernel(np.vstack([targets, sources]), sources, outward, 0.5)[:, :, 0, :]
    turn = Rotation.from_rotvec([0.7, -0.4, 1.1]).as_matrix()
    shift = np.array([0.003, -0.002, 0.01])
    tilted = _point_kernel(
        np.vstack([targets, sources]) @ turn.T + shift, sources @ turn.T + shift, outward @ turn.T, 0.5
    )[:, :, 0, :]
    np.testing.assert_allclose(tilted[:-1], turn @ flat[:-1] @ turn.T, rtol=1e-10, atol=1e-12 * np.abs(flat[:-1]).max())
    assert np.isnan(tilted[-1]).all() and np.isnan(flat[-1]).all()


def test_the_disc_average_is_its_rule() -> None:
    """A force spread over a disc is the rule's weighted sum of point forces at the rule's
    points in the source's tangent plane (weights summing to 1)."""
    assert DISC_RULE[:, 2].sum() == pytest.approx(1.0)
    rng = np.random.default_rng(6)
    targets = np.column_stack([rng.uniform(-0.01, 0.01, (15, 2)), -rng.uniform(0.001, 0.003, 15)])
    frames = np.array([[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])  # normal, t1, t2
    radius = 0.0008
    spread = disc_averaged_kernel(targets, np.zeros((1, 3)), frames, radius, 0.45, G)
    points = np.array([[radius * x, radius * y, 0.0] for x, y, _ in DISC_RULE])
    each = _point_kernel(targets, points, np.tile([0.0, 0.0, 1.0], (len(points), 1)), 0.45)
    np.testing.assert_allclose(spread[:, :, 0, :], np.einsum("tasb,s->tab", each, DISC_RULE[:, 2]), rtol=1e-12)
