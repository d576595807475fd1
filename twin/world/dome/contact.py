"""One quasi-static increment of frictional contact between the compliant dome and a
rigid object (Kalker's incremental theory, posed as two convex problems).

Unknowns per contact-candidate node i (local frame: outward normal n, tangents t1, t2):
pressure p_i ≥ 0 (force on the dome −p_i n) and tangential force q_i (2-vector). With the
nodes' displacements u = D f (D the compliance block of the candidates, m/N):

* normal (Signorini): gap after deformation h = g + w ≥ 0, p ≥ 0, p·h = 0, where g is the
  rigid gap along the normal (negative = overlap) and w = −n·u the inward displacement.
  Convex: p minimises ½ pᵀ D_nn p + (g − D_nt q)ᵀ p over p ≥ 0 (its gradient is h);
* tangential (Coulomb, incremental): the slip of the skin against the object since the
  last increment, v = u_t − u_t,prev − Δo_t (Δo: the object's own displacement at the
  node), vanishes where |q_i| < μ p_i (stick) and opposes q_i where |q_i| = μ p_i (slip).
  Convex for fixed p (maximum dissipation): q minimises ½ qᵀ D_tt q + (−D_tn p −
  u_t,prev − Δo_t)ᵀ q over the discs |q_i| ≤ μ p_i (its gradient is v).

The two are alternated (Panagiotopoulos) until neither changes; with an incompressible
gel (ν = 0.5) on a flat they decouple exactly and one pass suffices. Each convex problem
is solved warm-started from the previous increment, to a residual in metres: the normal
one by active sets (exact Cholesky solves on the nodes in contact), the tangential one by
accelerated projected gradient with adaptive restart (Nesterov; O'Donoghue & Candès 2015).
Nothing passes silently: a problem that does not converge raises `ContactNotConverged`.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve


class ContactNotConverged(RuntimeError):
    """The contact problem did not reach its tolerance (message says which and how far)."""


@dataclass
class ContactIncrement:
    """The solution of one increment, for the candidate nodes.

    pressure (m,) N ≥ 0; traction (m, 2) N in (t1, t2); forces (m, 3) N on the dome in
    the nodes' local frames (n, t1, t2);
    iterations: projected-gradient iterations (both problems, all passes); passes:
    normal/tangential alternations; residual: final residual (m).
    """

    pressure: np.ndarray
    traction: np.ndarray
    forces: np.ndarray
    iterations: int
    passes: int
    residual: float


def largest_eigenvalue(matrix: np.ndarray, iterations: int = 40) -> float:
    """Upper estimate of the largest eigenvalue of a symmetric positive definite matrix
    (power iteration, +2 %)."""
    x = np.ones(len(matrix)) / np.sqrt(len(matrix))
    value = 0.0
    for _ in range(iterations):
        y = matrix @ x
        value = float(np.linalg.norm(y))
        if value == 0.0:
            return 0.0
        x = y / value
    return 1.02 * value


def projected_gradient(matrix: np.ndarray, linear: np.ndarray, start: np.ndarray,
                       project: Callable[[np.ndarray], np.ndarray], tolerance: float,
                       max_iterations: int, lipschitz: float | None = None) -> tuple[np.ndarray, int, float]:
    """Minimise ½ xᵀ A x + bᵀ x over a convex set (its projection given).

    Returns (x, iterations, residual) where the residual is the infinity norm of the
    gradient mapping L·(x − P(x − ∇/L)) — in the units of the gradient (here m). Raises
    ContactNotConverged if it stays above `tolerance` after `max_iterations`.
    """
    lip = largest_eigenvalue(matrix) if lipschitz is None else lipschitz
    x = project(start)
    if lip == 0.0:
        return x, 0, 0.0
    y, momentum = x.copy(), 1.0
    residual = np.inf
    for k in range(1, max_iterations + 1):
        gradient = matrix @ y + linear
        x_next = project(y - gradient / lip)
        step = x_next - y
        residual = lip * float(np.max(np.abs(step))) if len(step) else 0.0
        if residual < tolerance:
            return x_next, k, residual
        if float(step @ (x_next - x)) > 0.0:  # moving against the gradient: restart the momentum
            momentum = 1.0
            y = x_next.copy()
        else:
            momentum_next = 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * momentum * momentum))
            y = x_next + ((momentum - 1.0) / momentum_next) * (x_next - x)
            momentum = momentum_next
        x = x_next
    raise ContactNotConverged(f"projected gradient: residual {residual:.3g} m after {max_iterations} iterations "
                              f"(tolerance {tolerance:.3g} m)")


def solve_normal(matrix: np.ndarray, linear: np.ndarray, start: np.ndarray, tolerance: float,
                 max_iterations: int) -> tuple[np.ndarray, int, float]:
    """The normal problem min ½ pᵀ D p + cᵀ p over p ≥ 0 by active sets (Kalker's NORM):
    solve D_AA p_A = −c_A on the nodes A in contact, drop those that pull (p < 0), add
    those that penetrate (gradient h = D p + c < −tolerance), until neither happens —
    exact up to round-off, typically in 2–4 Cholesky solves when warm-started. Falls back
    to `projected_gradient` if the sets cycle. Returns (p, solves, residual (m))."""
    active = (start > 0.0) | (linear < 0.0)
    for k in range(1, 31):
        p = np.zeros_like(linear)
        idx = np.flatnonzero(active)
        if len(idx):
            block = matrix[np.ix_(idx, idx)]
            try:
                factor = cho_factor(block, check_finite=False)
            except np.linalg.LinAlgError:
                break
            p[idx] = cho_solve(factor, -linear[idx], check_finite=False)
        pulling = p < 0.0
        if pulling.any():
            active &= ~pulling
            continue
        gap = matrix @ p + linear
        penetrating = ~active & (gap < -tolerance)
        if not penetrating.any():
            # complementarity: no gap where pressed, no penetration anywhere (round-off in
            # an ill-conditioned block can leave µm: the gradient method finishes then)
            residual = float(max(np.abs(gap[p > 0.0]).max(initial=0.0), -gap.min(initial=0.0)))
            if residual < tolerance:
                return p, k, residual
            start = p
            break
        active |= penetrating
    return projected_gradient(matrix, linear, start, lambda x: np.maximum(x, 0.0), tolerance, max_iterations)


def project_discs(q: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Project stacked 2-vectors (flattened, (2m,)) onto discs |q_i| ≤ radius_i."""
    pairs = q.reshape(-1, 2)
    norm = np.sqrt(np.einsum("ij,ij->i", pairs, pairs))
    scale = np.where(norm > radius, radius / np.maximum(norm, 1e-300), 1.0)
    return (pairs * scale[:, None]).ravel()


def solve_increment(compliance: np.ndarray, gap: np.ndarray, previous_tangential: np.ndarray,
                    object_shift: np.ndarray, friction: float, pressure0: np.ndarray, traction0: np.ndarray,
                    tolerance: float, max_iterations: int, max_passes: int = 50) -> ContactIncrement:
    """Solve one increment for m candidate nodes, everything in the nodes' local frames
    (normal, t1, t2).

    compliance (3m, 3m) m/N; gap (m,) rigid gap along n (m); previous_tangential (m, 2) m,
    the nodes' tangential displacement after the previous increment; object_shift (m, 2)
    m, the object's tangential displacement at each node since then; friction μ (0 =
    frictionless: no tangential problem is solved); pressure0 (m,), traction0 (m, 2):
    warm start. tolerance: residual in m.
    """
    m = len(gap)
    idx = np.arange(m) * 3
    n_idx, t_idx = idx, np.column_stack([idx + 1, idx + 2]).ravel()
    d_nn = compliance[np.ix_(n_idx, n_idx)]
    d_nt = compliance[np.ix_(n_idx, t_idx)]
    d_tt = compliance[np.ix_(t_idx, t_idx)]
    rigid_t = -(np.asarray(previous_tangential, float) + np.asarray(object_shift, float)).ravel()
    lip_t = largest_eigenvalue(d_tt) if friction > 0 else 0.0
    p = np.maximum(np.asarray(pressure0, float), 0.0)
    q = np.asarray(traction0, float).ravel() if friction > 0 else np.zeros(2 * m)
    iterations, passes = 0, 0
    residual = np.inf
    for passes in range(1, max_passes + 1):
        p_new, k, res_n = solve_normal(d_nn, gap - d_nt @ q, p, tolerance, max_iterations)
        iterations += k
        if friction > 0:
            q_new, k, res_t = projected_gradient(d_tt, rigid_t - d_nt.T @ p_new, q,
                                                 lambda x, r=friction * p_new: project_discs(x, r),
                                                 tolerance, max_iterations, lip_t)
            iterations += k
            # how far each problem's data moved with the other's new solution (m)
            change = max(float(np.max(np.abs(d_nt @ (q_new - q)), initial=0.0)),
                         float(np.max(np.abs(d_nt.T @ (p_new - p)), initial=0.0)))
        else:
            q_new, res_t, change = q, 0.0, 0.0
        p, q = p_new, q_new
        residual = max(res_n, res_t, change)
        if change < tolerance:
            break
    else:
        raise ContactNotConverged(f"normal/tangential alternation: coupling still changing by {residual:.3g} m after "
                                  f"{max_passes} passes (tolerance {tolerance:.3g} m)")
    traction = q.reshape(m, 2)
    return ContactIncrement(p, traction, np.column_stack([-p, traction]), iterations, passes, residual)
