"""How well the runs determine each fitted parameter: standard errors (Gauss–Newton and
cluster-robust), resolution, variance inflation, and whether it is identifiable."""

from __future__ import annotations

import numpy as np

from twin.analysis.calibration_fit.evaluator import Evaluator
from twin.core.sensor import N_PINS


def jacobian(ev: Evaluator, values: dict[str, float], tips: np.ndarray) -> np.ndarray:
    """d(whitened data residuals)/d(parameter) for every fitted parameter (central differences:
    physics by simulation, 5 % of the range; camera 1e-4 of the range). A step that would
    leave the parameter's bounds stops at the bound (a point at a bound gets the one-sided
    difference): beyond them a candidate may not be simulated at all (a modulus below its least)."""
    space = ev.space
    p = space.settings.parameters

    def steps(n: str, h: float) -> tuple[float, float]:
        return min(values[n] + h, p[n].upper), max(values[n] - h, p[n].lower)

    cols = []
    physics_steps = {n: steps(n, 0.05 * space.range[n]) for n in space.physics}
    plus_minus = []
    for n in space.physics:
        for value in physics_steps[n]:
            plus_minus.append({m: values[m] for m in space.physics} | {n: value})
    sims = ev.simulate(plus_minus) if plus_minus else []
    r0 = ev.residuals(tips, values, priors=False)
    for n in space.fitted:
        if n in space.physics:
            i = space.physics.index(n)
            plus, minus = sims[2 * i], sims[2 * i + 1]
            high, low = physics_steps[n]
            # a side the physics cannot simulate: the one-sided difference from the point; both: no column
            rp, high = (r0, values[n]) if plus is None else (ev.residuals(plus, values, priors=False), high)
            rm, low = (r0, values[n]) if minus is None else (ev.residuals(minus, values, priors=False), low)
            cols.append((rp - rm) / (high - low) if high > low else np.zeros_like(r0))
        else:
            high, low = steps(n, 1e-4 * space.range[n])
            rp = ev.residuals(tips, {**values, n: high}, priors=False)
            rm = ev.residuals(tips, {**values, n: low}, priors=False)
            cols.append((rp - rm) / (high - low))
    return np.column_stack(cols) if cols else np.zeros((0, 0))


def robust_variances(jac: np.ndarray, r: np.ndarray, sample: np.ndarray, info: np.ndarray, s2: float) -> np.ndarray:
    """Per parameter, the larger of the Gauss–Newton variance s²·info⁻¹ and the
    cluster-robust (sandwich) one info⁻¹ M info⁻¹ · G/(G−1), with the meat M =
    Σ_s J_sᵀ r_s r_sᵀ J_s summed over the samples s (the clusters) and G the samples with
    pins. `info` is JᵀJ (plus the priors' information); units: the parameters' squared."""
    bread = np.linalg.pinv(info, rcond=1e-12)
    scores = np.zeros((int(sample.max(initial=-1)) + 1, jac.shape[1]))
    np.add.at(scores, sample, jac * r[:, None])  # J_sᵀ r_s per sample
    clusters = len(np.unique(sample))
    sandwich = bread @ (scores.T @ scores) @ bread * (clusters / max(clusters - 1, 1))
    return np.maximum(np.diag(sandwich), np.diag(bread) * s2)


def variance_inflation(scaled: np.ndarray) -> np.ndarray:
    """VIF_i = 1/(1 − R_i²) per column: R_i² is the share of column i (its length) that the
    best combination of the other columns reproduces (inf for a zero column or one inside
    their span)."""
    norms = np.linalg.norm(scaled, axis=0)
    unit = scaled / np.where(norms > 0, norms, 1.0)
    vif = np.full(scaled.shape[1], np.inf)
    for i in np.nonzero(norms > 1e-12 * max(norms.max(initial=0.0), 1e-300))[0]:
        others = np.delete(unit, i, axis=1)
        rest = (
            unit[:, i] - others @ np.linalg.lstsq(others, unit[:, i], rcond=None)[0] if others.shape[1] else unit[:, i]
        )
        vif[i] = 1.0 / max(float(rest @ rest), 1e-300)
    return vif


