"""The paper's perception: pins → PCA → modified spherical coordinates → three GPs → (θ̂, l̂).

Aquilina, Barton & Lepora (ICRA 2019), §II-B. Used unchanged for simulated and real frames.

Data vector (paper Eq. 1). One frame's 127 pins (px, canonical order) are flattened
*interleaved*: z = (u1, v1, u2, v2, …, u127, v127) — exactly `pins.reshape(254)` of a
(127, 2) array. Every function here uses that layout (`pins_to_vectors`).

Pipeline (method "pca"):

1. PCA of the tap training matrix D (N × 254): p = E3ᵀ (z − z̄), 3 components (SVD; each
   eigenvector's sign is fixed so its largest-magnitude loading is positive).
2. q = p − p0 with p0 the projection of the reference no-contact training frame (the
   first one: see "No contact" below).
   θ_PC23 = atan2(q3, q2) about that origin. ρ and φ are taken about an origin shifted in
   the PC2–PC3 plane by c(θ_PC23) = s(θ_PC23)·(cos θ_PC23, sin θ_PC23) (paper: "shifted in
   the PC2-PC3 plane for each θ_PC23 so that the same lateral positions in the middle of
   the collected range for different depths have the same φ"):
   ρ² = q1² + r², φ = atan2(r, q1), r = ‖(q2, q3) − c‖.
   `DepthShift` fits s per orientation label from the mid-range lateral label l_mid (the
   label nearest the middle of [min l, max l]): with t = radial coordinate of (q2, q3)
   along the points' mean PC2–PC3 direction, the least-squares line t = s + k·q1 through
   the points of all depths gives s, the shift that puts them on one ray from the new
   origin (equal φ). s is interpolated periodically (linear) over θ_PC23 at prediction
   time. With a single depth s ≡ 0 (the paper's unshifted origin). Only contact frames
   enter the fit. `depth_shift_mode`: "per_orientation" (the above, the paper's; default),
   "pooled" (one s from one line through the mid-range points of all orientations — an
   option for data whose per-orientation fits scatter, as on a dome model that is not
   rotation-invariant) or "none" (s ≡ 0).
3. Pruning (paper §"Training Data Pruning"): the no-contact frames are removed from both
   sets (the paper: "we remove them from the training set"); then sensitivity S = ‖Δp‖/|Δw| to the neighbouring
   labels (lateral: along l within each (θ, depth); orientation: circularly along θ within
   each (l, depth)); a point's S is the mean over its neighbours. Tukey rule on S⁻¹:
   drop S⁻¹ > Q3 + 1.5·IQR (S = 0 → S⁻¹ = ∞ → dropped), judged among the contact frames
   (S itself is computed with all neighbours, no-contact ones included). The lateral set
   keeps at least 90 % of the contact frames (the ones with the smallest S⁻¹). The orientation set trains GP_cos and GP_sin,
   the lateral set GP_lat.
4. GP inputs x = (ρ / ρ_scale, cos θ_PC23, sin θ_PC23, φ): θ_PC23 enters through its cosine
   and sine so the ±π wrap is continuous; ρ is divided by the RMS training ρ (px); φ in rad.
   GP_cos and GP_sin take all four; GP_lat takes (cos θ_PC23, sin θ_PC23, φ), not ρ
   (`PCA_GP_INPUTS`). φ is the coordinate that step 2 makes the same at every depth for
   a lateral position; ρ grows with depth (about as depth^1.5 on the twin's domes). With
   ρ among its inputs the lateral GP can prefer it, since at the training depths alone
   ρ separates the lateral positions finely, and then it reads a tap between the training
   depths as a tap at another lateral position: the compliant dome's held-out taps (2.5
   and 3.5 mm deep against 2 and 4) read 2.5–5.8 mm wrong with the sensor's centre 1–5 mm
   on the object, 0.15–0.27 mm without ρ (measured; docs/paper.md, "Perception: the lateral GP
   reads φ, not ρ"). The paper
   gives all three GPs v; it does not say how its GPs weighed ρ.
   Kernel ConstantKernel · Matern(ν = 5/2, one length scale per input (ARD)) + WhiteKernel.
   Constant mean: `normalize_y=True` (targets centred on their training mean and scaled to
   unit variance, undone on prediction). Hyperparameters maximise the log marginal
   likelihood with bounded L-BFGS-B (sklearn), restarts seeded from the passed-in Generator.
   θ̂ = atan2(f̄_sin, f̄_cos) (deg), l̂ = f̄_lat (mm).

No contact. The paper's l = 9.9 mm taps do not touch anything; on the twin the 40 mm dome
pressed 4 mm deep there does touch the edge (pins move ≈ 5 px). So "no contact" is what the
pins show, not the label: the frames labelled l ≥ `no_contact_lateral_mm` are only the
candidates for the reference frame, and a frame is no-contact when all its pins lie within
`no_contact_px` (0.3 px ≈ 3× the tracker's error on twin frames) of the reference. The
touching l = 9.9 frames then train the GPs with their labels like any contact frame, and
the contact threshold of `predict` (3 × the RMS ‖q‖ of the no-contact frames, at least
half the smallest ‖q‖ of a kept contact frame) is no longer inflated by them — with the
label rule it exceeded every 2 mm tap, so half of all predictions came out "no contact".

Baseline (method "baseline", paper: "raw sensor measurements … one hyperparameter for all
the pin positions"): the same three GPs on x = (z − z_ref) / scale with an isotropic Matern
5/2 length scale; same pruned training sets.

Resolution: a model stores the camera resolution of its training frames. Pins from another
resolution are rescaled to it by r = W_model / W_input, u' = (u + 0.5)·r − 0.5 (pixel
centres at integer coordinates, as in `CameraModel`; the intrinsics scale with the image size
at a fixed field of view, so the same aspect ratio is assumed). Models trained on sim frames
apply to real frames and back because both use the same pin order and pixel units.

`synthetic_tap_pins` is a smooth analytic stand-in for the dome (tests and benchmarks), not
the simulation's physics.
"""

from __future__ import annotations

import io
import json
import math
import platform
import time
import warnings
import zipfile
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from importlib.metadata import version
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import sklearn
from pydantic import Field
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Kernel, Matern, WhiteKernel

from twin.core.errors import UserError
from twin.core.files import replace_file
from twin.core.poses import wrap_deg
from twin.core.sensor import N_PINS, CameraModel
from twin.core.validation import StrictModel, bounded, bounded_list, validate_mapping
from twin.sensing.tracker import PinTracker, detect_pins, reference_pins_from_frame, render_pins_frame

