"""One quasi-static increment of frictional contact between the compliant dome and a
rigid object (Kalker's incremental theory: a normal and a tangential problem, solved together).

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

With an incompressible open half-space the two decouple; the sealed gel and the skin
membrane couple them (a tangential pull on the curved skin moves it normally), and then
alternating the two convex problems (Panagiotopoulos) converges slowly or not at all
(a contraction of 0.93 per pass with a 0.6 MPa membrane: the 288 taps failed at 50 passes). So the
frictional increment is solved jointly (`solve_coulomb`): semismooth Newton on Alart and
Curnier's functions, warm-started from the previous increment, which converges in a few
iterations (where its line search finds no descent at a kink of the merit function it takes
the full step anyway, up to FULL_STEPS times); where Newton stalls (far from the solution,
or nodes that barely touch) it is restarted from the warm start with smaller augmentation
parameters (AUGMENTATION_SCALES: the same roots; they rescue high friction over the skin
membrane); where that stalls too, the roots are followed up from lower friction
(continuation in μ, each stage warm-started from the last: over a skin shell on 1.0 mm
nodes at μ = 3, a press onto an edge in 3 s where the alternation took 51 s), and
where that stalls as well the alternation takes over, converging linearly
(up to ALTERNATION_PASSES), with Newton retried from its iterate every NEWTON_RETRY_PASSES
passes: near the solution Newton finishes what the alternation started (μ = 2–3 over the
skin membrane).
Where an increment has several solutions, the one returned is the one its path reaches:
at μ = 3 over that shell, paths of rising friction ending at the same increment of a
reversal found six, up to 81 µm of gap or slip apart at a node
(docs/measurements/finding-2026-12-05-friction-path).
The normal problem alone (frictionless, and each alternation pass) is solved by active
sets (exact Cholesky solves on the nodes in contact); the tangential one in a pass by
accelerated projected gradient with adaptive restart (Nesterov; O'Donoghue & Candès
2015). Residuals are in metres. Nothing passes silently: a problem that does not
converge raises `ContactNotConverged`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from twin.world.dome.compiled import compiled

#: Newton iterations of one frictional increment before it counts as not converged
NEWTON_ITERATIONS = 100
#: the augmentation parameter r as a multiple of a node's own stiffness: Newton's first
#: run, then its restarts where it stalls
AUGMENTATION_SCALES = (1.0, 0.3, 0.1)
#: continuation in friction where Newton stalls at μ: its first step, and the smallest it
#: halves to before the alternation takes over, as fractions of μ
FRICTION_FIRST_STEP = 1.0 / 6.0
FRICTION_SMALLEST_STEP = 1.0 / 64.0
#: what that step is multiplied by after a stage converges
FRICTION_STEP_GROWTH = 2.0
#: full Newton steps taken where the line search finds no descent, per Newton run
FULL_STEPS = 10
#: alternation passes that may take a stalled Newton iteration near the solution
ALTERNATION_PASSES = 5000
#: during the alternation, Newton is retried from its iterate every this many passes,
#: with at most this many iterations
NEWTON_RETRY_PASSES = 20
NEWTON_RETRY_ITERATIONS = 20


class ContactNotConverged(RuntimeError):
    """The contact problem did not reach its tolerance (message says which and how far)."""


@dataclass
class ContactIncrement:
    """The solution of one increment, for the candidate nodes.

    pressure (m,) N ≥ 0; traction (m, 2) N in (t1, t2); forces (m, 3) N on the dome in
    the nodes' local frames (n, t1, t2);
    iterations: Newton iterations and alternation passes (frictional), or active-set
    solves (frictionless); residual: final residual (m).
    """

    pressure: np.ndarray
    traction: np.ndarray
    forces: np.ndarray
    iterations: int
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


def projected_gradient(
    matrix: np.ndarray,
    linear: np.ndarray,
    start: np.ndarray,
    project: Callable[[np.ndarray], np.ndarray],
    tolerance: float,
    max_iterations: int,
    lipschitz: float | None = None,
) -> tuple[np.ndarray, int, float]:
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
    raise ContactNotConverged(
        f"projected gradient: residual {residual:.3g} m after {max_iterations} iterations (tolerance {tolerance:.3g} m)"
    )


def solve_normal(
    matrix: np.ndarray, linear: np.ndarray, start: np.ndarray, tolerance: float, max_iterations: int
) -> tuple[np.ndarray, int, float]:
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


def friction_bound(pressure: np.ndarray, friction: float, adhesion: np.ndarray | None = None) -> np.ndarray:
    """(m,) N: the most tangential force each node takes before it slips, at its normal
    force `pressure` (m,) N: μ p, plus with `adhesion` (m, 2) N an adhesive part s (1 −
    e^(−p/c)) that grows from nothing to the node's strength s (its shear strength times
    its area) as p passes the ramp c (the same pressure's worth of force), so that a
    node in contact slips at shear stress μ·pressure + τ once pressed past the ramp
    (`_bound_at`, the one statement of the law)."""
    return _bounds(
        np.maximum(np.asarray(pressure, dtype=float), 0.0), float(friction), _strengths(adhesion, len(pressure))
    )


def _strengths(adhesion: np.ndarray | None, m: int) -> np.ndarray:
    """(m, 2) N, contiguous: `adhesion`, or none (zeros) for Coulomb's law alone."""
    return np.zeros((m, 2)) if adhesion is None else np.ascontiguousarray(adhesion, dtype=float)


@compiled
def _bound_at(pressed: float, friction: float, strength: float, ramp: float) -> tuple[float, float]:
    """The friction bound (N) of a node pressed by `pressed` ≥ 0 N and its slope d/dp:
    μ p, plus s (1 − e^(−p/c)) for a node of strength s > 0 (N) and ramp c (N) in contact."""
    radius, slope = friction * pressed, friction
    if strength > 0.0 and pressed > 0.0:
        exponent = -pressed / ramp
        radius -= strength * math.expm1(exponent)
        slope += strength / ramp * math.exp(exponent)
    return radius, slope


@compiled
def _bounds(pressure: np.ndarray, friction: float, strengths: np.ndarray) -> np.ndarray:
    """(m,) N: `_bound_at` of each node's pressure ≥ 0 (m,) N and strengths (m, 2) N."""
    radius = np.empty(len(pressure))
    for i in range(len(pressure)):
        radius[i] = _bound_at(pressure[i], friction, strengths[i, 0], strengths[i, 1])[0]
    return radius


def project_discs(q: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Project stacked 2-vectors (flattened, (2m,)) onto discs |q_i| ≤ radius_i."""
    pairs = q.reshape(-1, 2)
    norm = np.sqrt(np.einsum("ij,ij->i", pairs, pairs))
    scale = np.where(norm > radius, radius / np.maximum(norm, 1e-300), 1.0)
    return (pairs * scale[:, None]).ravel()


# ---------------------------------------------------------------- compiled Newton kernel
# Semismooth Newton for `solve_coulomb`, compiled (`twin.world.dome.compiled`). Its
# per-iteration work is many small vector operations and one LU factorisation; in numpy
# the former cost more than the latter.


@compiled
def _alart_curnier(
    matrix: np.ndarray,
    offset: np.ndarray,
    friction: float,
    adhesion: np.ndarray,
    f: np.ndarray,
    r_n: np.ndarray,
    r_t: np.ndarray,
    phi: np.ndarray,
    contact: np.ndarray,
    slip: np.ndarray,
    z: np.ndarray,
    size: np.ndarray,
    radius: np.ndarray,
    slope: np.ndarray,
) -> None:
    """Alart & Curnier's functions at f, in place: phi (3m,) = Φ/r (m) per node (n, t1,
    t2); contact (m,): p − r h > 0; slip (m,): the tangential predictor z (m, 2) = q − r v
    lies outside the friction disc, whose radius (m,) is `friction_bound` of max(0, p − r h)
    (adhesion (m, 2): each node's adhesive strength and ramp, N), and slope (m,) its
    derivative there; size (m,) |z|."""
    w = matrix @ f + offset
    for i in range(len(r_n)):
        a = 3 * i
        pressed = f[a] - r_n[i] * w[a]
        augmented = max(0.0, pressed)
        contact[i] = pressed > 0.0
        z0 = f[a + 1] - r_t[i] * w[a + 1]
        z1 = f[a + 2] - r_t[i] * w[a + 2]
        z[i, 0], z[i, 1] = z0, z1
        size[i] = math.sqrt(z0 * z0 + z1 * z1)
        radius[i], slope[i] = _bound_at(augmented, friction, adhesion[i, 0], adhesion[i, 1])
        slip[i] = size[i] > radius[i]
        scale = radius[i] / max(size[i], 1e-300) if slip[i] else 1.0
        phi[a] = (f[a] - augmented) / r_n[i]
        phi[a + 1] = (f[a + 1] - scale * z0) / r_t[i]
        phi[a + 2] = (f[a + 2] - scale * z1) / r_t[i]


@compiled
def _alart_curnier_residual(
    matrix: np.ndarray,
    offset: np.ndarray,
    friction: float,
    adhesion: np.ndarray,
    f: np.ndarray,
    r_n: np.ndarray,
    r_t: np.ndarray,
) -> np.ndarray:
    """(3m,) m: Φ/r at f (`_alart_curnier`)."""
    m = len(r_n)
    phi = np.empty(3 * m)
    _alart_curnier(
        matrix,
        offset,
        friction,
        adhesion,
        f,
        r_n,
        r_t,
        phi,
        np.zeros(m, np.bool_),
        np.zeros(m, np.bool_),
        np.empty((m, 2)),
        np.empty(m),
        np.empty(m),
        np.empty(m),
    )
    return phi


@compiled
def _newton_step(
    matrix: np.ndarray,
    slope: np.ndarray,
    f: np.ndarray,
    phi: np.ndarray,
    contact: np.ndarray,
    slip: np.ndarray,
    z: np.ndarray,
    size: np.ndarray,
    radius: np.ndarray,
    r_n: np.ndarray,
    r_t: np.ndarray,
    step: np.ndarray,
) -> bool:
    """Newton's step for Φ/r at f, in place (step (3m,)); False where the system is singular.

    The full Jacobian's step, solved condensed. Rows out of contact (Φn/r = p/r) and
    tangential rows slipping with no friction bound (Φt/r = q/r) are explicit: their step
    is −f. A node sliding in contact is turned into its slip direction ẑ and the direction
    ẑ⊥ across it, where its rows separate: along ẑ, Φt = q − ρ ẑ with its own normal row
    (h, where pressed) gives dq∥ = μ' dp + μ' Φn − Φt∥ (μ' the friction bound's slope,
    `_alart_curnier`'s; μ under Coulomb's law alone), so dq∥ is eliminated; across it,
    (1 − ρ/|z|) dq⊥ + (ρ/|z|) r_t (M df)⊥ = −Φt⊥. What is factorised is the normal step of
    each node in contact, both tangential steps of each stuck node and the ⊥ step of each
    sliding one: 159 unknowns on average on the sweep probe's slides, against 225 for the
    full system (an LU costs the cube)."""
    n = len(f)
    m = n // 3
    # unknown c moves the step at col_pos[c, :col_len[c]] by col_coef × x[c]; equation r
    # combines the matrix's rows row_pos[r, :row_len[r]] (and row_diag[r] × x[r])
    col_pos, col_coef, col_len = np.zeros((n, 3), np.int64), np.zeros((n, 3)), np.zeros(n, np.int64)
    row_pos, row_coef, row_len = np.zeros((n, 2), np.int64), np.zeros((n, 2)), np.zeros(n, np.int64)
    row_diag, rhs = np.zeros(n), np.empty(n)
    step[:] = 0.0
    k = 0
    for i in range(m):
        a = 3 * i
        pressure_unknown = -1
        if contact[i]:  # Φn/r = h: a row of the matrix
            pressure_unknown = k
            col_pos[k, 0], col_coef[k, 0], col_len[k] = a, 1.0, 1
            row_pos[k, 0], row_coef[k, 0], row_len[k] = a, 1.0, 1
            rhs[k] = -phi[a]
            k += 1
        else:
            step[a] = -f[a]
        if not slip[i]:  # stuck: Φt/r = v, rows of the matrix
            for axis in range(a + 1, a + 3):
                col_pos[k, 0], col_coef[k, 0], col_len[k] = axis, 1.0, 1
                row_pos[k, 0], row_coef[k, 0], row_len[k] = axis, 1.0, 1
                rhs[k] = -phi[axis]
                k += 1
        elif radius[i] <= 0.0:  # no friction bound: Φt/r = q/r
            step[a + 1], step[a + 2] = -f[a + 1], -f[a + 2]
        else:  # sliding, so in contact
            along0, along1 = z[i, 0] / size[i], z[i, 1] / size[i]
            across0, across1 = -along1, along0
            ratio = radius[i] / size[i]
            parallel = slope[i] * r_n[i] * phi[a] - r_t[i] * (along0 * phi[a + 1] + along1 * phi[a + 2])
            step[a + 1], step[a + 2] = along0 * parallel, along1 * parallel
            col_pos[pressure_unknown, 1], col_coef[pressure_unknown, 1] = a + 1, slope[i] * along0
            col_pos[pressure_unknown, 2], col_coef[pressure_unknown, 2] = a + 2, slope[i] * along1
            col_len[pressure_unknown] = 3
            col_pos[k, 0], col_coef[k, 0], col_pos[k, 1], col_coef[k, 1], col_len[k] = a + 1, across0, a + 2, across1, 2
            row_pos[k, 0], row_coef[k, 0] = a + 1, ratio * r_t[i] * across0
            row_pos[k, 1], row_coef[k, 1], row_len[k] = a + 2, ratio * r_t[i] * across1, 2
            row_diag[k] = 1.0 - ratio
            rhs[k] = -r_t[i] * (across0 * phi[a + 1] + across1 * phi[a + 2])
            k += 1
    system = np.empty((k, k))
    line = np.empty(n)
    for r in range(k):
        line[:] = row_coef[r, 0] * matrix[row_pos[r, 0]]
        if row_len[r] == 2:
            line += row_coef[r, 1] * matrix[row_pos[r, 1]]
        rhs[r] -= line @ step  # the explicit and eliminated parts of the step
        for c in range(k):
            total = col_coef[c, 0] * line[col_pos[c, 0]]
            for g in range(1, col_len[c]):
                total += col_coef[c, g] * line[col_pos[c, g]]
            system[r, c] = total
        system[r, r] += row_diag[r]
    try:
        x = np.linalg.solve(system, rhs[:k])
    except Exception:  # a singular Jacobian
        return False
    if not np.all(np.isfinite(x)):
        return False
    for c in range(k):
        for g in range(col_len[c]):
            step[col_pos[c, g]] += col_coef[c, g] * x[c]
    return True


@compiled
def _newton(
    matrix: np.ndarray,
    offset: np.ndarray,
    friction: float,
    adhesion: np.ndarray,
    start: np.ndarray,
    r_n: np.ndarray,
    r_t: np.ndarray,
    budget: int,
    tolerance: float,
    full_steps: int,
):
    """Semismooth Newton on `_alart_curnier`'s Φ/r from `start` (not changed), with a
    backtracking line search on |Φ|² (where it finds no descent, the full step, up to
    `full_steps` times), for at most `budget` iterations; each step `_newton_step`'s.
    Returns the best iterate: (f (3m,), iterations, residual (m), contact (m,) bool at f)."""
    n = len(offset)
    m = n // 3
    f = start.copy()
    phi, contact, slip = np.empty(n), np.zeros(m, np.bool_), np.zeros(m, np.bool_)
    z, size, radius, slope = np.empty((m, 2)), np.empty(m), np.empty(m), np.empty(m)
    phi_trial, contact_trial, slip_trial = np.empty(n), np.zeros(m, np.bool_), np.zeros(m, np.bool_)
    z_trial, size_trial, radius_trial, slope_trial = np.empty((m, 2)), np.empty(m), np.empty(m), np.empty(m)
    _alart_curnier(matrix, offset, friction, adhesion, f, r_n, r_t, phi, contact, slip, z, size, radius, slope)
    best_residual, best_f, best_contact = np.inf, f.copy(), contact.copy()
    forced = full_steps
    step = np.empty(n)
    trial = f
    iteration = 0
    for iteration in range(budget + 1):
        residual = np.max(np.abs(phi)) if n else 0.0
        if residual < best_residual:
            best_residual = residual
            best_f[:] = f
            best_contact[:] = contact
        if residual < tolerance or iteration == budget:
            break
        if not _newton_step(matrix, slope, f, phi, contact, slip, z, size, radius, r_n, r_t, step):
            break
        merit = phi @ phi
        length, descent = 1.0, False
        while length >= 1e-3 and not descent:
            trial = f + length * step
            _alart_curnier(
                matrix,
                offset,
                friction,
                adhesion,
                trial,
                r_n,
                r_t,
                phi_trial,
                contact_trial,
                slip_trial,
                z_trial,
                size_trial,
                radius_trial,
                slope_trial,
            )
            descent = phi_trial @ phi_trial <= (1.0 - 1e-4 * length) * merit
            if not descent:
                length *= 0.5
        if not descent:
            # no descent along Newton's direction (a kink of Φ): the full step anyway, a few
            # times (a watchdog: semismooth Newton converges locally where |Φ|² rises)
            if forced == 0:
                break
            forced -= 1
            trial = f + step
            _alart_curnier(
                matrix,
                offset,
                friction,
                adhesion,
                trial,
                r_n,
                r_t,
                phi_trial,
                contact_trial,
                slip_trial,
                z_trial,
                size_trial,
                radius_trial,
                slope_trial,
            )
        f = trial
        phi, phi_trial = phi_trial, phi
        contact, contact_trial = contact_trial, contact
        slip, slip_trial = slip_trial, slip
        z, z_trial = z_trial, z
        size, size_trial = size_trial, size
        radius, radius_trial = radius_trial, radius
        slope, slope_trial = slope_trial, slope
    return best_f, iteration, best_residual, best_contact


#: S's diagonal per node (`unknowns_matrix`): the force on the dome of each unknown (p, q1, q2)
UNKNOWN_SIGNS = np.array([-1.0, 1.0, 1.0])


def unknowns_matrix(compliance: np.ndarray) -> np.ndarray:
    """(3m, 3m) m/N: M = S D S, S = diag(−1, 1, 1) per node (UNKNOWN_SIGNS), from the
    candidates' compliance D (3m, 3m) m/N in their local frames (normal, t1, t2): the
    matrix of `solve_increment`'s unknowns f = (p, q1, q2), whose force on the dome is
    (−p, q1, q2). So the gap after deformation and the slip are h = (M f)_n + gap,
    v = (M f)_t + rigid_t; M is symmetric positive semi-definite as D is. Only the
    normal–tangential couplings change sign: the normal block is D's."""
    signs = np.tile(UNKNOWN_SIGNS, len(compliance) // 3)
    return signs[:, None] * np.asarray(compliance, dtype=float) * signs[None, :]


def solve_increment(
    matrix: np.ndarray,
    gap: np.ndarray,
    previous_tangential: np.ndarray,
    object_shift: np.ndarray,
    friction: float,
    pressure0: np.ndarray,
    traction0: np.ndarray,
    tolerance: float,
    max_iterations: int,
    adhesion: np.ndarray | None = None,
    anisotropy: np.ndarray | None = None,
) -> ContactIncrement:
    """Solve one increment for m candidate nodes, everything in the nodes' local frames
    (normal, t1, t2).

    matrix (3m, 3m) m/N: `unknowns_matrix` of the candidates' compliance (built once for
    as long as the candidates and their frames stay the same); gap (m,) rigid gap along n
    (m); previous_tangential (m, 2) m, the nodes' tangential displacement after the
    previous increment; object_shift (m, 2) m, the object's tangential displacement at
    each node since then; friction μ and adhesion (m, 2) N, each node's adhesive strength
    and ramp (`friction_bound`; None = none; with μ = 0 and none, frictionless: only the
    normal problem is solved); pressure0 (m,), traction0 (m, 2): warm start. tolerance:
    residual in m. anisotropy (m, 2, 2), symmetric positive definite, or None: each node's
    friction disc stretched into the ellipse {S q : |q| ≤ bound}, S its matrix in (t1, t2).
    Solved as the disc problem in q = S⁻¹ traction, whose work-conjugate slip is S times the
    slip: the compliance becomes T W T and the offset T o, T = diag(1, S) per node, so the
    slip stays normal to the ellipse (maximal dissipation).
    """
    m = len(gap)
    n_idx = np.arange(m) * 3
    if friction == 0 and adhesion is None:
        p, solves, residual = solve_normal(
            matrix[np.ix_(n_idx, n_idx)],
            np.asarray(gap, float),
            np.maximum(np.asarray(pressure0, float), 0.0),
            tolerance,
            max_iterations,
        )
        return ContactIncrement(p, np.zeros((m, 2)), np.column_stack([-p, np.zeros((m, 2))]), solves, residual)
    offset = np.column_stack([gap, -(np.asarray(previous_tangential, float) + np.asarray(object_shift, float))])
    start = np.column_stack([np.maximum(np.asarray(pressure0, float), 0.0), np.asarray(traction0, float)])
    # only the nodes whose ellipse is not the disc (those on an edge's round) are stretched
    stretched = np.zeros(0, int) if anisotropy is None else np.flatnonzero(np.any(anisotropy != np.eye(2), axis=(1, 2)))
    if len(stretched):
        ellipse = anisotropy[stretched]
        dofs = (3 * stretched[:, None] + np.array([1, 2])).ravel()  # their tangential unknowns
        matrix = np.array(matrix)  # the caller keeps its own
        rows = matrix[dofs].reshape(len(stretched), 2, -1)
        matrix[dofs] = np.einsum("kab,kbn->kan", ellipse, rows).reshape(len(dofs), -1)
        columns = matrix[:, dofs].reshape(-1, len(stretched), 2)
        matrix[:, dofs] = np.einsum("nkb,kba->nka", columns, ellipse).reshape(-1, len(dofs))
        offset[stretched, 1:] = np.einsum("kab,kb->ka", ellipse, offset[stretched, 1:])
        start[stretched, 1:] = np.linalg.solve(ellipse, start[stretched, 1:, None])[:, :, 0]
    forces, iterations, residual = solve_coulomb(
        matrix, offset.ravel(), friction, start.ravel(), tolerance, max_iterations, adhesion
    )
    f = forces.reshape(m, 3)
    if len(stretched):
        f[stretched, 1:] = np.einsum("kab,kb->ka", ellipse, f[stretched, 1:])
    return ContactIncrement(f[:, 0], f[:, 1:], np.column_stack([-f[:, 0], f[:, 1:]]), iterations, residual)


def alternation_pass(
    matrix: np.ndarray,
    offset: np.ndarray,
    friction: float,
    f: np.ndarray,
    tolerance: float,
    max_iterations: int,
    lipschitz: float | None = None,
    adhesion: np.ndarray | None = None,
) -> np.ndarray:
    """One pass of Panagiotopoulos' alternation on `solve_coulomb`'s problem: the normal
    forces for the current tangential ones (exact, `solve_normal`), then the tangential
    forces within `friction_bound` of those (`projected_gradient`; `lipschitz`: the
    tangential block's largest eigenvalue, if known). Returns the new f (3m,) N."""
    m = len(offset) // 3
    n_idx = np.arange(m) * 3
    t_idx = np.column_stack([n_idx + 1, n_idx + 2]).ravel()
    p, _, _ = solve_normal(
        matrix[np.ix_(n_idx, n_idx)],
        offset[n_idx] + matrix[np.ix_(n_idx, t_idx)] @ f[t_idx],
        np.maximum(f[n_idx], 0.0),
        tolerance,
        max_iterations,
    )
    d_tt = matrix[np.ix_(t_idx, t_idx)]
    radius = friction_bound(p, friction, adhesion)  # the same for every projection of the pass
    q, _, _ = projected_gradient(
        d_tt,
        offset[t_idx] + matrix[np.ix_(t_idx, n_idx)] @ p,
        f[t_idx],
        lambda x: project_discs(x, radius),
        tolerance,
        max_iterations,
        lipschitz,
    )
    out = np.empty_like(f)
    out[n_idx], out[t_idx] = p, q
    return out


def own_stiffness(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(m,), (m,) N/m: each node's own normal and tangential stiffness, the inverse of its
    diagonal entries of `solve_coulomb`'s matrix (tangential: of their mean), which
    `solve_coulomb` takes as the augmentation parameters r_n, r_t."""
    diagonal = np.diag(matrix)
    return 1.0 / diagonal[0::3], 1.0 / (0.5 * (diagonal[1::3] + diagonal[2::3]))


@dataclass(frozen=True)
class NewtonRuns:
    """`solve_coulomb`'s problem, for semismooth Newton runs on it at any friction: matrix
    (3m, 3m) m/N and offset (3m,) m as there, strengths (m, 2) N (`_strengths`), the
    residual's tolerance (m) and each run's iteration budget. The augmentation parameters
    are multiples of each node's own stiffness (`own_stiffness`)."""

    matrix: np.ndarray
    offset: np.ndarray
    strengths: np.ndarray
    tolerance: float
    budget: int

    @classmethod
    def of(
        cls,
        matrix: np.ndarray,
        offset: np.ndarray,
        tolerance: float,
        max_iterations: int,
        adhesion: np.ndarray | None = None,
    ) -> NewtonRuns:
        """`solve_coulomb`'s problem from its arguments: each run's budget is
        max_iterations, at most NEWTON_ITERATIONS."""
        offset = np.ascontiguousarray(offset, dtype=float)
        return cls(
            np.ascontiguousarray(matrix, dtype=float),
            offset,
            _strengths(adhesion, len(offset) // 3),
            tolerance,
            min(max_iterations, NEWTON_ITERATIONS),
        )

    @cached_property
    def stiffness(self) -> tuple[np.ndarray, np.ndarray]:
        """(m,), (m,) N/m: `own_stiffness` of the matrix."""
        return own_stiffness(self.matrix)

    def newton(
        self, start: np.ndarray, friction: float, scale: float = 1.0, budget: int | None = None
    ) -> tuple[np.ndarray, int, float]:
        """`_newton` from `start` at `friction` with r = scale × own stiffness, for `budget`
        iterations (None: the problem's); returns (f, iterations, residual) at
        convergence, else the best iterate where it stalls or runs out of iterations."""
        r_n, r_t = self.stiffness
        f, iterations, residual, contact = _newton(
            self.matrix,
            self.offset,
            friction,
            self.strengths,
            np.ascontiguousarray(start, dtype=float),
            scale * r_n,
            scale * r_t,
            self.budget if budget is None else budget,
            self.tolerance,
            FULL_STEPS,
        )
        if residual < self.tolerance:
            f.reshape(-1, 3)[~contact] = 0.0  # free nodes carry nothing (not round-off)
        return f, iterations, residual

    def from_start(self, start: np.ndarray, friction: float) -> tuple[np.ndarray, int, float]:
        """Newton from `start` at each of AUGMENTATION_SCALES until one converges: r = a
        node's own stiffness first, then (where Newton stalls with it: at high friction the
        tangential predictor z = q − r v overshoots the disc) smaller r, the same roots with
        a gentler predictor. Returns (f, iterations, residual): the roots, or where every
        run stalls the best iterate of all."""
        done, best, residual = 0, start, np.inf
        for scale in AUGMENTATION_SCALES:
            attempt, iterations, attempt_residual = self.newton(start, friction, scale)
            done += iterations
            if attempt_residual < residual:
                best, residual = attempt, attempt_residual
            if residual < self.tolerance:
                break
        return best, done, residual

    def residual(self, f: np.ndarray, friction: float) -> float:
        """The largest Alart–Curnier residual (m) of f at `friction`, r = own stiffness."""
        phi = _alart_curnier_residual(self.matrix, self.offset, friction, self.strengths, f, *self.stiffness)
        return float(np.max(np.abs(phi), initial=0.0))


def rising_friction(
    problem: NewtonRuns,
    start: np.ndarray,
    friction: float,
    first_step: float = FRICTION_FIRST_STEP,
    growth: float = FRICTION_STEP_GROWTH,
) -> tuple[np.ndarray | None, int, float]:
    """The roots at `friction` (> 0) followed up from lower friction: Newton
    (`NewtonRuns.from_start`) at first_step × μ from `start`, then each stage from the
    last one's roots; the step × `growth` after a stage that converges, halved after one
    that stalls, until μ is reached or the step falls below FRICTION_SMALLEST_STEP × μ.
    Returns (f at μ or None, Newton iterations, the last run's residual (m))."""
    path, reached, rise, done, residual = start, 0.0, friction * first_step, 0, np.inf
    while rise >= friction * FRICTION_SMALLEST_STEP:
        target = min(friction, reached + rise)
        attempt, iterations, residual = problem.from_start(path, target)
        done += iterations
        if residual >= problem.tolerance:
            rise *= 0.5
            continue
        path, reached = attempt, target
        if reached >= friction:
            return attempt, done, residual
        rise *= growth
    return None, done, residual


def solve_coulomb(
    matrix: np.ndarray,
    offset: np.ndarray,
    friction: float,
    start: np.ndarray,
    tolerance: float,
    max_iterations: int,
    adhesion: np.ndarray | None = None,
) -> tuple[np.ndarray, int, float]:
    """Signorini contact with Coulomb friction, normal and tangential solved together.

    matrix (3m, 3m) m/N, offset (3m,) m: per node (n, t1, t2), the gap after deformation
    h = (M f + offset)_n and the slip v = (M f + offset)_t for unknowns f = (p, q) (N).
    Solves p ≥ 0, h ≥ 0, p·h = 0; |q| ≤ g(p) with v = 0 where |q| < g(p) and v opposing
    q where |q| = g(p), g = `friction_bound` (μ p, with `adhesion` (m, 2) N its adhesive
    part), as the roots of Alart & Curnier's functions (1991)
    Φn = p − max(0, p − r h), Φt = q − proj(q − r v, disc of radius g(max(0, p − r h)))
    (r = a node's own stiffness), by semismooth Newton with a backtracking line search on
    |Φ|² (where it finds no descent, the full step, up to FULL_STEPS times); where that
    stalls, by Newton again from `start` with r scaled down (AUGMENTATION_SCALES); where
    that stalls too, by Newton along a path of rising friction (FRICTION_FIRST_STEP of μ
    first, each stage from the last one's roots at each of those r, the step halved
    where a stage stalls, down to FRICTION_SMALLEST_STEP, and grown by FRICTION_STEP_GROWTH
    where it converges: `rising_friction`);
    where that stalls as well, by `alternation_pass`, with Newton retried from its iterate every
    NEWTON_RETRY_PASSES passes, until the residual is below `tolerance`. The residual,
    Φ/r, is in metres: the largest gap, penetration or slip left over. max_iterations
    bounds each projected gradient, and Newton to NEWTON_ITERATIONS per run. Returns (f,
    Newton iterations + passes, residual); raises ContactNotConverged.
    """
    problem = NewtonRuns.of(matrix, offset, tolerance, max_iterations, adhesion)
    matrix, offset, friction = problem.matrix, problem.offset, float(friction)
    f, done, residual = problem.from_start(start, friction)
    if residual < tolerance:
        return f, done, residual
    if friction > 0.0:
        roots, iterations, residual = rising_friction(problem, start, friction)
        done += iterations
        if roots is not None:
            return roots, done, residual
    # Newton stalled at every scale and along the friction path (at a kink, a singular
    # Jacobian, cycling between contact sets at nodes that barely touch): the
    # normal/tangential alternation, linear but steady, brings the iterate near the
    # solution, and Newton, retried from there every NEWTON_RETRY_PASSES passes, finishes
    # it. The alternation's own stop is the residual, not the change per pass: at a
    # contraction of 0.93 a change below the tolerance still leaves 14 times as much to go.
    tangential = np.flatnonzero(np.arange(len(offset)) % 3)  # every node's t1, t2
    lipschitz = largest_eigenvalue(matrix[np.ix_(tangential, tangential)])  # the same for every pass
    retry_budget = min(problem.budget, NEWTON_RETRY_ITERATIONS)
    for passes in range(1, ALTERNATION_PASSES + 1):
        moved = alternation_pass(matrix, offset, friction, f, 0.1 * tolerance, max_iterations, lipschitz, adhesion)
        change = float(np.max(np.abs(matrix @ (moved - f)), initial=0.0))
        f = moved
        if change < tolerance or passes % NEWTON_RETRY_PASSES == 0:
            # Newton measures the residual first and returns at once where it is met
            attempt, iterations, attempt_residual = problem.newton(f, friction, budget=retry_budget)
            done += iterations
            if attempt_residual < tolerance:
                return attempt, done + passes, attempt_residual
    residual = problem.residual(f, friction)
    raise ContactNotConverged(
        f"semismooth Newton stalled after {done} iterations and the normal/tangential "
        f"alternation leaves a residual of {residual:.3g} m (its last pass changed "
        f"{change:.3g} m) after {ALTERNATION_PASSES} passes (tolerance {tolerance:.3g} m)"
    )