def uncertainty(ev: Evaluator, values: dict[str, float], tips: np.ndarray) -> dict:
    """Standard errors, resolution, variance inflation and identifiability per parameter.

    A fitted parameter is identifiable from these runs when all three hold (a "no" lists
    the ones that failed, and the parameter is left at its default):

    1. error: its data-only standard error is below `identifiable_fraction` of its bounds'
       range. The error is cluster-robust, samples as clusters (robust_variances): the
       254 residuals of one frame share its contact, tracking and model errors, so the
       Gauss–Newton s²(JᵀJ)⁻¹, which counts them as independent, is too small (friction
       from 4 taps: ±0.04 stated, 0.6 off). The sandwich lets a sample's residuals
       correlate freely; with few samples it is itself noisy (rank ≤ G − 1, so it can come
       out below the Gauss–Newton error), hence the larger of the two.
    2. resolution: its resolution (the change that moves the pins by the fit's pin RMS)
       is below its bounds' range, i.e. the whole range moves the pins by more than the
       residual. Errors shared across samples (a tracker's per-pin bias, the twin's model
       error) do not average out over frames, while the standard error of (1) falls as
       1/√samples: a parameter whose whole range is lost in the residual of every frame
       is not told apart from them by fitting more frames of the same kind.
    3. collinearity: its variance inflation 1/(1 − R²) is at most `max_variance_inflation`,
       R² the share of its Jacobian column that the other columns reproduce. Above it
       (default 100: under 10 % of the column is its own), its effect can be traded for
       the others', and a model error along the shared direction moves it √VIF times more
       than a parameter with a column of its own; the noise-based errors of (1) do not see
       a model error.
    """
    space = ev.space
    if not space.fitted:
        return {"parameters": {}, "singular_values": [], "reduced_chi2": None}
    jac = jacobian(ev, values, tips)
    r = ev.residuals(tips, values, priors=False)
    n_offsets = 2 * N_PINS if ev.fit_rest else 0
    dof = max(1, r.size - len(space.fitted) - n_offsets)
    s2 = float(np.sum(r**2) / dof)
    ranges = np.array([space.range[n] for n in space.fitted])
    scaled = jac * ranges  # per unit of the bounds' range
    singular = np.linalg.svd(scaled, compute_uv=False)
    vif = variance_inflation(scaled)
    info = jac.T @ jac
    p = space.settings.parameters
    prior = np.diag([1.0 / p[n].prior_std ** 2 if p[n].prior_std else 0.0 for n in space.fitted])
    data_var = robust_variances(jac, r, ev.row_sample, info, s2)
    post_var = robust_variances(jac, r, ev.row_sample, info + prior, s2)
    settings = space.settings
    fit_rms = np.sqrt(s2) * settings.noise_px * np.sqrt(2.0)  # px, Euclidean per pin
    out = {}
    for i, n in enumerate(space.fitted):
        column = float(np.linalg.norm(jac[:, i]))
        data_std = float(np.sqrt(max(data_var[i], 0.0))) if column > 1e-12 else float("inf")
        std = float(np.sqrt(max(post_var[i], 0.0))) if column > 1e-12 else float("inf")
        # how much the pin RMS (px, Euclidean per pin) changes per unit of the parameter
        # over the residuals the rest layout does not absorb, as the fit's RMS is (its dof): a figures-only
        # fit's one no-contact frame would otherwise dilute a column of 32 figures by √(286 / 32)
        per_unit = column * settings.noise_px * np.sqrt(2.0 / max(1, r.size - n_offsets))
        resolution = float(fit_rms / max(per_unit, 1e-300))
        why = []
        if not data_std < settings.identifiable_fraction * space.range[n]:
            why.append(
                f"standard error {data_std:.2g} ≥ {settings.identifiable_fraction:g} × the range {space.range[n]:g}"
            )
        if not resolution < space.range[n]:
            why.append(f"resolution {resolution:.2g} ≥ the range {space.range[n]:g}")
        if not vif[i] <= settings.max_variance_inflation:
            why.append(f"variance inflation {vif[i]:.3g} > {settings.max_variance_inflation:g}")
        out[n] = {
            "value": values[n],
            "default": space.defaults[n],
            "std": std,
            "data_std": data_std,
            "pin_rms_px_per_unit": float(per_unit),
            "bounds": [p[n].lower, p[n].upper],
            "identifiable": not why,
            "not_identifiable_because": why,
            "resolution": resolution,
            "variance_inflation": float(vif[i]),
            "at_bound": space.at_bound(n, values[n]),
        }
    return {
        "parameters": out,
        "singular_values": singular.tolist(),
        "reduced_chi2": s2,
        "condition_number": float(singular.max() / max(singular.min(), 1e-300)),
    }