FORMAT = "tactip-twin/perception-model"
FORMAT_VERSION = 2
N_DIMS = 2 * N_PINS
GP_NAMES = ("cos", "sin", "lat")
#: the columns of x = (ρ / ρ_scale, cos θ_PC23, sin θ_PC23, φ) each GP of method "pca" takes
#: (module doc, step 4); the baseline's GPs take every pin
PCA_GP_INPUTS: dict[str, tuple[int, ...]] = {"cos": (0, 1, 2, 3), "sin": (0, 1, 2, 3), "lat": (1, 2, 3)}
NO_CONTACT = "no contact"
SHIFT_MODES = ("pooled", "per_orientation", "none")


class GPConfigHeader(StrictModel):
    """`GPConfig` as stored in a model file's header (bounds on scaled inputs and
    normalised targets, dimensionless)."""

    length_scale_bounds: bounded_list(1e-9, 1e9, "dimensionless", length=2)
    constant_bounds: bounded_list(1e-9, 1e9, "dimensionless", length=2)
    noise_bounds: bounded_list(1e-12, 1e3, "dimensionless", length=2)
    length_scale_init: float = bounded(1e-9, 1e9, "dimensionless", "initial length scale")
    noise_init: float = bounded(1e-12, 1e3, "dimensionless", "initial noise level")
    n_restarts: int = bounded(0, 100, "restarts", "optimiser restarts")
    alpha: float = bounded(0, 1, "dimensionless", "kernel jitter")
    max_alpha: float = bounded(0, 1, "dimensionless", "largest kernel jitter")


class ModelHeader(StrictModel):
    """The JSON header of a perception model file (`PerceptionModel.save`)."""

    format: Literal["tactip-twin/perception-model"]
    format_version: Literal[2]
    created_utc: str
    software: dict[str, str]
    method: Literal["pca", "baseline"]
    source: str
    camera_resolution: Annotated[
        list[Annotated[int, Field(ge=16, le=8192)]],
        Field(min_length=2, max_length=2, description="training camera width, height (px; each in [16, 8192])"),
    ]
    n_pins: Literal[127]
    data_layout: str
    n_components: int = bounded(1, 2 * N_PINS, "components", "PCA components")
    gp_config: GPConfigHeader
    gp_alpha: dict[
        Literal["cos", "sin", "lat"], Annotated[float, Field(ge=0, le=1, description="dimensionless; [0, 1]")]
    ]
    max_missing_fraction: float = bounded(0, 1, "dimensionless", "largest fraction of missing pins")
    lateral_keep_fraction: float = bounded(0, 1, "dimensionless", "pruning keeps at least this fraction")
    no_contact_lateral_mm: float = bounded(-50, 50, "mm", "no-contact label threshold")
    no_contact_px: float = bounded(0, 1000, "px", "no-contact pin distance", 0.3)
    depth_shift_mode: Literal["pooled", "per_orientation", "none"] = "per_orientation"
    gp_inputs: dict[Literal["cos", "sin", "lat"], list[Annotated[int, Field(ge=0, le=3)]]]
    input_scale: float = bounded(0, 1e9, "1/px", "input scaling", open_lo=True)
    contact_threshold: float = bounded(0, 1e9, "px", "contact threshold")
    info: dict[str, Any] = {}


# ----------------------------------------------------------------------------- helpers


def pins_to_vectors(pins_px: np.ndarray) -> np.ndarray:
    """(N, 127, 2) or (127, 2) pins (px) → (N, 254) data vectors z = (u1, v1, u2, v2, …)."""
    pins_px = np.asarray(pins_px, dtype=float)
    if pins_px.ndim == 2:
        pins_px = pins_px[None]
    if pins_px.shape[1:] != (N_PINS, 2):
        raise UserError(f"perception: pins must be (N, {N_PINS}, 2) px, got shape {pins_px.shape}")
    return pins_px.reshape(len(pins_px), N_DIMS)


def without_uniform_shift(pins_px: np.ndarray, rest_px: np.ndarray) -> np.ndarray:
    """(N, 127, 2) px: the frames with each one's uniform shift (its mean pin displacement
    from the rest pins `rest_px`, (127, 2) px) taken out."""
    return pins_px - (pins_px.mean(axis=1, keepdims=True) - rest_px.mean(axis=0))


def angle_error_deg(predicted_deg: np.ndarray, true_deg: np.ndarray) -> np.ndarray:
    """Signed wrapped difference predicted − true (deg), in [−180, 180)."""
    return wrap_deg(np.asarray(predicted_deg, float) - np.asarray(true_deg, float))


