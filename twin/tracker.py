"""Pin detection and identity-preserving pin tracking for TacTip camera frames.

The same code runs on rendered (sim) and filmed (real) frames: it only sees pixels.

* `detect_pins` finds the white pin tips in one frame: grayscale → circular aperture mask →
  Otsu threshold → connected components → area/shape filter → intensity-weighted
  sub-pixel centroids (px, u right, v down).
* `PinTracker` keeps every pin's identity (the fixed 127-pin order of README
  "Conventions") from a no-contact reference frame onwards: each frame's detections are
  assigned to the previous frame's positions with the Hungarian method, gated by a
  maximum jump. A pin that cannot be assigned keeps its last known position and is
  flagged; pins are never reordered or dropped.
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

from twin.errors import UserError
from twin.tactip import N_PINS, CameraModel

# Per-pin reasons in TrackResult.reasons ("" = tracked normally).
OK = ""
MISSING = "missing"      # no detection within the jump gate: last known position kept
MERGED = "merged"        # shares one blob with another pin: position estimated from the blob's motion
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

    frame: (H, W) gray or (H, W, 3) BGR image, uint8 (floats in [0, 1] or [0, 255] accepted).
    aperture_radius_px / aperture_centre_px: circular region searched; defaults from
        `CameraModel` at the frame's resolution (centred on ((W − 1)/2, (H − 1)/2) like the intrinsics).
    min_area_px: smallest blob kept (px²); default 15 % of the area of the smallest
        expected pin at this resolution (rejects noise specks).
    threshold: fixed gray threshold; default Otsu over the aperture.
    """
    gray = _to_gray(np.asarray(frame))
    height, width = gray.shape
    if aperture_radius_px is None:
        aperture_radius_px = camera_for_frame(width, height).aperture_radius_px
    cx, cy = aperture_centre_px if aperture_centre_px is not None else ((width - 1) / 2, (height - 1) / 2)
    mask = _aperture_mask(width, height, float(cx), float(cy), float(aperture_radius_px))
    masked = cv2.bitwise_and(gray, mask)
    if threshold is None:
        thr, binary = cv2.threshold(masked, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    else:
        thr, binary = cv2.threshold(masked, float(threshold), 255, cv2.THRESH_BINARY)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(binary, connectivity=8, ltype=cv2.CV_32S)
    if min_area_px is None:
        min_area_px = _default_min_area(width, height)
    area = stats[1:, cv2.CC_STAT_AREA].astype(float)
    bw = stats[1:, cv2.CC_STAT_WIDTH].astype(float)
    bh = stats[1:, cv2.CC_STAT_HEIGHT].astype(float)
    fill = area / np.maximum(bw * bh, 1.0)
    aspect = np.maximum(bw, bh) / np.maximum(np.minimum(bw, bh), 1.0)
    # Discs fill π/4 of their box; two merged discs still fill > 0.5 with aspect ≤ 2.
    keep = (area >= min_area_px) & (fill >= 0.45) & (aspect <= 3.0)
    if n <= 1 or not keep.any():
        return Detections(np.zeros((0, 2)), np.zeros(0), float(thr))

    # Intensity-weighted centroids over each component's pixels, weights = gray − threshold
    # (the background level contributes nothing, the bright core the most).
    nz = cv2.findNonZero(binary).reshape(-1, 2)  # much faster than np.nonzero
    xs, ys = nz[:, 0], nz[:, 1]
    lab = labels[ys, xs]
    w = gray[ys, xs].astype(np.float64) - (float(thr) - 1.0)
    sw = np.bincount(lab, weights=w, minlength=n)
    su = np.bincount(lab, weights=w * xs, minlength=n)
    sv = np.bincount(lab, weights=w * ys, minlength=n)
    idx = np.flatnonzero(keep) + 1
    centroids = np.column_stack([su[idx] / sw[idx], sv[idx] / sw[idx]])
    return Detections(centroids, area[idx - 1], float(thr))


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
    if np.max(residual) > 0.5 * spacing:
        raise UserError(
            "tracker reference: the no-contact frame's pins do not fit the hexagonal pin template "
            f"(worst residual {np.max(residual):.1f} px, pin spacing {spacing:.1f} px)"
        )
    return points_px[order]


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


class PinTracker:
    """Frame-to-frame pin tracker that preserves the canonical pin identities.

    reference: (127, 2) reference pin positions (px, canonical order) or a no-contact
        frame (H, W[, 3]) from which they are detected and ordered.
    max_jump_px: largest per-frame pin displacement accepted (px); default half the
        median nearest-neighbour pin spacing of the reference.
    merge_area_ratio: a blob whose area exceeds this multiple of the expected pin area
        may hold several pins.
    ambiguity_ratio: a pin is "ambiguous" when the distance to its blob is more than this
        fraction of the blob's distance to the next-closest pin (and at least a quarter
        of a pin spacing).
    """

    def __init__(
        self,
        reference: np.ndarray,
        *,
        max_jump_px: float | None = None,
        merge_area_ratio: float = 1.45,
        ambiguity_ratio: float = 0.8,
        reference_areas_px: np.ndarray | None = None,
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
        self._previous = pins.copy()

    @property
    def reference_pins_px(self) -> np.ndarray:
        """(127, 2) reference (no-contact) pin positions (px)."""
        return self._reference.copy()

    def reset(self) -> None:
        """Forget the motion history: the next frame is matched against the reference."""
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

    def assign(self, det: Detections) -> TrackResult:
        """Assign detections to pin identities and advance the tracker state."""
        t0 = time.perf_counter()
        prev = self._previous
        cents, areas = det.centroids_px, det.areas_px
        k = len(cents)
        pins = prev.copy()
        found = np.zeros(N_PINS, bool)
        reasons = [MISSING] * N_PINS
        if k == 0:
            self._previous = pins
            return TrackResult(pins, found, tuple(reasons), 0, (time.perf_counter() - t0) * 1e3)

        dist = np.linalg.norm(prev[:, None, :] - cents[None, :, :], axis=2)  # (127, K)
        expected = self._expected_areas(det)
        nearest_pin = np.argmin(dist, axis=0)
        ratio = areas / np.maximum(expected[nearest_pin], 1e-9)
        # A blob of area ratio r can hold up to round(r) pins (at most 3 offered).
        mult = np.clip(np.rint(ratio), 1, 3).astype(int)
        mult[ratio <= self.merge_area_ratio] = 1
        cols = np.repeat(np.arange(k), mult)
        cost = dist[:, cols]
        gated = np.where(cost <= self.max_jump_px, cost, _BIG_COST)
        rows, cc = linear_sum_assignment(gated)
        valid = gated[rows, cc] < _BIG_COST
        rows, blob = rows[valid], cols[cc[valid]]

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
            # The group moves with its blob; each pin keeps its offset within the group.
            shift = cents[j] - prev[group].mean(axis=0)
            for i in group:
                pins[i] = prev[i] + shift
                found[i] = False
                reasons[i] = MERGED

        # Ambiguity: the blob is nearly as close to another pin's previous position.
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
    cv2.circle(frame, ((width - 1) * 8, (height - 1) * 8), int(camera.aperture_radius_px * 16), int(background), -1, cv2.LINE_AA, shift)
    pins_px = np.asarray(pins_px, float)
    if radii_px is None:
        radii = template_pin_radii_px(camera) if len(pins_px) == N_PINS else np.full(len(pins_px), 7.0)
    else:
        radii = np.broadcast_to(np.asarray(radii_px, float), (len(pins_px),))
    for (u, v), r in zip(pins_px, radii):
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        cv2.circle(frame, (int(round(u * 16)), int(round(v * 16))), int(round(r * 16)), int(foreground), -1, cv2.LINE_AA, shift)
    if noise_std > 0:
        rng = rng if rng is not None else np.random.default_rng(0)
        frame = np.clip(frame + rng.normal(0.0, noise_std, frame.shape), 0, 255).astype(np.uint8)
    return frame

