"""Pin detection and identity-preserving pin tracking for TacTip camera frames.

The same code runs on rendered (sim) and filmed (real) frames: it only sees pixels.

* `detect_pins` finds the white pin tips in one frame: grayscale → circular aperture mask
  (only the aperture's bounding box is processed) → Otsu threshold → connected components
  → area/shape filter → intensity-weighted sub-pixel centroids (px, u right, v down).
* `PinTracker` keeps every pin's identity (the fixed 127-pin order of README
  "Conventions") from a no-contact reference frame onwards. Pins can move by more than
  half a pin spacing between two frames — independent taps (the sensor lifts between
  them: up to 1.6 spacings on the twin) or the shear when a slide starts (up to 1.2
  spacings) — so detections are not matched to the previous positions directly but
  through a smooth displacement field over the pin lattice, grown from the pins that
  match unambiguously, and one-to-one (Hungarian) for the pins that the skin's bending at
  a contact's border swings off that field (see `PinTracker`). A pin that cannot be
  assigned is reported where its neighbours' motion puts it and flagged with a reason;
  pins are never reordered or dropped.
* `reference_pins_from_frame` orders the detections of a no-contact frame into the
  canonical order by fitting the projected pin template (`CameraModel`) with a
  similarity transform, so it also works for a real camera whose centre, scale and
  roll (within ±25°) differ from the model's.
* `render_pins_frame` draws a synthetic TacTip frame from known pin positions (tests and
  benchmarks; it is not the renderer of the simulation).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

from twin.core.errors import UserError
from twin.core.sensor import N_PINS, CameraModel

# Per-pin reasons in TrackResult.reasons ("" = tracked normally).
OK = ""
MISSING = "missing"  # no detection within the jump gate: last known position kept
MERGED = "merged"  # shares one blob with another pin: position estimated from the blob's motion
AMBIGUOUS = "ambiguous"  # the assigned blob is almost as close to another pin: position is a best guess

_BIG_COST = 1e9


@dataclass(frozen=True)
class Detections:
    """Blobs found in one frame.

    centroids_px: (K, 2) intensity-weighted centroids (px).
    areas_px: (K,) blob areas (px²).
    threshold: gray level used for the binary mask (0–255).
    """

    centroids_px: np.ndarray
    areas_px: np.ndarray
    threshold: float


@dataclass(frozen=True)
class TrackResult:
    """One tracked frame.

    pins_px: (127, 2) pin positions (px) in the canonical order; never NaN.
    found: (127,) True where the pin was matched to its own blob this frame.
    reasons: 127 strings, "" where found, else "missing", "merged" or "ambiguous".
    n_detected: blobs detected in the frame.
    ms: wall time of detection + assignment (ms).
    """

    pins_px: np.ndarray
    found: np.ndarray
    reasons: tuple[str, ...]
    n_detected: int
    ms: float

    @property
    def n_found(self) -> int:
        return int(self.found.sum())


def camera_for_frame(width: int, height: int) -> CameraModel:
    """The default camera model at a given resolution (intrinsics scale with the height)."""
    return CameraModel(width=int(width), height=int(height))


def template_pins_px(camera: CameraModel | None = None) -> np.ndarray:
    """(127, 2) undeformed pin tips projected through `camera` (px), canonical order."""
    camera = camera or CameraModel()
    return camera.project_tool_points(camera.geometry.pin_tip_points())


def template_pin_radii_px(camera: CameraModel | None = None) -> np.ndarray:
    """(127,) apparent radius (px) of each undeformed pin tip."""
    camera = camera or CameraModel()
    depth = camera.geometry.camera_to_apex + camera.geometry.pin_tip_points()[:, 2]
    return np.asarray(camera.pin_radius_px(depth), dtype=float)


@lru_cache(maxsize=8)
def _aperture_mask(width: int, height: int, cx: float, cy: float, radius: float) -> np.ndarray:
    mask = np.zeros((height, width), np.uint8)
    cv2.circle(mask, (int(round(cx * 16)), int(round(cy * 16))), int(round(radius * 16)), 255, -1, cv2.LINE_8, 4)
    return mask


@lru_cache(maxsize=8)
def _default_min_area(width: int, height: int) -> float:
    r_min = float(np.min(template_pin_radii_px(camera_for_frame(width, height))))
    return max(3.0, 0.15 * np.pi * r_min**2)


def _to_gray(frame: np.ndarray) -> np.ndarray:
    if frame.ndim == 3 and frame.shape[2] == 1:
        frame = frame[:, :, 0]
    if frame.ndim == 3:
        if frame.shape[2] == 3 and frame.strides[2] < 0:
            # A channel-reversed view (e.g. RGB ↔ BGR by [..., ::-1]): reverse it back for
            # free instead of letting OpenCV copy it.
            frame = cv2.cvtColor(frame[..., ::-1], cv2.COLOR_RGB2GRAY)
        else:
            frame = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    if frame.ndim != 2:
        raise UserError(f"tracker: a frame must be (H, W) or (H, W, 3), got shape {frame.shape}")
    if frame.dtype != np.uint8:
        if np.issubdtype(frame.dtype, np.floating) and frame.size and float(np.nanmax(frame)) <= 1.0:
            frame = frame * 255.0
        frame = np.clip(np.nan_to_num(frame), 0, 255).astype(np.uint8)
    return frame


def detect_pins(
    frame: np.ndarray,
    *,
    aperture_radius_px: float | None = None,
    aperture_centre_px: tuple[float, float] | None = None,
    min_area_px: float | None = None,
    threshold: float | None = None,
) -> Detections:
    """Detect white pin tips in a TacTip frame.

    frame: (H, W) gray or (H, W, 3) colour image (BGR weights; the pins are white, so RGB
        works the same), uint8 (floats in [0, 1] or [0, 255] accepted).
    aperture_radius_px / aperture_centre_px: circular region searched; defaults from
        `CameraModel` at the frame's resolution (centred on ((W − 1)/2, (H − 1)/2) like the intrinsics).
        Only the aperture's bounding box is processed.
    min_area_px: smallest blob kept (px²); default 15 % of the area of the smallest
        expected pin at this resolution (rejects noise specks).
    threshold: fixed gray threshold; default Otsu over the aperture's bounding box
        (outside the aperture counts as black).

    Shape filter (rotation invariant, from each blob's second moments): aspect
    √(λmax/λmin) ≤ 3 and fill = area / (4π·√det Σ) ≥ 0.6 (1 for a filled ellipse; two
    touching discs ≈ 0.9, so merged pins are kept and flagged later by their area).
    """
    frame = np.asarray(frame)
    height, width = frame.shape[:2]
    if aperture_radius_px is None:
        aperture_radius_px = camera_for_frame(width, height).aperture_radius_px
    cx, cy = aperture_centre_px if aperture_centre_px is not None else ((width - 1) / 2, (height - 1) / 2)
    r = float(aperture_radius_px)
    x0, x1 = max(0, int(np.floor(cx - r)) - 1), min(width, int(np.ceil(cx + r)) + 2)
    y0, y1 = max(0, int(np.floor(cy - r)) - 1), min(height, int(np.ceil(cy + r)) + 2)
    if x1 <= x0 or y1 <= y0:
        return Detections(np.zeros((0, 2)), np.zeros(0), 0.0)
    gray = _to_gray(frame[y0:y1, x0:x1])
    mask = _aperture_mask(x1 - x0, y1 - y0, float(cx) - x0, float(cy) - y0, r)
    masked = cv2.bitwise_and(gray, mask)
    if threshold is None:
        thr, binary = cv2.threshold(masked, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    else:
        thr, binary = cv2.threshold(masked, float(threshold), 255, cv2.THRESH_BINARY)
    n, labels = cv2.connectedComponents(binary, connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return Detections(np.zeros((0, 2)), np.zeros(0), float(thr))
    if min_area_px is None:
        min_area_px = _default_min_area(width, height)
    nz = cv2.findNonZero(binary).reshape(-1, 2)  # much faster than np.nonzero
    xs, ys = nz[:, 0].astype(np.float64), nz[:, 1].astype(np.float64)
    lab = labels[nz[:, 1], nz[:, 0]]
    area = np.bincount(lab, minlength=n).astype(float)
    safe = np.maximum(area, 1.0)
    mx, my = np.bincount(lab, xs, n) / safe, np.bincount(lab, ys, n) / safe
    sxx = np.bincount(lab, xs * xs, n) / safe - mx**2
    syy = np.bincount(lab, ys * ys, n) / safe - my**2
    sxy = np.bincount(lab, xs * ys, n) / safe - mx * my
    # Pixels are unit squares: add their own variance (1/12) so one-pixel-wide blobs stay finite.
    sxx, syy = sxx + 1.0 / 12.0, syy + 1.0 / 12.0
    half_tr, det = 0.5 * (sxx + syy), np.maximum(sxx * syy - sxy**2, 1e-12)
    disc = np.sqrt(np.maximum(half_tr**2 - det, 0.0))
    aspect = np.sqrt((half_tr + disc) / np.maximum(half_tr - disc, 1e-12))
    fill = area / (4.0 * np.pi * np.sqrt(det))
    keep = (area >= min_area_px) & (fill >= 0.6) & (aspect <= 3.0)
    keep[0] = False  # background
    if not keep.any():
        return Detections(np.zeros((0, 2)), np.zeros(0), float(thr))

    # Intensity-weighted centroids over each component's pixels, weights = gray − threshold
    # (the background level contributes nothing, the bright core the most).
    w = gray[nz[:, 1], nz[:, 0]].astype(np.float64) - (float(thr) - 1.0)
    sw = np.bincount(lab, weights=w, minlength=n)
    su = np.bincount(lab, weights=w * xs, minlength=n)
    sv = np.bincount(lab, weights=w * ys, minlength=n)
    idx = np.flatnonzero(keep)
    centroids = np.column_stack([su[idx] / sw[idx] + x0, sv[idx] / sw[idx] + y0])
    return Detections(centroids, area[idx], float(thr))


def _similarity_fit(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares s, R, t with dst ≈ s·R·src + t (Umeyama, 2-D, no reflection)."""
    mu_s, mu_d = src.mean(0), dst.mean(0)
    a, b = src - mu_s, dst - mu_d
    u, sig, vt = np.linalg.svd(b.T @ a)
    d = np.diag([1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    rot = u @ d @ vt
    scale = float(np.trace(np.diag(sig) @ d) / max(np.sum(a**2), 1e-12))
    return scale, rot, mu_d - scale * rot @ mu_s


def order_to_template(points_px: np.ndarray, template_px: np.ndarray, iterations: int = 20) -> np.ndarray:
    """Order 127 detected points (px) into the canonical pin order of `template_px`.

    The template is first normalised onto the points (centroid and RMS radius), then
    refined by alternating Hungarian matching and a similarity fit (ICP). The result is
    independent of the detection order. Robust to a template offset/scale/roll mismatch up
    to roughly half a pin spacing at the rim (roll ≲ 25°). Raises UserError if the final
    match is not one-to-one within half a pin spacing.
    """
    points_px = np.asarray(points_px, float)
    template_px = np.asarray(template_px, float)
    if points_px.shape != template_px.shape:
        raise UserError(
            f"tracker reference: found {len(points_px)} pins in the no-contact frame, expected {len(template_px)}"
        )
    mu_p, mu_t = points_px.mean(0), template_px.mean(0)
    s0 = np.sqrt(np.mean(np.sum((points_px - mu_p) ** 2, 1)) / np.mean(np.sum((template_px - mu_t) ** 2, 1)))
    # Coarse roll search (nearest-neighbour cost), then ICP from the best roll.
    tree = cKDTree(points_px)
    best = (np.inf, None)
    for roll in np.radians(np.arange(-25.0, 25.5, 1.0)):
        c, s = np.cos(roll), np.sin(roll)
        cand = (template_px - mu_t) @ np.array([[c, s], [-s, c]]) * s0 + mu_p
        cost = float(np.sum(tree.query(cand)[0] ** 2))
        if cost < best[0]:
            best = (cost, cand)
    moved = best[1]
    best_rms = np.inf
    order = np.arange(len(points_px))
    for _ in range(iterations):
        cost = np.linalg.norm(moved[:, None, :] - points_px[None, :, :], axis=2)
        rows, cols = linear_sum_assignment(cost)
        order = cols[np.argsort(rows)]
        scale, rot, t = _similarity_fit(template_px, points_px[order])
        moved = template_px @ (scale * rot).T + t
        rms = float(np.sqrt(np.mean(np.sum((moved - points_px[order]) ** 2, 1))))
        if rms >= best_rms - 1e-9:
            break
        best_rms = rms
    spacing = float(np.median(cKDTree(points_px).query(points_px, 2)[0][:, 1]))
    residual = np.linalg.norm(moved - points_px[order], axis=1)
    if np.max(residual) > 0.5 * spacing:  # a real lens spaces the rings unlike the model camera
        moved, order = _radial_icp(points_px, template_px, iterations)
        residual = np.linalg.norm(moved - points_px[order], axis=1)
    if np.max(residual) > 0.5 * spacing:
        raise UserError(
            "tracker reference: the no-contact frame's pins do not fit the hexagonal pin template "
            f"(worst residual {np.max(residual):.1f} px, pin spacing {spacing:.1f} px)"
        )
    return points_px[order]


def _radial_warp(template_px: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    """The template about its centroid, each radius r mapped to r·(c0 + c1·ρ² + c2·ρ⁴),
    ρ = r over the largest radius (px)."""
    v = template_px - template_px.mean(0)
    rho = np.linalg.norm(v, axis=1) / np.max(np.linalg.norm(v, axis=1))
    return v * (coefficients[0] + coefficients[1] * rho**2 + coefficients[2] * rho**4)[:, None]


def _radial_coefficients(template_px: np.ndarray, radii_px: np.ndarray) -> np.ndarray:
    """Least-squares (c0, c1, c2) of `_radial_warp` that move each template pin to the radius `radii_px`."""
    r = np.linalg.norm(template_px - template_px.mean(0), axis=1)
    rho = r / np.max(r)
    return np.linalg.lstsq(np.column_stack([r, r * rho**2, r * rho**4]), radii_px, rcond=None)[0]


def _radial_icp(points_px: np.ndarray, template_px: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """`order_to_template`'s fit with the template's rings respaced (`_radial_warp`) as well as
    moved, scaled and rolled: a filmed TacTip's lens compresses the inner rings against the
    outer ones more than the model camera does. Starts from matching the sorted radii;
    returns (the fitted template, the order of the points) as the similarity fit does."""
    mu_p, mu_t = points_px.mean(0), template_px.mean(0)
    coefficients = _radial_coefficients(
        template_px[np.argsort(np.linalg.norm(template_px - mu_t, axis=1))],
        np.sort(np.linalg.norm(points_px - mu_p, axis=1)),
    )
    warped = _radial_warp(template_px, coefficients)
    tree = cKDTree(points_px)
    best = (np.inf, None)
    for roll in np.radians(np.arange(-30.0, 30.5, 1.0)):  # a hexagonal lattice repeats every 60°
        c, s = np.cos(roll), np.sin(roll)
        cand = warped @ np.array([[c, s], [-s, c]]) + mu_p
        cost = float(np.sum(tree.query(cand)[0] ** 2))
        if cost < best[0]:
            best = (cost, cand)
    moved, order, best_rms = best[1], np.arange(len(points_px)), np.inf
    for _ in range(iterations):
        rows, cols = linear_sum_assignment(np.linalg.norm(moved[:, None, :] - points_px[None, :, :], axis=2))
        order = cols[np.argsort(rows)]
        scale, rot, t = _similarity_fit(warped, points_px[order])
        back = (points_px[order] - t) @ rot / scale  # the matched points in the warped template's frame
        warped = _radial_warp(template_px, _radial_coefficients(template_px, np.linalg.norm(back, axis=1)))
        moved = warped @ (scale * rot).T + t
        rms = float(np.sqrt(np.mean(np.sum((moved - points_px[order]) ** 2, 1))))
        if rms >= best_rms - 1e-9:
            break
        best_rms = rms
    return moved, order


def reference_pins_from_frame(frame: np.ndarray, camera: CameraModel | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Pins of a no-contact frame in canonical order: ((127, 2) px, (127,) areas px²).

    `camera` defaults to the model camera at the frame's resolution; only its pin template
    is used, so a real camera's offset, scale and small roll are absorbed by the fit.
    """
    gray = _to_gray(np.asarray(frame))
    camera = camera or camera_for_frame(gray.shape[1], gray.shape[0])
    det = detect_pins(gray)
    ordered = order_to_template(det.centroids_px, template_pins_px(camera))
    # Recover each ordered pin's area by matching back to the detections (exact copies).
    idx = cKDTree(det.centroids_px).query(ordered)[1]
    return ordered, det.areas_px[idx]


def _bipartite_components(near: np.ndarray) -> np.ndarray:
    """Connected components of the bipartite graph whose (n, m) adjacency is `near`: a
    label per node, rows first (0…n−1), then columns (n…n+m−1)."""
    n, m = near.shape
    label = np.arange(n + m)
    while True:  # every node takes the smallest label among itself and its neighbours
        rows = np.minimum(label[:n], np.where(near, label[None, n:], n + m).min(axis=1, initial=n + m))
        cols = np.minimum(label[n:], np.where(near, rows[:, None], n + m).min(axis=0, initial=n + m))
        merged = np.concatenate([rows, cols])
        if np.array_equal(merged, label):
            return label
        label = merged


def _unambiguous_pairs(dist: np.ndarray, reach: float, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (rows, cols) of the one-to-one assignment of rows to columns on `dist` (px) that
    nothing else comes close to.

    A row may stay unassigned at cost `reach` (px), so no pair is farther apart than that. A
    pair (i, j) is kept when the best assignment without it costs at least (1/ratio − 1)·dist
    more (for one row and two columns: dist[i, j] ≤ ratio × the other distance). Rows and
    columns that cannot meet within `reach` of each other are solved apart."""
    n, m = dist.shape
    near = dist <= reach
    label = _bipartite_components(near)
    keep_rows, keep_cols = [], []
    for group in np.unique(label[:n][near.any(axis=1)]):
        r = np.flatnonzero(label[:n] == group)
        c = np.flatnonzero(label[n:] == group)
        cost = np.hstack([dist[np.ix_(r, c)], np.where(np.eye(len(r), dtype=bool), reach, _BIG_COST)])
        rows, cols = linear_sum_assignment(cost)
        total = cost[rows, cols].sum()
        for i, j in zip(rows, cols):
            if j >= len(c):  # left unassigned
                continue
            own = cost[i, j]
            cost[i, j] = _BIG_COST
            alt_rows, alt_cols = linear_sum_assignment(cost)
            cost[i, j] = own
            if cost[alt_rows, alt_cols].sum() - total >= (1.0 / ratio - 1.0) * own:
                keep_rows.append(r[i])
                keep_cols.append(c[j])
    return np.asarray(keep_rows, int), np.asarray(keep_cols, int)


class PinTracker:
    """Pin tracker that preserves the canonical pin identities from frame to frame.

    Each frame's detections are matched to the pins through a smooth displacement field
    over the pin lattice (the skin moves as a continuum) and, for the pins the field cannot
    predict, through the one-to-one constraint: where the skin bends at a contact's border
    the pins tilt and swing off their neighbours' motion (on the twin, up to 0.7 spacing
    off the field fitted to all the other pins, neighbours differing by up to 1.2 spacings,
    while the pins jump by more than a spacing between frames):

    1. Start from a prediction of every pin's position: the previous frame's pins; if that
       leaves pins unresolved, the previous pins moved by the mean displacement of the
       detections (with all pins seen, the mean of the blobs minus the mean of the pins is
       the pins' mean motion: it catches the whole-pattern shear when a slide starts), the
       reference moved likewise, and the reference itself (taps are independent presses,
       so the previous frame may belong to another contact). The starts are tried in
       this order, each through steps 2–5, and the first that resolves every pin is the
       assignment; if none does, the start whose steps 2–4 resolved the most pins (then
       the smoothest field) goes on to step 6.
    2. Confident matches: the pin's nearest blob is within `confident_fraction` of a pin
       spacing, the match is mutual (the blob's nearest prediction is that pin) and both
       pass a ratio test (the second-nearest blob / prediction is at least twice as far).
    3. Consistency: each confident match's displacement from the reference is compared
       with the field fitted to the *other* confident pins (leave-one-out); matches that
       disagree by more than `consistency_fraction` of a spacing are dropped — a pin that
       took its neighbour's blob is a spacing off its neighbours' motion.
    4. The field (moving-least-squares affine fit over the reference lattice, Gaussian
       weights of σ = `field_sigma` spacings, ridge `field_ridge` on the affine part)
       predicts the unresolved pins; repeat from 2 until the confident set stops changing
       (at most `max_iterations`), so the resolved region grows into the pins near the
       contact that moved furthest.
    5. The pins still unresolved are assigned one-to-one (Hungarian) to the blobs of one
       pin's size that no resolved pin holds, on the distance to their prediction; a pin
       may stay unassigned at the cost of `grow_fraction` of a spacing, the reach. A pair is
       kept only if every assignment without it costs at least (1/`ambiguity_ratio` − 1)
       × its distance more (no rearrangement of the open pins comes close); the kept pins
       join the field, which predicts the rest again; repeat (at most `max_iterations`).
       This resolves the swung pins that step 3 drops: their blobs are the ones left.
    6. If every pin is resolved that is the assignment. Otherwise all pins are assigned
       one-to-one to blobs (Hungarian) on the distance to their prediction, gated by
       `max_jump_px`; a blob much larger than a pin may take several.

    A pin without a blob within the gate is "missing"; pins sharing one blob are
    "merged"; a pin whose blob is nearly as close to another pin's prediction is
    "ambiguous". Such pins are reported at their predicted position (from the motion of
    their neighbours) with the reason; pins are never reordered or dropped.

    reference: (127, 2) reference pin positions (px, canonical order) or a no-contact
        frame (H, W[, 3]) from which they are detected and ordered.
    max_jump_px: largest distance between a pin's predicted position and its blob in step 6
        (px); default half the median nearest-neighbour pin spacing of the reference.
    merge_area_ratio: a blob whose area exceeds this multiple of the expected pin area
        may hold several pins.
    ambiguity_ratio: a pin is "ambiguous" when the distance to its blob is more than this
        fraction of the blob's distance to the next-closest predicted pin (and at least a
        quarter of a pin spacing).
    confident_fraction, consistency_fraction, grow_fraction, field_sigma (spacings),
    field_ridge, max_iterations: steps 2–5 above.
    """

    def __init__(
        self,
        reference: np.ndarray,
        *,
        max_jump_px: float | None = None,
        merge_area_ratio: float = 1.45,
        ambiguity_ratio: float = 0.8,
        reference_areas_px: np.ndarray | None = None,
        confident_fraction: float = 0.35,
        consistency_fraction: float = 0.4,
        grow_fraction: float = 1.0,
        field_sigma: float = 0.75,
        field_ridge: float = 0.05,
        max_iterations: int = 8,
    ) -> None:
        reference = np.asarray(reference)
        if reference.shape == (N_PINS, 2):
            pins = reference.astype(float)
            if reference_areas_px is None:
                reference_areas_px = np.full(N_PINS, np.nan)
        else:
            pins, reference_areas_px = reference_pins_from_frame(reference)
        if not np.all(np.isfinite(pins)):
            raise UserError("tracker reference: reference pin positions must be finite")
        self._reference = pins.copy()
        self._ref_areas = np.asarray(reference_areas_px, float)
        self.spacing_px = float(np.median(cKDTree(pins).query(pins, 2)[0][:, 1]))
        self.max_jump_px = float(max_jump_px) if max_jump_px is not None else 0.5 * self.spacing_px
        self.merge_area_ratio = float(merge_area_ratio)
        self.ambiguity_ratio = float(ambiguity_ratio)
        self.confident_px = float(confident_fraction) * self.spacing_px
        self.consistency_px = float(consistency_fraction) * self.spacing_px
        self.grow_px = float(grow_fraction) * self.spacing_px
        self.field_ridge = float(field_ridge)
        self.max_iterations = int(max_iterations)
        # Lattice geometry of the field fit (spacing units), fixed by the reference.
        # Weighted moments over pin pairs (i, j): w, w·x, w·y, w·x², w·xy, w·y², with (x, y) the
        # offset of j from i in spacings and w = exp(−|offset|² / 2σ²).
        off = (pins[None, :, :] - pins[:, None, :]) / self.spacing_px
        w = np.exp(-np.sum(off**2, axis=2) / (2.0 * float(field_sigma) ** 2))
        ox, oy = off[..., 0], off[..., 1]
        self._moments = np.stack([w, w * ox, w * oy, w * ox * ox, w * ox * oy, w * oy * oy])
        # The same without each pin's own term (weight 1 at offset 0, so only in Σw), for the
        # leave-one-out fit: taking 1 off 1 + Σw(others) rounds Σw(others) away below 1e-16 (at
        # σ = 0.75, a pin over 6.4 spacings from all the others in use), and moments / Σw overflow.
        self._moments_others = self._moments.copy()
        np.fill_diagonal(self._moments_others[0], 0.0)
        self._previous = pins.copy()

    @property
    def reference_pins_px(self) -> np.ndarray:
        """(127, 2) reference (no-contact) pin positions (px)."""
        return self._reference.copy()

    def reset(self) -> None:
        """Forget the motion history: the next frame is matched starting from the reference."""
        self._previous = self._reference.copy()

    def _expected_areas(self, detections: Detections) -> np.ndarray:
        """Expected single-pin area (px²) for each pin."""
        ref = self._ref_areas
        if np.all(np.isfinite(ref)):
            return ref
        # Unknown reference areas: use the median blob of the frame (robust to a few merges).
        med = float(np.median(detections.areas_px)) if len(detections.areas_px) else 1.0
        return np.where(np.isfinite(ref), ref, med)

    def track(self, frame: np.ndarray) -> TrackResult:
        """Detect the pins in `frame` and assign them to the canonical identities."""
        t0 = time.perf_counter()
        det = detect_pins(frame)
        result = self.assign(det)
        ms = (time.perf_counter() - t0) * 1e3
        return TrackResult(result.pins_px, result.found, result.reasons, result.n_detected, ms)

    # ------------------------------------------------------------------ displacement field

    def _field(self, disp: np.ndarray, use: np.ndarray, exclude_self: bool = False) -> np.ndarray:
        """(127, 2) displacement (px) predicted at every pin from the displacements `disp`
        of the pins in `use` (see the class doc, step 4). exclude_self: leave each pin out
        of its own fit (the consistency check)."""
        u = use.astype(float)
        rhs = np.column_stack([u, u[:, None] * disp])  # (127, 3): u, u·du, u·dv
        g = (self._moments_others if exclude_self else self._moments) @ rhs  # (6, 127, 3)
        # Per pin, the weighted affine fit's normal equations A·x = b, divided by Σw:
        # A = [[1, m1, m2], [m1, m11 + ridge, m12], [m2, m12, m22 + ridge]]; its constant
        # term x[0] (the displacement at the pin) by the first row of A's adjugate.
        sw = g[0, :, 0] + 1e-300
        m1, m2 = g[1, :, 0] / sw, g[2, :, 0] / sw
        m11, m12, m22 = g[3, :, 0] / sw + self.field_ridge, g[4, :, 0] / sw, g[5, :, 0] / sw + self.field_ridge
        c0, c1, c2 = m11 * m22 - m12 * m12, m12 * m2 - m1 * m22, m1 * m12 - m11 * m2
        det = c0 + m1 * c1 + m2 * c2
        return (c0[:, None] * g[0, :, 1:] + c1[:, None] * g[1, :, 1:] + c2[:, None] * g[2, :, 1:]) / (det * sw)[:, None]

    def _match_field(
        self, cents: np.ndarray, tree: cKDTree, start: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Steps 2–4 of the class doc from the predicted positions `start`.

        Returns (predicted positions (127, 2) px — the matched blob for confident pins, the
        field's prediction otherwise —, confident mask (127,), blob index of each pin (127,),
        valid where confident, RMS leave-one-out residual of the confident pins (px))."""
        ref = self._reference
        k = len(cents)
        pred = start
        conf = np.zeros(N_PINS, bool)
        loo_rms = np.inf
        pin_ids = np.arange(N_PINS)
        for _ in range(self.max_iterations):
            d, nn = tree.query(pred, k=2)
            d = d.reshape(N_PINS, -1)
            nn = nn.reshape(N_PINS, -1)
            j = nn[:, 0]
            second = d[:, 1] if k > 1 else np.full(N_PINS, np.inf)
            dp, ip = cKDTree(pred).query(cents, k=2)
            new = (ip[j, 0] == pin_ids) & (d[:, 0] <= self.confident_px) & (d[:, 0] <= 0.5 * second)
            new &= dp[j, 0] <= 0.5 * dp[j, 1]
            disp = cents[j] - ref
            if new.sum() >= 4:
                resid = np.linalg.norm(disp - self._field(disp, new, exclude_self=True), axis=1)
                new &= resid <= self.consistency_px
                loo_rms = float(np.sqrt(np.mean(resid[new] ** 2))) if new.any() else np.inf
            if new.all():  # every pin has its own blob: nothing left to predict
                return cents[j], new, j, loo_rms
            pred = ref + self._field(disp, new)
            pred[new] = cents[j[new]]
            if np.array_equal(new, conf):
                break
            conf = new
        return pred, conf, j, loo_rms

    def _grow(
        self, cents: np.ndarray, single: np.ndarray, pred: np.ndarray, resolved: np.ndarray, blob: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Step 5 of the class doc: assign the unresolved pins to the blobs no resolved pin
        holds, keep the unambiguous pairs, refit the field, repeat.

        single: (K,) blobs of one pin's size that no resolved pin holds. Returns (predicted positions (127, 2) px,
        resolved mask (127,)); `blob` is updated in place."""
        ref = self._reference
        pred, resolved = pred.copy(), resolved.copy()
        for _ in range(self.max_iterations):
            pins = np.flatnonzero(~resolved)
            held = np.zeros(len(cents), bool)
            held[blob[resolved]] = True
            free = np.flatnonzero(single & ~held)
            if not len(pins) or not len(free):
                break
            d = np.linalg.norm(pred[pins, None, :] - cents[None, free, :], axis=2)  # (open pins, free blobs)
            rows, cols = _unambiguous_pairs(d, self.grow_px, self.ambiguity_ratio)
            if not len(rows):
                break
            resolved[pins[rows]] = True
            blob[pins[rows]] = free[cols]
            if resolved.all():  # every pin on its blob: no field left to predict
                return cents[blob], resolved
            disp = np.where(resolved[:, None], cents[blob] - ref, 0.0)
            pred = ref + self._field(disp, resolved)
            pred[resolved] = cents[blob[resolved]]
        return pred, resolved

    def assign(self, det: Detections) -> TrackResult:
        """Assign detections to pin identities and advance the tracker state."""
        t0 = time.perf_counter()
        cents, areas = det.centroids_px, det.areas_px
        k = len(cents)
        found = np.zeros(N_PINS, bool)
        reasons = [MISSING] * N_PINS
        if k == 0:
            pins = self._previous.copy()
            return TrackResult(pins, found, tuple(reasons), 0, (time.perf_counter() - t0) * 1e3)

        # Steps 1–4: predict every pin, from the previous frame, then if pins are left
        # unresolved from the previous frame and the reference moved by the detections' mean
        # displacement (a jump of a spacing or more: shear when sliding starts, or a new tap).
        tree = cKDTree(cents)
        shift = cents.mean(axis=0) - self._reference.mean(axis=0) if k >= 0.9 * N_PINS else None
        starts = [self._previous]
        if shift is not None:
            starts += [self._previous + (cents.mean(axis=0) - self._previous.mean(axis=0)), self._reference + shift]
        starts.append(self._reference)
        expected = self._expected_areas(det)
        best = None
        for start in starts:
            pred, resolved, blob, loo = self._match_field(cents, tree, start)
            score = (int(resolved.sum()), -loo)
            if not resolved.all():
                # Blobs of one pin's size, among those no resolved pin holds (the only ones
                # step 5 looks at), by the expected area of their nearest pin.
                single = np.ones(k, bool)
                single[blob[resolved]] = False
                loose = np.flatnonzero(single)
                nearest_pin = np.argmin(np.linalg.norm(cents[loose, None, :] - pred[None, :, :], axis=2), axis=1)
                single[loose] = areas[loose] <= self.merge_area_ratio * expected[nearest_pin]
                pred, resolved = self._grow(cents, single, pred, resolved, blob)
            if resolved.all():
                best = (score, pred, resolved, blob)
                break
            if best is None or score > best[0]:
                best = (score, pred, resolved, blob)
        _, pred, resolved, blob = best
        if resolved.all():
            # Every pin holds a blob of its own, matched unambiguously (ratio tests, or the
            # assignment's margin in step 5): that is the assignment.
            self._previous = pred
            return TrackResult(pred.copy(), np.ones(N_PINS, bool), (OK,) * N_PINS, k, (time.perf_counter() - t0) * 1e3)

        # Step 6: one-to-one assignment to the predictions, gated; large blobs may take several pins.
        dist = np.linalg.norm(pred[:, None, :] - cents[None, :, :], axis=2)  # (127, K)
        nearest_pin = np.argmin(dist, axis=0)
        ratio = areas / np.maximum(expected[nearest_pin], 1e-9)
        mult = np.clip(np.rint(ratio), 1, 3).astype(int)
        mult[ratio <= self.merge_area_ratio] = 1
        cols = np.repeat(np.arange(k), mult)
        cost = dist[:, cols]
        gated = np.where(cost <= self.max_jump_px, cost, _BIG_COST)
        rows, cc = linear_sum_assignment(gated)
        valid = gated[rows, cc] < _BIG_COST
        rows, blob = rows[valid], cols[cc[valid]]

        pins = pred.copy()  # unassigned pins: where their neighbours' motion puts them
        owner_count = np.bincount(blob, minlength=k)
        assigned_blob = np.full(N_PINS, -1)
        assigned_blob[rows] = blob
        pins[rows] = cents[blob]
        found[rows] = True
        for i in rows:
            reasons[i] = OK

        # Unassigned pins whose nearest blob (within the gate) was taken: they merged into it.
        unassigned = np.flatnonzero(assigned_blob < 0)
        merged_groups: dict[int, list[int]] = {}
        for i in unassigned:
            j = int(np.argmin(dist[i]))
            if dist[i, j] <= self.max_jump_px and owner_count[j] > 0:
                merged_groups.setdefault(j, []).append(int(i))
        for j in np.flatnonzero(owner_count > 1):
            merged_groups.setdefault(int(j), [])
        for j, extra in merged_groups.items():
            group = sorted(set(np.flatnonzero(assigned_blob == j).tolist()) | set(extra))
            # The group's predicted layout, centred on its blob.
            shift = cents[j] - pred[group].mean(axis=0)
            for i in group:
                pins[i] = pred[i] + shift
                found[i] = False
                reasons[i] = MERGED

        # Ambiguity: the blob is nearly as close to another pin's predicted position.
        idx = np.flatnonzero(found)
        if len(idx) and N_PINS > 1:
            two = np.partition(dist, 1, axis=0)[:2]  # (2, K): closest and second-closest pin per blob
            j = assigned_blob[idx]
            d_own = dist[idx, j]
            d_other = np.where(np.argmin(dist, axis=0)[j] == idx, two[1, j], two[0, j])
            amb = idx[(d_own >= 0.25 * self.spacing_px) & (d_own > self.ambiguity_ratio * d_other)]
            found[amb] = False
            for i in amb:
                reasons[i] = AMBIGUOUS

        self._previous = pins
        return TrackResult(pins.copy(), found, tuple(reasons), k, (time.perf_counter() - t0) * 1e3)


def render_pins_frame(
    pins_px: np.ndarray,
    *,
    width: int = 640,
    height: int = 480,
    radii_px: np.ndarray | float | None = None,
    background: int = 25,
    foreground: int = 235,
    noise_std: float = 0.0,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """Draw a synthetic TacTip frame (H, W) uint8: anti-aliased white discs on a dark disc.

    pins_px: (N, 2) pin centres (px); NaN rows are not drawn.
    radii_px: per-pin or single radius (px); default the model's apparent pin-tip radii
        at this resolution (`CameraModel.pin_radius_px`).
    noise_std: Gaussian pixel noise (gray levels), drawn from `rng`.
    """
    camera = camera_for_frame(width, height)
    frame = np.zeros((height, width), np.uint8)
    shift = 4
    cv2.circle(
        frame,
        ((width - 1) * 8, (height - 1) * 8),
        int(camera.aperture_radius_px * 16),
        int(background),
        -1,
        cv2.LINE_AA,
        shift,
    )
    pins_px = np.asarray(pins_px, float)
    if radii_px is None:
        radii = template_pin_radii_px(camera) if len(pins_px) == N_PINS else np.full(len(pins_px), 7.0)
    else:
        radii = np.broadcast_to(np.asarray(radii_px, float), (len(pins_px),))
    for (u, v), r in zip(pins_px, radii):
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        cv2.circle(
            frame, (int(round(u * 16)), int(round(v * 16))), int(round(r * 16)), int(foreground), -1, cv2.LINE_AA, shift
        )
    if noise_std > 0:
        rng = rng if rng is not None else np.random.default_rng(0)
        frame = np.clip(frame + rng.normal(0.0, noise_std, frame.shape), 0, 255).astype(np.uint8)
    return frame