def pca_fit(data: np.ndarray, n_components: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """PCA of the data matrix D (N × d) by SVD.

    Returns (mean z̄ (d,), eigenvectors E (k, d) as rows, variance explained (k,) as
    fractions of the total variance). Sign convention: each eigenvector's largest-magnitude
    loading is positive (deterministic).
    """
    data = np.asarray(data, float)
    mean = data.mean(axis=0)
    _, sing, vt = np.linalg.svd(data - mean, full_matrices=False)
    comps = vt[:n_components].copy()
    signs = np.sign(comps[np.arange(len(comps)), np.argmax(np.abs(comps), axis=1)])
    comps *= np.where(signs == 0, 1.0, signs)[:, None]
    total = float(np.sum(sing**2))
    explained = sing[:n_components] ** 2 / total if total > 0 else np.zeros(n_components)
    if len(comps) < n_components:  # fewer frames than components: pad (degenerate but defined)
        pad = n_components - len(comps)
        comps = np.vstack([comps, np.zeros((pad, data.shape[1]))])
        explained = np.concatenate([explained, np.zeros(pad)])
    return mean, comps, explained


def sensitivity(p: np.ndarray, labels: np.ndarray, groups: np.ndarray, *, circular_deg: bool = False) -> np.ndarray:
    """Per-point sensitivity S = ‖Δp‖ / |Δw| to its neighbouring labels within each group.

    p: (N, k) projections; labels: (N,) w (deg or mm); groups: (N,) group id (points are
    neighbours only within a group). Neighbours are the adjacent distinct labels after
    sorting (circular over 360° if `circular_deg` and the labels cover the circle). A
    point's S is the mean over its neighbours; NaN if it has none.
    """
    p = np.asarray(p, float)
    labels = np.asarray(labels, float)
    s_sum = np.zeros(len(p))
    s_cnt = np.zeros(len(p))
    for g in np.unique(groups):
        idx = np.flatnonzero(groups == g)
        idx = idx[np.argsort(labels[idx], kind="stable")]
        if len(idx) < 2:
            continue
        pairs = [(idx[a], idx[a + 1]) for a in range(len(idx) - 1)]
        if circular_deg and len(idx) > 2:
            lab = labels[idx]
            step = np.median(np.diff(lab))
            if 360.0 - (lab[-1] - lab[0]) <= 1.5 * step:
                pairs.append((idx[-1], idx[0]))
        for a, b in pairs:
            dw = labels[b] - labels[a]
            if circular_deg:
                dw = float(wrap_deg(dw))
            if abs(dw) < 1e-12:
                continue
            s = float(np.linalg.norm(p[b] - p[a])) / abs(dw)
            s_sum[[a, b]] += s
            s_cnt[[a, b]] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(s_cnt > 0, s_sum / np.maximum(s_cnt, 1), np.nan)


def tukey_keep(s: np.ndarray, min_keep_fraction: float = 0.0) -> np.ndarray:
    """Boolean keep-mask of the Tukey boxplot rule on S⁻¹ (drop S⁻¹ > Q3 + 1.5·IQR).

    S = 0 gives S⁻¹ = ∞ (always an outlier); NaN S (no neighbour) is kept. At least
    ceil(min_keep_fraction·N) points are kept: the ones with the smallest S⁻¹.
    """
    s = np.asarray(s, float)
    with np.errstate(divide="ignore"):
        inv = np.where(np.isnan(s), np.nan, 1.0 / s)
    finite = inv[np.isfinite(inv)]
    if len(finite) >= 4:
        q1, q3 = np.percentile(finite, [25, 75])
        limit = q3 + 1.5 * (q3 - q1)
    else:
        limit = np.inf
    keep = np.isnan(inv) | (inv <= limit)
    n_min = int(math.ceil(min_keep_fraction * len(s) - 1e-9))
    if keep.sum() < n_min:
        order = np.argsort(np.where(np.isnan(inv), -np.inf, inv), kind="stable")
        keep = np.zeros(len(s), bool)
        keep[order[:n_min]] = True
    return keep


@dataclass(frozen=True)
class DepthShift:
    """Per-θ_PC23 shift s (PC units, px) of the ρ/φ origin along the PC2–PC3 radial direction.

    anchors_rad: θ_PC23 of each orientation label's mid-range points (rad, sorted).
    shifts: s at each anchor. Empty arrays mean no shift (single depth).
    """

    anchors_rad: np.ndarray
    shifts: np.ndarray

    def __call__(self, theta_pc23: np.ndarray) -> np.ndarray:
        if len(self.anchors_rad) == 0:
            return np.zeros_like(theta_pc23)
        if len(self.anchors_rad) == 1:
            return np.full_like(theta_pc23, self.shifts[0])
        return np.interp(theta_pc23, self.anchors_rad, self.shifts, period=2 * np.pi)

    @classmethod
    def fit(
        cls,
        q: np.ndarray,
        theta_deg: np.ndarray,
        lateral_mm: np.ndarray,
        depth_mm: np.ndarray,
        mode: str = "per_orientation",
    ) -> DepthShift:
        """Fit from training projections q = p − p0 (N, 3) and their labels (see module doc).

        mode: "pooled" (one shift from the mid-range points of all orientations),
        "per_orientation" (one per orientation label, interpolated over θ_PC23) or "none".
        """
        if mode not in SHIFT_MODES:
            raise UserError(f"perception: depth_shift must be one of {', '.join(SHIFT_MODES)}, got {mode!r}")
        depths = np.unique(np.round(depth_mm, 9))
        lats = np.unique(np.round(lateral_mm, 9))
        empty = cls(np.zeros(0), np.zeros(0))
        if mode == "none" or len(depths) < 2 or len(lats) == 0:
            return empty
        mid = 0.5 * (lats.min() + lats.max())
        l_mid = lats[np.argmin(np.abs(lats - mid))]
        anchors, shifts, x1s, ts = [], [], [], []
        for th in np.unique(np.round(theta_deg, 9)):
            sel = np.flatnonzero((np.abs(theta_deg - th) < 1e-6) & (np.abs(lateral_mm - l_mid) < 1e-6))
            if len(np.unique(np.round(depth_mm[sel], 9))) < 2:
                continue
            qq = q[sel]
            mean23 = qq[:, 1:].mean(axis=0)
            norm = float(np.linalg.norm(mean23))
            if norm <= 1e-12:
                continue
            u = mean23 / norm
            t = qq[:, 1:] @ u
            x1 = qq[:, 0]
            if np.ptp(x1) <= 1e-9 * max(1.0, float(np.max(np.abs(x1)))):
                continue
            slope, intercept = np.polyfit(x1, t, 1)
            anchors.append(math.atan2(u[1], u[0]))
            shifts.append(float(intercept))
            x1s.append(x1)
            ts.append(t)
        if not anchors:
            return empty
        if mode == "pooled":
            x1, t = np.concatenate(x1s), np.concatenate(ts)
            return cls(np.zeros(1), np.array([float(np.polyfit(x1, t, 1)[1])]))
        order = np.argsort(anchors)
        return cls(np.asarray(anchors)[order], np.asarray(shifts)[order])


def spherical_coordinates(q: np.ndarray, shift: DepthShift) -> np.ndarray:
    """(N, 3) q = p − p0 → (N, 3) v = (ρ (px), θ_PC23 (rad), φ (rad)), see module doc."""
    q = np.atleast_2d(np.asarray(q, float))
    theta = np.arctan2(q[:, 2], q[:, 1])
    s = shift(theta)
    d2 = q[:, 1] - s * np.cos(theta)
    d3 = q[:, 2] - s * np.sin(theta)
    r = np.hypot(d2, d3)
    rho = np.hypot(q[:, 0], r)
    phi = np.arctan2(r, q[:, 0])
    return np.column_stack([rho, theta, phi])


# ----------------------------------------------------------------------------- GPs


@dataclass(frozen=True)
class GPConfig:
    """Kernel bounds and optimiser settings shared by the three GPs.

    Bounds are on the (scaled) inputs and the normalised targets. The WhiteKernel's lower
    bound, 1 % of the target variance (σ ≈ 4° on cos/sin θ, ≈ 0.5 mm on l), is the noise
    floor of real tap data (robot repeatability, tracking); it also keeps the kernel matrix
    positive definite with duplicate points. Simulated taps are noise-free: with a floor
    of 1e-6 the GPs interpolated them exactly and read slides worse (the six contours,
    pins projected: 16.7° mean orientation RMS and 3–3.9 mm lateral, against 10.1° and
    0.9–1.5 mm with the floor; measured).
    """

    length_scale_bounds: tuple[float, float] = (1e-2, 1e3)
    constant_bounds: tuple[float, float] = (1e-3, 1e3)
    noise_bounds: tuple[float, float] = (1e-2, 1.0)
    length_scale_init: float = 1.0
    noise_init: float = 1e-2
    n_restarts: int = 2
    alpha: float = 1e-10  # jitter added to the kernel diagonal
    max_alpha: float = 1e-2  # jitter is raised ×100 up to this if Cholesky fails


def make_kernel(n_features: int, ard: bool, cfg: GPConfig) -> Kernel:
    """ConstantKernel · Matern(ν = 5/2) + WhiteKernel; ARD length scales if `ard`."""
    length = np.full(n_features, cfg.length_scale_init) if ard else cfg.length_scale_init
    return ConstantKernel(1.0, cfg.constant_bounds) * Matern(
        length_scale=length, length_scale_bounds=cfg.length_scale_bounds, nu=2.5
    ) + WhiteKernel(min(max(cfg.noise_init, cfg.noise_bounds[0]), cfg.noise_bounds[1]), cfg.noise_bounds)


def fit_gp(
    x: np.ndarray, y: np.ndarray, kernel: Kernel, cfg: GPConfig, rng: np.random.Generator
) -> GaussianProcessRegressor:
    """Fit one GP by maximising the log marginal likelihood (bounded L-BFGS-B, restarts)."""
    seed = int(rng.integers(0, 2**31 - 1))
    alpha = cfg.alpha
    while True:
        gp = GaussianProcessRegressor(
            kernel=kernel, alpha=alpha, normalize_y=True, n_restarts_optimizer=cfg.n_restarts, random_state=seed
        )
        try:
            with warnings.catch_warnings():
                # With ARD length scales an input that carries no information is expected
                # to run to its upper bound; that is the answer, not a failure.
                warnings.simplefilter("ignore", ConvergenceWarning)
                return gp.fit(x, y)
        except np.linalg.LinAlgError:
            if alpha * 100 > cfg.max_alpha:
                raise
            alpha *= 100


def rebuild_gp(
    x: np.ndarray, y: np.ndarray, kernel: Kernel, theta: np.ndarray, alpha: float
) -> GaussianProcessRegressor:
    """A GP with fixed hyperparameters `theta` (log space), refitted on (x, y) without optimising."""
    gp = GaussianProcessRegressor(
        kernel=kernel.clone_with_theta(np.asarray(theta, float)), alpha=alpha, normalize_y=True, optimizer=None
    )
    return gp.fit(x, y)


# ----------------------------------------------------------------------------- model


@dataclass(frozen=True)
class Prediction:
    """Perception output for M frames.

    theta_deg: (M,) θ̂ in [−180, 180) (deg). lateral_mm: (M,) l̂ (mm).
    std: (M, 2) one-sigma (θ deg, l mm) from the GP predictive variances (θ by first-order
        propagation through atan2, capped at 180°).
    ok: (M,) False where the output should not be trusted (no contact, too many missing pins).
    reason: M strings; "" when nothing to report, else "; "-joined notes.
    """

    theta_deg: np.ndarray
    lateral_mm: np.ndarray
    std: np.ndarray
    ok: np.ndarray
    reason: tuple[str, ...]

    @property
    def theta_std_deg(self) -> np.ndarray:
        return self.std[:, 0]

    @property
    def lateral_std_mm(self) -> np.ndarray:
        return self.std[:, 1]


@dataclass
class PerceptionModel:
    """PCA + spherical-coordinate + GP perception (paper §II-B), or the raw-pin GP baseline.

    method: "pca" (the paper's method) or "baseline".
    gp: kernel bounds and optimiser settings.
    max_missing_fraction: above this fraction of missing pins a prediction is not ok.
    lateral_keep_fraction: pruning keeps at least this fraction of the lateral set.
    no_contact_lateral_mm: frames labelled with a lateral position ≥ this (mm) are the
        candidates for the reference (no-contact) frame.
    no_contact_px: default no-contact rule for `fit`: a frame whose pins all lie within this
        distance (px, training resolution) of the reference pins is "no contact" — by what
        the pins show, not by the label (see `fit`).
    depth_shift_mode: origin shift of ρ/φ — "per_orientation" (the paper), "pooled" or "none"
        (module doc, step 2).
    gp_inputs (fitted): the feature columns each GP takes (`PCA_GP_INPUTS`; the
        baseline's GPs: all); a GP not named takes every column.
    """

    method: str = "pca"
    gp: GPConfig = field(default_factory=GPConfig)
    max_missing_fraction: float = 0.2
    lateral_keep_fraction: float = 0.9
    no_contact_lateral_mm: float = 9.9
    n_components: int = 3
    no_contact_px: float = 0.3
    depth_shift_mode: str = "per_orientation"

    # Fitted state (set by fit / load).
    resolution: tuple[int, int] = (640, 480)
    source: str = "sim"
    reference_pins_px: np.ndarray | None = field(default=None, repr=False)
    pca_mean: np.ndarray | None = field(default=None, repr=False)
    pca_components: np.ndarray | None = field(default=None, repr=False)
    variance_explained: np.ndarray | None = field(default=None, repr=False)
    origin_p: np.ndarray | None = field(default=None, repr=False)
    depth_shift: DepthShift | None = field(default=None, repr=False)
    input_scale: float = 1.0
    contact_threshold: float = 0.0
    info: dict = field(default_factory=dict, repr=False)
    gp_inputs: dict[str, tuple[int, ...]] = field(default_factory=dict)
    _gps: dict = field(default_factory=dict, repr=False)
    _train: dict = field(default_factory=dict, repr=False)
    _gp_y: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if self.method not in ("pca", "baseline"):
            raise UserError(f"perception: method must be 'pca' or 'baseline', got {self.method!r}")
        if self.depth_shift_mode not in SHIFT_MODES:
            raise UserError(
                f"perception: depth_shift_mode must be one of {', '.join(SHIFT_MODES)}, got {self.depth_shift_mode!r}"
            )

    # ------------------------------------------------------------------ features

    @property
    def fitted(self) -> bool:
        return bool(self._gps)

    def _scaled_pins(self, pins_px: np.ndarray, resolution: tuple[int, int] | None) -> np.ndarray:
        pins = np.array(pins_px, dtype=float)
        if pins.ndim == 2:
            pins = pins[None]
        if pins.shape[1:] != (N_PINS, 2):
            raise UserError(f"perception: pins must be (M, {N_PINS}, 2) px, got shape {pins.shape}")
        if resolution is not None and (int(resolution[0]), int(resolution[1])) != tuple(self.resolution):
            pins = CameraModel(*self.resolution).rescale_px(pins, int(resolution[0]), int(resolution[1]))
        return pins

    def project(self, pins_px: np.ndarray) -> np.ndarray:
        """(M, 127, 2) pins (px, model resolution) → (M, 3) PCA projections p (px)."""
        return (pins_to_vectors(pins_px) - self.pca_mean) @ self.pca_components.T

    def pc23_px(self, pins_px: np.ndarray, resolution: tuple[int, int] | None = None) -> np.ndarray:
        """(M, 2) px: frames' coordinates in the PC2–PC3 plane about the origin p0, whose
        angle is θ_PC23 (pins at `resolution`, default the model's)."""
        return (self.project(self._scaled_pins(pins_px, resolution)) - self.origin_p)[:, 1:3]

    def spherical(self, pins_px: np.ndarray) -> np.ndarray:
        """(M, 127, 2) pins → (M, 3) v = (ρ px, θ_PC23 rad, φ rad)."""
        return spherical_coordinates(self.project(pins_px) - self.origin_p, self.depth_shift)

    def _gp_x(self, name: str, x: np.ndarray) -> np.ndarray:
        """The columns of the features x that GP `name` takes."""
        cols = self.gp_inputs.get(name)
        return x if cols is None else x[:, list(cols)]

    def _features(self, pins_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """GP inputs (M, d) and contact magnitude (M,) px for pins at the model resolution."""
        if self.method == "baseline":
            dz = pins_to_vectors(pins_px) - self.reference_pins_px.reshape(N_DIMS)
            return dz / self.input_scale, np.linalg.norm(dz, axis=1)
        q = self.project(pins_px) - self.origin_p
        v = spherical_coordinates(q, self.depth_shift)
        x = np.column_stack([v[:, 0] / self.input_scale, np.cos(v[:, 1]), np.sin(v[:, 1]), v[:, 2]])
        return x, np.linalg.norm(q, axis=1)

    # ------------------------------------------------------------------ fit

    def fit(
        self,
        pins_px: np.ndarray,
        theta_deg: np.ndarray,
        lateral_mm: np.ndarray,
        depth_mm: np.ndarray,
        rng: np.random.Generator,
        *,
        no_contact: np.ndarray | None = None,
        resolution: tuple[int, int] = (640, 480),
        source: str = "sim",
    ) -> PerceptionModel:
        """Fit from N tap frames.

        pins_px: (N, 127, 2) px at `resolution` (W, H). theta_deg (deg), lateral_mm (mm),
        depth_mm (mm): (N,) labels. rng seeds the hyperparameter restarts. source: "sim" or
        "real" (recorded).

        no_contact: (N,) bool; default measured from the pins. The frames labelled with
        lateral ≥ `no_contact_lateral_mm` are the candidates; the reference is the first
        candidate whose pins lie within `no_contact_px` of the candidates' median pins (the
        first candidate if none does); a frame is "no contact" when all its pins lie within
        `no_contact_px` of the reference. (On the twin the 40 mm dome pressed 4 mm deep at
        l = 9.9 mm does touch the edge — pins move by ≈ 5 px — so those frames are contact
        frames and train the GPs with their labels.) With `no_contact` given, the reference
        is its first frame. The reference is the origin p0 and the model's reference pins.
        """
        t0 = time.perf_counter()
        pins = np.asarray(pins_px, float)
        if pins.ndim != 3 or pins.shape[1:] != (N_PINS, 2):
            raise UserError(f"perception fit: pins must be (N, {N_PINS}, 2) px, got shape {pins.shape}")
        n = len(pins)
        theta_deg, lateral_mm, depth_mm = (np.asarray(a, float).reshape(-1) for a in (theta_deg, lateral_mm, depth_mm))
        for name, arr in (("theta_deg", theta_deg), ("lateral_mm", lateral_mm), ("depth_mm", depth_mm)):
            if len(arr) != n or not np.all(np.isfinite(arr)):
                raise UserError(f"perception fit: {name} must be {n} finite labels, got {len(arr)}")
        if not np.all(np.isfinite(pins)):
            raise UserError("perception fit: training pins contain NaN/inf (fill or drop those frames)")
        if source not in ("sim", "real"):
            raise UserError(f"perception fit: source must be 'sim' or 'real', got {source!r}")
        if no_contact is None:
            candidates = np.flatnonzero(lateral_mm >= self.no_contact_lateral_mm - 1e-9)
            if not len(candidates):
                raise UserError(
                    f"perception fit: no no-contact frame in the training set (lateral ≥ {self.no_contact_lateral_mm} mm); "
                    "pass no_contact="
                )
            median = np.median(pins[candidates], axis=0)
            near = [i for i in candidates if _max_shift(pins[i], median) <= self.no_contact_px]
            ref_idx = int(near[0] if near else candidates[0])
            no_contact = np.array([_max_shift(p, pins[ref_idx]) <= self.no_contact_px for p in pins])
            rule = f"measured: all pins within {self.no_contact_px:g} px of frame {ref_idx}"
        else:
            no_contact = np.asarray(no_contact, bool).reshape(-1)
            if len(no_contact) != n:
                raise UserError(f"perception fit: no_contact must be {n} bools, got {len(no_contact)}")
            if not no_contact.any():
                raise UserError("perception fit: no_contact marks no frame; the reference needs a no-contact frame")
            ref_idx = int(np.flatnonzero(no_contact)[0])
            rule = "given"
        self.resolution = (int(resolution[0]), int(resolution[1]))
        self.source = source
        first_nc = ref_idx
        self.reference_pins_px = pins[first_nc].copy()

        z = pins_to_vectors(pins)
        self.pca_mean, self.pca_components, self.variance_explained = pca_fit(z, self.n_components)
        p = (z - self.pca_mean) @ self.pca_components.T
        self.origin_p = p[first_nc].copy()
        q = p - self.origin_p
        self.depth_shift = DepthShift.fit(
            q[~no_contact],
            theta_deg[~no_contact],
            lateral_mm[~no_contact],
            depth_mm[~no_contact],
            self.depth_shift_mode,
        )

        # Pruning (paper): orientation set per (l, depth), lateral set per (θ, depth).
        s_orient = sensitivity(p, theta_deg, _group_ids(lateral_mm, depth_mm), circular_deg=True)
        s_lat = sensitivity(p, lateral_mm, _group_ids(wrap_deg(theta_deg), depth_mm))
        # The paper removes the no-contact frames outright (indistinguishable, different
        # labels); S and the Tukey rule then prune the rest. The 90 % floor is of the contact set.
        contact_idx = np.flatnonzero(~no_contact)
        keep_orient = np.zeros(n, bool)
        keep_lat = np.zeros(n, bool)
        keep_orient[contact_idx] = tukey_keep(s_orient[contact_idx])
        keep_lat[contact_idx] = tukey_keep(s_lat[contact_idx], self.lateral_keep_fraction)
        if keep_orient.sum() < 2 or keep_lat.sum() < 2:
            raise UserError("perception fit: fewer than 2 training points left after pruning")

        contact_mag = np.linalg.norm(q, axis=1)
        if self.method == "baseline":
            dz = z - self.reference_pins_px.reshape(N_DIMS)
            self.input_scale = float(np.sqrt(np.mean(np.sum(dz**2, axis=1)))) or 1.0
            contact_mag = np.linalg.norm(dz, axis=1)
        else:
            v = spherical_coordinates(q, self.depth_shift)
            self.input_scale = float(np.sqrt(np.mean(v[:, 0] ** 2))) or 1.0
        nc_rms = float(np.sqrt(np.mean(contact_mag[no_contact] ** 2)))
        contacts = contact_mag[keep_orient & ~no_contact]
        floor = 0.5 * float(contacts.min()) if len(contacts) else 0.0
        self.contact_threshold = max(3.0 * nc_rms, floor, 1e-9)

        x, _ = self._features(pins)
        theta_rad = np.radians(theta_deg)
        targets = {
            "cos": (np.cos(theta_rad), keep_orient),
            "sin": (np.sin(theta_rad), keep_orient),
            "lat": (lateral_mm, keep_lat),
        }
        ard = self.method == "pca"
        self.gp_inputs = dict(PCA_GP_INPUTS) if ard else {}
        self._gps = {}
        self._train = {
            "p": p,
            "theta_deg": theta_deg,
            "lateral_mm": lateral_mm,
            "depth_mm": depth_mm,
            "keep_orientation": keep_orient,
            "keep_lateral": keep_lat,
            "no_contact": no_contact,
        }
        for name in GP_NAMES:
            y, keep = targets[name]
            x_gp = self._gp_x(name, x)
            kernel = make_kernel(x_gp.shape[1], ard, self.gp)
            self._gps[name] = fit_gp(x_gp[keep], y[keep], kernel, self.gp, rng)
            self._gp_y[name] = y[keep].copy()
        touching = (lateral_mm >= self.no_contact_lateral_mm - 1e-9) & ~no_contact
        self.info = {
            "n_train": n,
            "no_contact_rule": rule,
            "n_no_contact": int(no_contact.sum()),
            "n_labelled_no_contact_touching": int(touching.sum()),
            "depth_shift": self.depth_shift_mode,
            "n_orientation_kept": int(keep_orient.sum()),
            "n_lateral_kept": int(keep_lat.sum()),
            "variance_explained": [float(a) for a in self.variance_explained],
            "fit_seconds": time.perf_counter() - t0,
            "kernels": {k: str(g.kernel_) for k, g in self._gps.items()},
            "log_marginal_likelihood": {k: float(g.log_marginal_likelihood_value_) for k, g in self._gps.items()},
        }
        return self

    # ------------------------------------------------------------------ predict

    def predict(
        self,
        pins_px: np.ndarray,
        found: np.ndarray | None = None,
        *,
        resolution: tuple[int, int] | None = None,
    ) -> Prediction:
        """Predict θ̂ (deg) and l̂ (mm) for (M, 127, 2) or (127, 2) pins (px).

        found: optional (M, 127) bool from the tracker; pins not found (or NaN) count as
        missing. NaN pins are filled from the model's reference (no-contact) pins; pins the
        tracker flagged keep the tracker's last-known position. More than
        `max_missing_fraction` missing → ok False. No contact (‖p − p0‖ below the
        contact threshold) → ok False, reason "no contact"; outputs stay finite.
        resolution: (W, H) of the input frames if not the model's (pins rescaled, CameraModel.rescale_px).
        """
        if not self.fitted:
            raise UserError("perception: the model is not fitted (call fit or load)")
        pins = self._scaled_pins(pins_px, resolution)
        m = len(pins)
        missing = ~np.all(np.isfinite(pins), axis=2)
        if found is not None:
            found = np.asarray(found, bool).reshape(m, N_PINS)
            missing |= ~found
        nan_rows = ~np.isfinite(pins)
        if nan_rows.any():
            pins = np.where(nan_rows, np.broadcast_to(self.reference_pins_px, pins.shape), pins)

        x, contact = self._features(pins)
        out = {}
        for name in GP_NAMES:
            mean, sd = self._gps[name].predict(self._gp_x(name, x), return_std=True)
            out[name] = (np.asarray(mean, float).reshape(m), np.asarray(sd, float).reshape(m))
        (c, sc), (s, ss), (lat, sl) = out["cos"], out["sin"], out["lat"]
        theta = wrap_deg(np.degrees(np.arctan2(s, c)))
        r2 = c**2 + s**2
        with np.errstate(divide="ignore", invalid="ignore"):
            sd_theta = np.degrees(np.sqrt(c**2 * ss**2 + s**2 * sc**2) / r2)
        sd_theta = np.where(np.isfinite(sd_theta), np.minimum(sd_theta, 180.0), 180.0)

        ok = np.ones(m, bool)
        reasons: list[str] = []
        for i in range(m):
            notes = []
            n_miss = int(missing[i].sum())
            if n_miss:
                frac = n_miss / N_PINS
                notes.append(f"{n_miss}/{N_PINS} pins missing ({frac:.0%})")
                if frac > self.max_missing_fraction:
                    ok[i] = False
                    notes.append("too many missing pins")
            if not contact[i] > self.contact_threshold:
                ok[i] = False
                notes.insert(0, NO_CONTACT)
            if not (np.isfinite(theta[i]) and np.isfinite(lat[i])):
                ok[i] = False
                notes.append("non-finite GP output")
            reasons.append("; ".join(notes))
        theta = np.nan_to_num(theta)
        lat = np.nan_to_num(lat)
        return Prediction(theta, lat, np.column_stack([sd_theta, np.nan_to_num(sl, nan=np.inf)]), ok, tuple(reasons))

    # ------------------------------------------------------------------ persistence

    def save(self, path: str | Path) -> Path:
        """Write the model to one .npz file (JSON header + arrays; loads without pickle)."""
        if not self.fitted:
            raise UserError("perception: cannot save an unfitted model")
        path = Path(path)
        header = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
            "software": _versions(),
            "method": self.method,
            "source": self.source,
            "camera_resolution": list(self.resolution),
            "n_pins": N_PINS,
            "data_layout": "interleaved (u1, v1, u2, v2, ...) px",
            "n_components": self.n_components,
            "gp_config": asdict(self.gp),
            "gp_alpha": {k: float(g.alpha) for k, g in self._gps.items()},
            "max_missing_fraction": self.max_missing_fraction,
            "lateral_keep_fraction": self.lateral_keep_fraction,
            "no_contact_lateral_mm": self.no_contact_lateral_mm,
            "no_contact_px": self.no_contact_px,
            "depth_shift_mode": self.depth_shift_mode,
            "gp_inputs": {k: list(v) for k, v in self.gp_inputs.items()},
            "input_scale": self.input_scale,
            "contact_threshold": self.contact_threshold,
            "info": self.info,
        }
        arrays: dict[str, np.ndarray] = {
            "header": np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8),
            "reference_pins_px": self.reference_pins_px,
            "pca_mean": self.pca_mean,
            "pca_components": self.pca_components,
            "variance_explained": self.variance_explained,
            "origin_p": self.origin_p,
            "shift_anchors_rad": self.depth_shift.anchors_rad,
            "shift_values": self.depth_shift.shifts,
        }
        for k, g in self._gps.items():
            arrays[f"gp_{k}_x"] = g.X_train_
            arrays[f"gp_{k}_y"] = self._gp_y[k]
            arrays[f"gp_{k}_theta"] = g.kernel_.theta
        for k, a in self._train.items():
            arrays[f"train_{k}"] = np.asarray(a)
        packed = io.BytesIO()
        np.savez(packed, **arrays)
        return replace_file(path, packed.getvalue())

    @classmethod
    def load(cls, path: str | Path) -> PerceptionModel:
        """Read a model written by `save` (any machine; no pickle)."""
        path = Path(path)
        if not path.is_file():
            raise UserError(f"perception model file not found: {path}")
        try:
            data = np.load(path, allow_pickle=False)
            header = json.loads(bytes(data["header"]).decode("utf-8"))
        except (ValueError, KeyError, OSError, EOFError, zipfile.BadZipFile) as exc:
            raise UserError(f"{path}: not a perception model file ({type(exc).__name__})") from None
        if not isinstance(header, dict):
            raise UserError(f"{path}: the header is not a JSON object")
        if header.get("format") != FORMAT:
            raise UserError(f"{path}: format {header.get('format')!r}, expected {FORMAT!r}")
        if header.get("format_version") != FORMAT_VERSION:
            raise UserError(
                f"{path}: format_version {header.get('format_version')}, this twin reads {FORMAT_VERSION} "
                "(fit a new model from the tap run it came from)"
            )
        if header.get("n_pins") != N_PINS:
            raise UserError(f"{path}: model has {header.get('n_pins')} pins, expected {N_PINS}")
        h: ModelHeader = validate_mapping(ModelHeader, header, str(path), "perception model header")
        for name in data.files:
            if name != "header" and data[name].dtype.kind == "f" and not np.all(np.isfinite(data[name])):
                raise UserError(f"{path}: array {name!r} holds NaN or ±inf")
        gp_cfg = GPConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in h.gp_config.model_dump().items()})
        model = cls(
            method=h.method,
            gp=gp_cfg,
            max_missing_fraction=h.max_missing_fraction,
            lateral_keep_fraction=h.lateral_keep_fraction,
            no_contact_lateral_mm=h.no_contact_lateral_mm,
            n_components=h.n_components,
            no_contact_px=h.no_contact_px,
            depth_shift_mode=h.depth_shift_mode,
        )
        model.resolution = tuple(h.camera_resolution)
        model.source = h.source
        model.input_scale = h.input_scale
        model.contact_threshold = h.contact_threshold
        model.info = h.info | {"loaded_from": str(path), "created_utc": h.created_utc}
        model.reference_pins_px = data["reference_pins_px"]
        model.pca_mean = data["pca_mean"]
        model.pca_components = data["pca_components"]
        model.variance_explained = data["variance_explained"]
        model.origin_p = data["origin_p"]
        model.depth_shift = DepthShift(data["shift_anchors_rad"], data["shift_values"])
        model.gp_inputs = {k: tuple(v) for k, v in h.gp_inputs.items()}
        ard = model.method == "pca"
        for k in GP_NAMES:
            x = data[f"gp_{k}_x"]
            if k in model.gp_inputs and x.shape[1] != len(model.gp_inputs[k]):
                raise UserError(
                    f"{path}: GP {k!r} was trained on {x.shape[1]} inputs, its header names {len(model.gp_inputs[k])}"
                )
            kernel = make_kernel(x.shape[1], ard, gp_cfg)
            model._gp_y[k] = data[f"gp_{k}_y"]
            model._gps[k] = rebuild_gp(x, model._gp_y[k], kernel, data[f"gp_{k}_theta"], h.gp_alpha[k])
        model._train = {k[len("train_") :]: data[k] for k in data.files if k.startswith("train_")}
        return model

    @property
    def training_summary(self) -> dict:
        """Training-set projections, labels and pruning masks (for plots and reports)."""
        return dict(self._train)


def _max_shift(a: np.ndarray, b: np.ndarray) -> float:
    """Largest pin displacement (px) between two (127, 2) pin sets."""
    return float(np.max(np.linalg.norm(a - b, axis=1)))


def _group_ids(*labels: np.ndarray) -> np.ndarray:
    keys = np.column_stack([np.round(np.asarray(a, float), 6) for a in labels])
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    return ids.reshape(-1)


def _versions() -> dict:

    try:
        twin_version = version("tactip-twin")
    except Exception:  # not installed as a distribution (source checkout)
        twin_version = "unknown"
    return {
        "tactip-twin": twin_version,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scikit-learn": sklearn.__version__,
    }


# ----------------------------------------------------------------------------- synthetic data


def synthetic_tap_pins(
    theta_deg: np.ndarray,
    lateral_mm: np.ndarray,
    depth_mm: np.ndarray,
    *,
    camera: CameraModel | None = None,
    noise_px: float = 0.0,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """(N, 127, 2) px pins of a smooth analytic tap model (not physics; for tests and benchmarks).

    Built to have the structure the paper's method assumes: pin displacements (tool plane,
    mm) are a(d, l)·[cos β(l)·S + sin β(l)·D(θ)] + 0.1·d·min(c(l), 1)·S, where S is a
    symmetric radial bulge (x / 10 mm), D(θ) a smooth shift along the edge normal
    n = (cos θ, −sin θ) (weighted towards the centre, σ = 8 mm), c(l) = max(8.5 − l, 0)^1.5 / 10
    the contact amount (exactly 0 off the object, l ≥ 8.5 mm), a = 0.04·d^1.3·c(l) and
    β(l) = 15° + 60°·sigmoid(l / 3 mm). Pins also move towards the camera by 0.05·a mm, then
    are projected through `camera`. So PC1 ≈ bulge, (PC2, PC3) ≈ direction of the edge,
    φ ≈ β(l) and ρ grows with depth.
    """
    camera = camera or CameraModel()
    geom = camera.geometry
    theta = np.radians(np.atleast_1d(np.asarray(theta_deg, float)))
    lat = np.atleast_1d(np.asarray(lateral_mm, float))
    dep = np.atleast_1d(np.asarray(depth_mm, float))
    theta, lat, dep = np.broadcast_arrays(theta, lat, dep)
    x = geom.pin_lattice * geom.pin_spacing * 1e3  # (127, 2) mm
    bulge = x / 10.0
    weight = np.exp(-np.sum(x**2, axis=1) / (2 * 8.0**2))[:, None]
    tips = geom.pin_tip_points()
    out = np.empty((len(theta), N_PINS, 2))
    for k in range(len(theta)):
        n = np.array([np.cos(theta[k]), -np.sin(theta[k])])
        c = max(8.5 - lat[k], 0.0) ** 1.5 / 10.0
        a = 0.04 * dep[k] ** 1.3 * c
        beta = np.radians(15.0 + 60.0 / (1.0 + np.exp(-lat[k] / 3.0)))
        disp = a * (np.cos(beta) * bulge + np.sin(beta) * weight * n) + 0.1 * dep[k] * min(c, 1.0) * 0.04 * bulge
        pts = tips.copy()
        pts[:, :2] += disp * 1e-3
        pts[:, 2] -= 0.05 * a * weight[:, 0] * 1e-3
        out[k] = camera.project_tool_points(pts)
    if noise_px > 0:
        rng = rng if rng is not None else np.random.default_rng(0)
        out += rng.normal(0.0, noise_px, out.shape)
    return out


def paper_training_labels() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paper's 288 tap labels (θ deg, l mm, depth mm): 18 θ × 8 l × 2 depths, θ-major."""
    thetas = np.arange(-160.0, 181.0, 20.0)
    lats = np.array([9.9, 6.0, 4.0, 2.0, 0.0, -2.0, -4.0, -6.0])
    depths = np.array([2.0, 4.0])
    t, l, d = np.meshgrid(thetas, lats, depths, indexing="ij")
    return t.ravel(), l.ravel(), d.ravel()


# ----------------------------------------------------------------------------- benchmark


def benchmark_perception(rng: np.random.Generator, *, n_frames: int = 50, n_restarts: int = 2) -> dict:
    """Time the tracker at 640×480, GP training on the 288 paper tap points, and prediction.

    Uses `synthetic_tap_pins` frames drawn by `twin.sensing.tracker.render_pins_frame` (2 gray levels
    of noise). Returns milliseconds per frame (median) and seconds for training, plus the
    tracker's accuracy and the held-out errors of predictions from the tracked pins.
    """

    camera = CameraModel()
    th, la, de = paper_training_labels()
    train = synthetic_tap_pins(th, la, de, camera=camera, noise_px=0.05, rng=rng)

    ref_frame = render_pins_frame(train[0], noise_std=2.0, rng=rng)
    ref, areas = reference_pins_from_frame(ref_frame)
    tracker = PinTracker(ref, reference_areas_px=areas)
    tt = rng.uniform(-180, 180, n_frames)
    tl = rng.uniform(-5, 5, n_frames)
    td = rng.uniform(2.2, 3.8, n_frames)
    test = synthetic_tap_pins(tt, tl, td, camera=camera)
    # Each test tap is pressed in 4 frames (¼…1 of the depth), as a camera would film it:
    # the tracker follows the pins frame to frame from the no-contact reference.
    detect_ms, track_ms, tracked = [], [], []
    for k in range(n_frames):
        tracker.reset()
        for frac in (0.25, 0.5, 0.75, 1.0):
            pins = synthetic_tap_pins(tt[k], tl[k], td[k] * frac, camera=camera)[0]
            f = render_pins_frame(pins, noise_std=2.0, rng=rng)
            t0 = time.perf_counter()
            detect_pins(f)
            detect_ms.append((time.perf_counter() - t0) * 1e3)
            res = tracker.track(f)
            track_ms.append(res.ms)
        tracked.append(res)
    centroid_rms = float(np.sqrt(np.mean([np.mean(np.sum((r.pins_px - p) ** 2, 1)) for r, p in zip(tracked, test)])))

    t0 = time.perf_counter()
    model = PerceptionModel(gp=GPConfig(n_restarts=n_restarts)).fit(train, th, la, de, rng)
    fit_s = time.perf_counter() - t0
    pred_ms = []
    for r in tracked:
        t0 = time.perf_counter()
        model.predict(r.pins_px, r.found)
        pred_ms.append((time.perf_counter() - t0) * 1e3)
    pred = model.predict(np.stack([r.pins_px for r in tracked]))
    theta_rms = float(np.sqrt(np.mean(angle_error_deg(pred.theta_deg, tt)[pred.ok] ** 2)))
    lat_rms = float(np.sqrt(np.mean((pred.lateral_mm - tl)[pred.ok] ** 2)))
    return {
        "frame_size": [camera.width, camera.height],
        "detect_ms_per_frame": float(np.median(detect_ms)),
        "tracker_ms_per_frame": float(np.median(track_ms)),
        "tracker_found_fraction": float(np.mean([r.n_found / N_PINS for r in tracked])),
        "tracker_rms_px": centroid_rms,
        "gp_train_points": int(len(train)),
        "gp_train_s": fit_s,
        "predict_ms_per_frame": float(np.median(pred_ms)),
        "variance_explained": [float(a) for a in model.variance_explained],
        "n_orientation_kept": model.info["n_orientation_kept"],
        "n_lateral_kept": model.info["n_lateral_kept"],
        "heldout_theta_rms_deg": theta_rms,
        "heldout_lateral_rms_mm": lat_rms,
        "heldout_ok_fraction": float(np.mean(pred.ok)),
    }
