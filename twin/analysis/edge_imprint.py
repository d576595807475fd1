"""What a sensor's taps on a straight edge carry of the edge, and how an in-contact slide
moves the pins against it: the figures that compare the twin with a real TacTip
(a recording imported by twin.runs.lab_recording beside the twin's own runs).

Unit-free figures, so they compare across cameras:

* signal profile: the edge's orientation signal (each pin's spread over the edge angles,
  RMS over the pins, px) at each lateral position l, over its value at l = 0;
* reach profile: mean |pin displacement| in ten bins across the pin array along the edge
  normal (from beyond the edge to the object side), over the largest bin, at one l;
* signal by ring: the same signal per ring of the pin array (the centre pin, the 6 around
  it, the next 12, …), over the whole array's at l = 0: how far out from the centre the
  pins still read the edge;
* drag / signal: how much more an in-contact slide moves the pins than the edge angle does;
* the along-edge drag in degrees of turn per mm of slide: how far along the orientation
  direction a 1 mm slide along the edge moves the pins, in degrees of the edge angle
  (raw pins), and how far it turns θ_PC23, the angle in the taps' PC2–PC3 plane that the
  paper reads the orientation from; and the share of that drag's energy in the plane;
* the across-edge drag in the same degrees (sheared taps): the slide across the edge,
  which the paper's sensor read far worse than the slide along it;
* the orientation pair by ring: where in the array the taps' rotating pair of PCs (PC2–PC3
  in the paper's taps) moves the pins, ring by ring, and how much of it moves them
  radially (towards or away from the centre) rather than round it;
* closest pins: how near the pins come to each other (each pin's nearest-neighbour
  distance over its distance at rest, the smallest in a frame): where it nears 0 two
  pins' images merge and a tracker loses them.

Plain tap runs (discrete l, θ over a turn) give the spread directly. Sheared-tap runs
(twin.core.scenario.ShearedTapProtocol: random l, θ, depth, slide and twist) are fitted
per lateral bin (1 mm wide, centred on whole mm) with a linear model of each pin
coordinate in θ, the slide along and across the edge, the twist, the depth offset and l
within the bin; the signal and the drag are the spreads of the fitted θ and slide terms
over the run's samples, less what the fit's own error adds to them (an estimated
gradient's noise inflates its spread; onto the object with ~100 taps a bin that can be
most of the raw figure, with the DigiTac set's ~450 a few percent). A run whose angles
span less than a turn (a lab set's ±45°) has its PCs taken over its frames turned by the
pin grid's six-fold symmetry (a 60° turn of the rest pins about their centre maps the
grid onto itself), so PC2–PC3 can turn with θ, each frame's uniform shift (its mean pin
displacement) taken out first: turned, a rigid shift would itself become a rotating pair
and take PC1 and PC2, and the drag (mostly a rigid shift) would then lie in an arbitrary
part of that pair.
Only samples with every pin found and in contact count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from twin.analysis.evaluation import orientation_signal_by_pin_px, orientation_signal_px
from twin.core.errors import UserError
from twin.core.poses import wrap_deg
from twin.core.scenario import SHEARED_TAP_MOTION
from twin.core.sensor import N_PINS
from twin.runs.record import Run
from twin.sensing.perception import pca_fit, pins_to_vectors, without_uniform_shift

#: the linear model's terms for sheared taps (after the constant), per lateral bin
SHEARED_TERMS = ("theta_deg", "slide_along_mm", "slide_lateral_mm", "twist_deg", "depth_offset_mm", "lateral_in_bin_mm")
SLIDE_TERMS = SHEARED_TAP_MOTION
REACH_BINS = 10
#: the equal ranges of depth offset a sheared run's signal is split into by depth
DEPTH_BANDS = 3
#: the lateral positions (mm) of the reach profile unless asked for others: 4 mm onto and off the object
REACH_AT_MM = (-4.0, 4.0)
#: how far (mm) a tap's lateral position may lie from an l asked for and count as there
NEAR_L_MM = 0.5
#: a 60° turn must map every rest pin within this fraction of a pin spacing of another
SYMMETRY_TOLERANCE = 0.35


def usable(run: Run) -> np.ndarray:
    """(N,) bool: samples with pins, every pin found, in contact (not a no-contact frame)."""
    ok = []
    for s in run.samples:
        found = s.get("found")
        ok.append(s["pins_px"] is not None and (found is None or all(found)) and not s["labels"].get("no_contact"))
    return np.array(ok, bool)


def is_sheared(run: Run) -> bool:
    return run.meta["scenario"]["protocol"]["kind"] == "sheared_taps"


@dataclass(frozen=True)
class BinFit:
    """The linear model of one lateral bin: z ≈ z0 + Σ gradient[term]·x[term] (px per unit)."""

    lateral_mm: float
    n: int
    gradients: dict[str, np.ndarray]  # term -> (254,) px per unit of the term
    spread_px: dict[str, float]  # term -> RMS over samples and pins of the term's fitted deviation, less its noise (px)
    mean_z: np.ndarray  # (254,) px: the bin's mean frame
    residual_px: float  # RMS pin distance left unexplained
    tap_z: np.ndarray  # (n, 254) px: the bin's frames with the fitted slide and twist taken out
    signal_shift_share: float  # the θ gradient's energy in a rigid shift of the pins, less its noise
    pin_signal_px: np.ndarray  # (127,) px: each pin's θ term spread, less its noise (`_TermNoise.pin_spread_px`)


def _pin_rms(vectors: np.ndarray) -> float:
    """RMS over rows and pins of the pin distances in (n, 254) vectors (px)."""
    return float(np.sqrt(np.mean(np.sum(vectors.reshape(len(vectors), -1, 2) ** 2, axis=-1))))


class _TermNoise:
    """The least-squares noise in a fitted term's spread. A term's fitted gradient carries
    the fit's error, so the spread of (values × gradient) over the samples is larger than
    the true one on average by the error's share: for terms S, Σ_j s_j² tr(X_Sᵀ X_S (DᵀD)⁻¹_SS)
    over (samples × pins) px², s_j² the unexplained variance of pin coordinate j and D the
    design. The spreads here have it taken out (floored at 0)."""

    def __init__(self, design: np.ndarray, unexplained: np.ndarray) -> None:
        dof = max(len(design) - design.shape[1], 1)
        self.pin_variance_px2 = np.sum(unexplained.reshape(len(unexplained), -1, 2) ** 2, axis=(0, 2)) / dof
        self.variance_px2 = float(np.sum(self.pin_variance_px2))  # Σ_j s_j²
        # the same for the rigid shift's two coordinates, × N_PINS: its share of that noise
        self.shift_variance_px2 = _shift_energy(unexplained) / dof
        self.inverse = np.linalg.pinv(design.T @ design)

    def spread_px(self, x: np.ndarray, coef: np.ndarray, terms: list[int]) -> float:
        """RMS over samples and pins of the terms' fitted deviation, less its noise (px);
        `terms` index the columns of the centred values `x` (coef's rows 1 + term)."""
        xs, cols = x[:, terms], [1 + k for k in terms]
        raw2 = float(np.sum((xs @ coef[cols]) ** 2))
        bias2 = float(np.trace(xs.T @ xs @ self.inverse[np.ix_(cols, cols)])) * self.variance_px2
        return float(np.sqrt(max(raw2 - bias2, 0.0) / (len(x) * N_PINS)))

    def pin_spread_px(self, x: np.ndarray, coef: np.ndarray, term: int) -> np.ndarray:
        """(pins,) px: `spread_px` of one term for each pin's two coordinates alone, so
        that their RMS over the pins is the term's spread (where none is floored)."""
        xt, col = x[:, term], 1 + term
        raw2 = float(xt @ xt) * np.sum(coef[col].reshape(-1, 2) ** 2, axis=1)
        bias2 = float(xt @ xt) * float(self.inverse[col, col]) * self.pin_variance_px2
        return np.sqrt(np.maximum(raw2 - bias2, 0.0) / len(x))

    def shift_share(self, gradient: np.ndarray, term: int) -> float:
        """`translation_share` of a fitted gradient (coef row 1 + term), its noise taken out
        of both energies (the fit's error in the gradient has the residuals' covariance ×
        (DᵀD)⁻¹ on the diagonal; a rigid jitter of the frames lands in the shift). Not
        floored, so that it is unbiased: below 0 it is 0 within its noise."""
        c = float(self.inverse[1 + term, 1 + term])
        shift = _shift_energy(gradient) - c * self.shift_variance_px2
        energy = float(gradient @ gradient) - c * self.variance_px2
        return shift / energy if energy > 0 else float("nan")


def _uniform_shift(vectors: np.ndarray) -> np.ndarray:
    """(n, 2) px: the mean pin displacement (x, y) of each of the (n, 254) vectors."""
    return vectors.reshape(len(vectors), -1, 2).mean(axis=1)


def _shift_energy(vectors: np.ndarray) -> float:
    """px²: the energy of the uniform shifts in the (n, 254) or (254,) vectors, summed: each
    vector's shift moves all N_PINS pins."""
    return N_PINS * float(np.sum(_uniform_shift(np.atleast_2d(vectors)) ** 2))


def sheared_fits(run: Run, width_mm: float = 1.0, min_samples: int = 20) -> list[BinFit]:
    """The per-bin linear fits of a sheared-taps run, from the object side to off it
    (bins centred on multiples of `width_mm`; bins with fewer than `min_samples` usable
    samples are left out, so a small run may have none)."""
    ok = usable(run)
    z = pins_to_vectors(run.pins_px[ok])
    lateral = run.label("lateral_mm")[ok]
    centre = np.round(lateral / width_mm) * width_mm
    values = {t: run.label(t)[ok] for t in SHEARED_TERMS[:-1]}
    values["lateral_in_bin_mm"] = lateral - centre
    fits = []
    for c in sorted(set(centre.tolist())):
        m = centre == c
        if m.sum() < min_samples:
            continue
        x = np.column_stack([values[t][m] for t in SHEARED_TERMS])
        x = x - x.mean(axis=0)
        design = np.column_stack([np.ones(m.sum()), x])
        coef, *_ = np.linalg.lstsq(design, z[m], rcond=None)
        unexplained = z[m] - design @ coef
        noise = _TermNoise(design, unexplained)
        gradients = {t: coef[1 + k] for k, t in enumerate(SHEARED_TERMS)}
        spread = {t: noise.spread_px(x, coef, [k]) for k, t in enumerate(SHEARED_TERMS)}
        spread["slides"] = noise.spread_px(x, coef, [1, 2, 3])
        residual = _pin_rms(unexplained)
        fits.append(
            BinFit(
                float(c) + 0.0,
                int(m.sum()),
                gradients,
                spread,
                z[m].mean(axis=0),
                residual,
                z[m] - x[:, 1:4] @ coef[2:5],
                noise.shift_share(coef[1], 0),
                noise.pin_spread_px(x, coef, 0),
            )
        )
    return fits


def signal_profile(
    run: Run, without_shift: bool = False, fits: list[BinFit] | None = None
) -> dict[float, dict[float, float]]:
    """{depth_mm: {lateral_mm: signal at l over signal at l = 0}}: plain taps per depth;
    sheared taps as one row at their nominal depth (the fitted θ term's spread). Rows
    without an l = 0 are left out. `without_shift`: the signal less its rigid shift of the
    pins (`signal_shift_share`), signal × √(1 − share) at each l: the imprint's change of
    pattern alone. `fits`: a sheared run's `sheared_fits`, where the caller has them."""
    if is_sheared(run):
        fits = sheared_fits(run) if fits is None else fits
        signal = {f.lateral_mm: f.spread_px["theta_deg"] for f in fits}
        rows = {_nominal_depth(run): signal}
    else:
        rows = orientation_signal_px(run.subset(usable(run)))
    if without_shift:
        shares = signal_shift_share(run, fits)
        rows = {
            d: {l: v * np.sqrt(max(1.0 - shares[d][l], 0.0)) for l, v in row.items() if l in shares.get(d, {})}
            for d, row in rows.items()
        }
    return {d: {l: v / row[0.0] for l, v in row.items()} for d, row in rows.items() if row.get(0.0)}


def signal_by_depth(run: Run, bands: int = DEPTH_BANDS) -> dict[float, dict[float, float]]:
    """{depth_mm: {lateral_mm: signal over its mean at l = 0}} of a sheared-taps run, its
    taps split into `bands` equal ranges of their depth offset (keyed by the nominal depth
    plus the range's middle, 0.01 mm): how the signal grows with depth, which the run's one
    row (`signal_profile`) pools. A band's signal is the θ term of `sheared_fits` on its taps
    alone; the bands' l = 0 values average to 1. Empty for plain taps, whose profile is per
    depth already, for a run without a usable tap, and where a band has no l = 0."""
    if not is_sheared(run):
        return {}
    ok = usable(run)
    if not ok.any():
        return {}
    offset = run.label("depth_offset_mm")
    edges = np.linspace(offset[ok].min(), offset[ok].max(), bands + 1)
    band = np.searchsorted(edges[1:-1], offset, side="right")  # the top edge in the last band
    signal = {}
    for k in range(bands):
        depth = round(_nominal_depth(run) + 0.5 * (edges[k] + edges[k + 1]), 2) + 0.0
        fits = sheared_fits(run.subset(ok & (band == k)))
        signal[depth] = {f.lateral_mm: f.spread_px["theta_deg"] for f in fits}
    if not all(row.get(0.0) for row in signal.values()):
        return {}
    centre = float(np.mean([row[0.0] for row in signal.values()]))
    return {d: {l: v / centre for l, v in row.items()} for d, row in signal.items()}


def pin_rings(rest_px: np.ndarray) -> np.ndarray:
    """(pins,) int: each rest pin's ring of the hexagonal layout by distance from the pin
    nearest the layout's centre: ring 0 that pin, ring k the next 6k pins (the nearest 1,
    6, 12, … pins; on the 127-pin dome rings 0–6)."""
    centre = rest_px[np.argmin(np.linalg.norm(rest_px - rest_px.mean(axis=0), axis=1))]
    order = np.argsort(np.linalg.norm(rest_px - centre, axis=1), kind="stable")
    rings = np.empty(len(rest_px), int)
    start, ring = 0, 0
    while start < len(order):
        size = 6 * ring if ring else 1
        rings[order[start : start + size]] = ring
        start, ring = start + size, ring + 1
    return rings


def signal_rings(
    run: Run, at_mm: tuple[float, ...] = (*REACH_AT_MM, 0.0), fits: list[BinFit] | None = None
) -> dict[float, dict[float, list[float]]]:
    """{depth_mm: {lateral_mm: [ring 0, 1, …]}}: where in the pin array the edge's
    orientation signal lies, at the lateral positions nearest each of `at_mm` (within
    0.5 mm; of two as near, the one nearer l = 0): each pin's spread over the edge angles,
    RMS over the pins of each ring (`pin_rings`), over the same RMS over all pins at l = 0
    (so the rings' RMS, weighted by their pins, is the signal profile's value there, where
    no pin's spread is floored at 0). Plain taps per depth; sheared taps as one row at
    their nominal depth (the fitted θ term's, less its noise). `fits`: a sheared run's
    `sheared_fits`, where the caller has them."""
    rings = pin_rings(run.rest_pins_px)
    if is_sheared(run):
        fits = sheared_fits(run) if fits is None else fits
        rows = {_nominal_depth(run): {f.lateral_mm: f.pin_signal_px for f in fits}}
    else:
        rows = orientation_signal_by_pin_px(run.subset(usable(run)))
    n_rings = rings.max() + 1
    table: dict[float, dict[float, list[float]]] = {}
    for d, row in rows.items():
        if 0.0 not in row or not np.any(row[0.0]):
            continue
        whole = float(np.sqrt(np.mean(row[0.0] ** 2)))
        for target in at_mm:
            nearest = min(row, key=lambda l: (abs(l - target), abs(l)))
            if abs(nearest - target) <= NEAR_L_MM + 1e-9:
                by_ring = [float(np.sqrt(np.mean(row[nearest][rings == k] ** 2))) / whole for k in range(n_rings)]
                table.setdefault(d, {})[nearest] = by_ring
    return table


def _nominal_depth(run: Run) -> float:
    """A sheared-taps run's nominal depth (mm): the depth its one row of figures is at."""
    return float(run.meta["scenario"]["protocol"]["depth_mm"])


def signal_shift_share(run: Run, fits: list[BinFit] | None = None) -> dict[float, dict[float, float]]:
    """{depth_mm: {lateral_mm: share}}: how much of the edge's orientation signal is a rigid
    shift of all the pins (the imprint moving as a whole, its direction turning with the
    edge): 0 for an imprint that only changes the pins' pattern, 1 for one that only shifts
    them. Over a turn, such a shift becomes part of the taps' PC2–PC3 pair, and a slide's
    drag, mostly a rigid shift, then lands in the plane the orientation is read from. Plain
    taps per depth: the frames' deviations from their mean over the angles at each l; sheared
    taps as one row at their nominal depth: the fitted θ gradient, less the fit's noise.
    `fits`: a sheared run's `sheared_fits`, where the caller has them."""
    if is_sheared(run):
        fits = sheared_fits(run) if fits is None else fits
        return {_nominal_depth(run): {f.lateral_mm: f.signal_shift_share for f in fits}}
    ok = usable(run)
    pins, depth, lateral = run.pins_px[ok], run.label("depth_mm")[ok], run.label("lateral_mm")[ok]
    table: dict[float, dict[float, float]] = {}
    for d in sorted(set(depth.tolist())):
        for l in sorted(set(lateral[depth == d].tolist()), reverse=True):
            group = pins_to_vectors(pins[(depth == d) & (lateral == l)])
            if len(group) > 1:
                deviation = group - group.mean(axis=0)
                shift = _shift_energy(deviation)
                table.setdefault(float(d), {})[float(l)] = shift / float(np.sum(deviation**2))
    return table


def drag_over_signal(run: Run, fits: list[BinFit] | None = None) -> dict[float, dict[str, float]]:
    """Sheared taps, per lateral bin: {"drag_px": the fitted slide and twist terms' spread,
    "signal_px": the θ term's, "ratio": drag / signal, NaN where the signal is within its
    noise (0 px)}. `fits`: the run's `sheared_fits`, where the caller has them."""
    table = {}
    for f in sheared_fits(run) if fits is None else fits:
        drag, signal = f.spread_px["slides"], f.spread_px["theta_deg"]
        table[f.lateral_mm] = {"drag_px": drag, "signal_px": signal, "ratio": drag / signal if signal > 0 else math.nan}
    return table


# ------------------------------------------------------------------ PCs over a turn
def grid_turn(rest_px: np.ndarray, turns: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pin grid turned by turns·60° about the rest pins' centre: (permutation p with
    pin i landing on pin p[i], 2×2 rotation (image px), centre px). UserError when the
    grid does not map onto itself within SYMMETRY_TOLERANCE spacings."""
    centre = rest_px.mean(axis=0)
    a = np.radians(60.0 * turns)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    moved = (rest_px - centre) @ rot.T + centre
    distance = np.linalg.norm(moved[:, None] - rest_px[None], axis=-1)
    perm = np.argmin(distance, axis=1)
    spacing = float(np.median(np.sort(np.linalg.norm(rest_px[:, None] - rest_px[None], axis=-1), axis=1)[:, 1]))
    off = distance[np.arange(len(perm)), perm].max()
    if len(set(perm.tolist())) != len(perm) or off > SYMMETRY_TOLERANCE * spacing:
        raise UserError(
            f"a {60 * turns}° turn does not map the rest pins onto themselves "
            f"({off:.1f} px off, pin spacing {spacing:.1f} px)"
        )
    return perm, rot, centre


def turned_frames(pins_px: np.ndarray, rest_px: np.ndarray) -> np.ndarray:
    """(6N, 127, 2) px: the frames and their five turns by the grid's symmetry (`grid_turn`).
    A turn turns each pin's displacement from rest and sets it on the rest pin it lands on:
    a real grid maps onto itself only to within its rest pins' scatter (the DigiTac set's:
    0.7 px RMS, up to 2.2 px), which turning the pins themselves would add to every turned
    frame as a fixed pattern of its own, as large as the edge's signal."""
    out = [pins_px]
    displacement = pins_px - rest_px
    for k in range(1, 6):
        perm, rot, _ = grid_turn(rest_px, k)
        turned = np.empty_like(pins_px)
        turned[:, perm] = displacement @ rot.T + rest_px[perm]
        out.append(turned)
    return np.concatenate(out)


@dataclass(frozen=True)
class TapPCs:
    """A tap set's first three PCs; PC2–PC3 is the plane the paper reads the orientation in.

    Turned sets are fitted to frames without their uniform shift, so their components are
    orthogonal to every rigid shift of the pins: a frame's or a field's shift projects to
    nothing, and `project`, `theta_pc23_deg` and `plane_share` need no step of their own."""

    mean: np.ndarray  # (254,) px
    components: np.ndarray  # (3, 254)
    explained: np.ndarray  # (3,) fractions (turned: of the variance without the frames' uniform shifts)
    turned: bool  # over the frames turned by the grid's symmetry, each frame's uniform shift taken out
    pair: tuple[int, int] = (1, 2)  # PC2, PC3 (0-based)

    def project(self, z: np.ndarray) -> np.ndarray:
        return (np.atleast_2d(z) - self.mean) @ self.components.T

    def in_plane(self, z: np.ndarray) -> np.ndarray:
        """(n, 2) px: frames' coordinates in the PC2–PC3 plane."""
        return self.project(z)[:, list(self.pair)]

    def theta_pc23_deg(self, z: np.ndarray) -> np.ndarray:
        """The angle (deg) of frames in the PC2–PC3 plane: the paper's θ_PC23."""
        p = self.in_plane(z)
        return np.degrees(np.arctan2(p[:, 1], p[:, 0]))

    def field_in_plane(self, field: np.ndarray) -> np.ndarray:
        """(2,) px: a displacement field's (254,) part in the PC2–PC3 plane (no mean taken:
        a field moves a frame by this much there)."""
        return self.components[list(self.pair)] @ field

    def plane_energy(self, field: np.ndarray) -> float:
        """px²: a displacement field's (254,) energy in the PC2–PC3 plane."""
        return float(np.sum(self.field_in_plane(field) ** 2))

    def plane_share(self, field: np.ndarray) -> float | None:
        """The share of a displacement field's energy (254,) in the PC2–PC3 plane (of its
        whole energy, any rigid shift in it included); None for a field that moves nothing
        (a frictionless slide's)."""
        energy = float(field @ field)
        return self.plane_energy(field) / energy if energy > 0.0 else None


def tap_pcs(run: Run, fits: list[BinFit] | None = None) -> TapPCs:
    """The PCs of a tap run's usable frames (sheared taps: with their fitted slide and
    twist taken out, the taps the paper's PCA is of); over their six-fold turns, each
    frame's uniform shift taken out, when its angles span less than 300° (a lab set's ±45°).
    `fits`: a sheared run's `sheared_fits`, where the caller has them."""
    ok = usable(run)
    theta = run.label("theta_deg")[ok]
    if fits is None:
        fits = sheared_fits(run) if is_sheared(run) else []
    pins = np.concatenate([f.tap_z for f in fits]).reshape(-1, 127, 2) if fits else run.pins_px[ok]
    turned = np.ptp(theta) < 300.0
    if turned:
        pins = turned_frames(without_uniform_shift(pins, run.rest_pins_px), run.rest_pins_px)
    mean, comps, explained = pca_fit(pins_to_vectors(pins), 3)
    return TapPCs(mean, comps, explained, turned)


def rotating_pair(explained: np.ndarray) -> tuple[int, int]:
    """The two of a tap set's first three PCs (0-based) whose explained variances lie
    closest: the edge's orientation, a rotating pair of equal variance. PC2–PC3, (1, 2),
    where the press outweighs it, as in the paper's taps and the DigiTac set's; where the
    pair outweighs the press it is PC1–PC2, and θ_PC23 reads one half of it and the press."""
    return min(((1, 2), (0, 1), (0, 2)), key=lambda p: abs(explained[p[0]] - explained[p[1]]))


def pair_rings(pcs: TapPCs, rest_px: np.ndarray) -> dict[str, list[float | None]]:
    """Where in the pin array the edge's orientation pair (`rotating_pair`) moves the pins,
    and how: "energy", each ring's share of the pair's energy (`pin_rings`, centre → rim;
    they sum to 1), and "radial", the share of a ring's part that moves its pins along
    their direction from the centre pin in the image rather than round it (None for the
    centre pin, which has no such direction, and for a ring the pair leaves still)."""
    rings = pin_rings(rest_px)
    pair = pcs.components[list(rotating_pair(pcs.explained))].reshape(2, -1, 2)
    outward = rest_px - rest_px[rings == 0][0]
    outward = outward / np.maximum(np.linalg.norm(outward, axis=1, keepdims=True), 1e-12)
    radial = np.sum(np.einsum("kpi,pi->kp", pair, outward) ** 2, axis=0)
    total = np.sum(pair**2, axis=(0, 2))
    energy, share = [], []
    for k in range(rings.max() + 1):
        ring_energy = float(total[rings == k].sum())
        energy.append(ring_energy / float(total.sum()))
        share.append(float(radial[rings == k].sum()) / ring_energy if k and ring_energy > 1e-12 else None)
    return {"energy": energy, "radial": share}


def along_edge_turn_sheared(
    run: Run, pcs: TapPCs | None = None, fits: list[BinFit] | None = None
) -> dict[float, dict[str, float]]:
    """Sheared taps, per lateral bin, for a 1 mm slide along the edge: "raw_deg_per_mm" (its
    pin field along the orientation direction, in degrees of θ: g_a·g_θ / |g_θ|²),
    "pc23_deg_per_mm" (how far it turns θ_PC23 from the bin's mean frame), "plane_share"
    (its energy in the taps' PC2–PC3 plane), "radius_px" (the bin's RMS radius in that plane)
    and "offset_deg" (`pressed_offset_deg`).
    `fits`: the run's `sheared_fits`, where the caller has them."""
    fits = sheared_fits(run) if fits is None else fits
    if not fits:  # no bin with enough taps (a small run, or a resample of one)
        return {}
    pcs = pcs or tap_pcs(run, fits)
    out = {}
    for f in fits:
        g_a = f.gradients["slide_along_mm"]
        p = pcs.in_plane(f.tap_z)
        out[f.lateral_mm] = {
            **_slide_turn(pcs, f, "slide_along_mm"),
            "plane_share": pcs.plane_share(g_a),
            "radius_px": float(np.sqrt(np.mean(np.sum(p**2, axis=1)))),
            "translation_share": translation_share(g_a),
            "offset_deg": pressed_offset_deg(pcs, f),
        }
    return out


def across_edge_turn_sheared(
    run: Run, pcs: TapPCs | None = None, fits: list[BinFit] | None = None
) -> dict[float, dict[str, float]]:
    """Sheared taps, per lateral bin, for a 1 mm slide across the edge (onto or off the
    object, ending at the tap's pose): "raw_deg_per_mm" and "pc23_deg_per_mm" as in
    `along_edge_turn_sheared`. The paper's Table I reads slides across the edge far worse
    than along it (22–53° On against 3.3° and 12.7°); onto the object the DigiTac set's
    drag turns θ_PC23 three to eight times as far per mm across the edge as along it.
    `fits`: the run's `sheared_fits`, where the caller has them."""
    fits = sheared_fits(run) if fits is None else fits
    if not fits:
        return {}
    pcs = pcs or tap_pcs(run, fits)
    return {f.lateral_mm: _slide_turn(pcs, f, "slide_lateral_mm") for f in fits}


def _slide_turn(pcs: TapPCs, fit: BinFit, term: str) -> dict[str, float]:
    """A 1 mm slide's (the fitted gradient of `term`) "raw_deg_per_mm", its pin field along
    the orientation direction in degrees of θ (g·g_θ / |g_θ|²), and "pc23_deg_per_mm", how far
    it turns θ_PC23 from the bin's mean frame."""
    g, g_t = fit.gradients[term], fit.gradients["theta_deg"]
    turn = wrap_deg(pcs.theta_pc23_deg(fit.mean_z + g) - pcs.theta_pc23_deg(fit.mean_z))[0]
    return {"raw_deg_per_mm": abs(float(g @ g_t / (g_t @ g_t))), "pc23_deg_per_mm": abs(float(turn))}


def plane_angle_deg(a: TapPCs, b: TapPCs) -> float:
    """The larger principal angle (deg) between two tap sets' PC2–PC3 planes: 0 where they
    are one plane. The along-edge drag is some 20 times its part in the plane, so a few
    degrees between the planes move θ_PC23's turn per mm by as much as the drag itself."""
    cosines = np.linalg.svd(a.components[list(a.pair)] @ b.components[list(b.pair)].T, compute_uv=False)
    return float(np.degrees(np.arccos(np.clip(cosines.min(), -1.0, 1.0))))


def carried_pcs(pcs: TapPCs, of: Run, onto: Run) -> TapPCs:
    """The PCs `pcs` of run `of`'s taps carried onto run `onto`'s rest pins, so that its
    frames project by their displacements."""
    moved = pins_to_vectors((onto.rest_pins_px - of.rest_pins_px)[None])[0]
    return replace(pcs, mean=pcs.mean + moved)


def turn_in_reference_plane(
    reference: Run,
    run: Run,
    reference_pcs: TapPCs | None = None,
    pcs: TapPCs | None = None,
    fits: list[BinFit] | None = None,
) -> dict:
    """How far a 1 mm slide along the edge turns `run`'s taps read in `reference`'s PC2–PC3
    plane rather than its own: "angle_deg" (`plane_angle_deg`) and "pc23_deg_per_mm" {l:
    deg/mm} (`along_edge_turn_sheared` of the run's own fits, in the reference's PCs carried
    onto the run's rest pins, so that its frames project by their displacements); and
    "across_pc23_deg_per_mm", the same for a slide across the edge (`across_edge_turn_sheared`).
    Beside the run's own turn it splits a miss of θ_PC23 into the drag's and the plane's
    (`twin compare`'s, through calibration_fit.figures.paired_figures). `reference_pcs`,
    `pcs`: the reference's and the run's `tap_pcs`, and `fits`: the run's `sheared_fits`,
    where the caller has them."""
    fits = sheared_fits(run) if fits is None else fits
    ref = tap_pcs(reference) if reference_pcs is None else reference_pcs
    own = tap_pcs(run, fits) if pcs is None else pcs
    plane = carried_pcs(ref, reference, run)
    along, across = along_edge_turn_sheared(run, plane, fits), across_edge_turn_sheared(run, plane, fits)
    return {
        "angle_deg": plane_angle_deg(ref, own),
        "pc23_deg_per_mm": {l: v["pc23_deg_per_mm"] for l, v in along.items()},
        "across_pc23_deg_per_mm": {l: v["pc23_deg_per_mm"] for l, v in across.items()},
    }


def pressed_offset_deg(pcs: TapPCs, fit: BinFit) -> float:
    """The angle (deg) of a bin's mean frame in PC2–PC3 from the direction a pure turn about
    the plane's centre would put it: perpendicular to the θ term's direction in the plane,
    on the mean frame's side. Positive: the frame sits ahead along increasing θ, as a fixed
    imprint added to the bin's taps (a tilted mount's) would put it; 0: the taps turn about
    the centre, as the paper's reading of θ_PC23 assumes."""
    m = pcs.in_plane(fit.mean_z)[0]
    ahead = pcs.field_in_plane(fit.gradients["theta_deg"])
    ahead /= np.linalg.norm(ahead)
    radial = np.array([ahead[1], -ahead[0]])
    if m @ radial < 0:
        radial = -radial
    return float(np.degrees(np.arctan2(m @ ahead, m @ radial)))


def along_edge_turn_slides(
    taps: Run, slides: Run, lateral_mm: float | None = None, pcs: TapPCs | None = None
) -> dict[str, float] | None:
    """The same figures from a slides run's along-edge slides (90°, 270°), their first step
    (sample 0 → 1), with the PCs and orientation direction of a plain tap run: the taps at
    the slides' lateral position, θ ± one orientation step, averaged over depths.
    None without such slides."""
    pcs = pcs or tap_pcs(taps)
    z_taps = pins_to_vectors(taps.pins_px)
    t_theta, t_lat = taps.label("theta_deg"), taps.label("lateral_mm")
    thetas = np.unique(t_theta[np.isfinite(t_theta)])
    step = float(np.min(np.diff(thetas))) if len(thetas) > 1 else None
    z = pins_to_vectors(slides.pins_px)
    direction, sample, theta = slides.label("direction_deg"), slides.label("sample_in_slide"), slides.label("theta_deg")
    lateral = slides.label("lateral_mm")
    raw, turns, energy_in, energy, radius, shift = [], [], 0.0, 0.0, [], 0.0
    for d in (90, 270):
        for t in np.unique(theta[direction == d]):
            first = np.flatnonzero((direction == d) & (theta == t) & (sample == 0))
            second = np.flatnonzero((direction == d) & (theta == t) & (sample == 1))
            if len(first) != 1 or len(second) != 1:
                continue
            i, j = first[0], second[0]
            l0 = lateral[i] if lateral_mm is None else lateral_mm
            if abs(lateral[i] - l0) > 1e-6:
                continue
            length = float(
                np.linalg.norm(np.subtract(slides.samples[j]["target"][:2], slides.samples[i]["target"][:2]))
            )
            g_a = (z[j] - z[i]) / length
            turns.append(abs(wrap_deg(pcs.theta_pc23_deg(z[j]) - pcs.theta_pc23_deg(z[i]))[0]) / length)
            energy_in += pcs.plane_energy(g_a)
            energy += float(g_a @ g_a)
            shift += _shift_energy(g_a)
            radius.append(float(np.linalg.norm(pcs.in_plane(z[i])[0])))
            if step is not None:
                at = np.isclose(t_lat, l0)
                plus = at & np.isclose(wrap_deg(t_theta - t - step), 0.0)
                minus = at & np.isclose(wrap_deg(t_theta - t + step), 0.0)
                if plus.any() and minus.any():
                    g_t = (z_taps[plus].mean(axis=0) - z_taps[minus].mean(axis=0)) / (2 * step)
                    raw.append(abs(float(g_a @ g_t / (g_t @ g_t))))
    if not turns:
        return None
    return {
        "raw_deg_per_mm": float(np.mean(raw)) if raw else None,
        "pc23_deg_per_mm": float(np.mean(turns)),
        "plane_share": energy_in / energy if energy > 0.0 else None,
        "radius_px": float(np.sqrt(np.mean(np.square(radius)))),
        "translation_share": shift / energy if energy > 0.0 else None,
    }


def translation_share(field: np.ndarray) -> float | None:
    """The share of a displacement field's energy (254,) in a rigid shift of all the pins;
    None for a field that moves nothing."""
    energy = float(field @ field)
    return _shift_energy(field) / energy if energy > 0.0 else None


# ------------------------------------------------------------------ closest pins
def nearest_neighbour_px(pins_px: np.ndarray) -> np.ndarray:
    """(n,) each pin's distance to its nearest neighbour, px, for (n, 2) pins."""
    distance, _ = cKDTree(pins_px).query(pins_px, k=2)
    return distance[:, 1]


def closest_pins(run: Run) -> dict[float, dict[float, dict[str, float]]]:
    """{depth_mm: {lateral_mm: {"min", "median", "lost"}}}: how near the pins come to each
    other. Per in-contact sample, each found pin's distance to its nearest found neighbour
    over its nearest-neighbour distance at rest, the smallest over the pins (1: no pin
    nearer a neighbour than at rest; 0: two pins in one place); its minimum and median over
    the samples at each l, and "lost": the share of those samples with a pin not found.
    Pin by pin, so a lens's magnification across the image cancels; found pins only, so a
    real sensor's frames that lost a pin count too. Plain taps per depth; sheared taps in
    1 mm lateral bins as one row at their nominal depth."""
    rest_px = nearest_neighbour_px(run.rest_pins_px)
    ratio, lost, lateral, depth = [], [], [], []
    sheared = is_sheared(run)
    for s in run.samples:
        if s["pins_px"] is None or s["labels"].get("no_contact"):
            continue
        found = np.ones(127, bool) if s.get("found") is None else np.asarray(s["found"], bool)
        if found.sum() < 2:
            continue
        pins = np.asarray(s["pins_px"], float)[found]
        ratio.append(np.min(nearest_neighbour_px(pins) / rest_px[found]))
        lost.append(not found.all())
        lateral.append(np.round(s["labels"]["lateral_mm"]) + 0.0 if sheared else s["labels"]["lateral_mm"])
        depth.append(_nominal_depth(run) if sheared else s["labels"]["depth_mm"])
    ratio, lost, lateral, depth = (np.array(v, float) for v in (ratio, lost, lateral, depth))
    rows: dict[float, dict[float, dict[str, float]]] = {}
    for d in sorted(set(depth.tolist())):
        for l in sorted(set(lateral[depth == d].tolist())):
            m = (depth == d) & (lateral == l)
            rows.setdefault(float(d), {})[float(l)] = {
                "min": float(ratio[m].min()),
                "median": float(np.median(ratio[m])),
                "lost": float(lost[m].mean()),
            }
    return rows


# ------------------------------------------------------------------ reach
def edge_normal_in_image(run: Run) -> tuple[float, float]:
    """(φ0 deg, σ ±1) with the image direction of the edge's outward normal (off the
    object) at edge angle θ being φ0 + σ·θ: fitted from where the pins move most (the
    displacement-weighted centroid of the rest pins lies towards the object)."""
    rest = run.rest_pins_px
    d = np.linalg.norm(run.pins_px - rest, axis=-1)
    ok = usable(run) & (np.nan_to_num(d).sum(axis=1) > 0)
    d = d[ok]
    centroid = (d @ (rest - rest.mean(axis=0))) / d.sum(axis=1, keepdims=True)
    towards_object = np.degrees(np.arctan2(centroid[:, 1], centroid[:, 0]))
    theta = run.label("theta_deg")[ok]
    weight = np.linalg.norm(centroid, axis=1)
    best = None
    for sigma in (1.0, -1.0):
        phase = np.radians(towards_object + 180.0 - sigma * theta)
        mean = np.sum(weight * np.exp(1j * phase))
        if best is None or abs(mean) > abs(best[1]):
            best = (sigma, mean)
    return float(np.degrees(np.angle(best[1]))), best[0]


def normal_bins(rest_px: np.ndarray, normal: tuple[float, float], theta_deg: float, bins: int) -> np.ndarray:
    """(pins,) int: each rest pin's bin of `bins` equal bins of its position along the edge's
    outward normal in the image at edge angle `theta_deg`, 0 = furthest beyond the edge, the
    last on the object side; `normal` is edge_normal_in_image's (φ0 deg, σ)."""
    phi0, sigma = normal
    a = np.radians(phi0 + sigma * theta_deg)
    along = (rest_px - rest_px.mean(axis=0)) @ np.array([np.cos(a), np.sin(a)])  # + beyond the edge
    edges = np.linspace(along.max(), along.min(), bins + 1)
    return np.clip(np.searchsorted(-edges, -along, side="right") - 1, 0, bins - 1)


def reach_profile(run: Run, lateral_mm: float, half_width_mm: float = NEAR_L_MM, bins: int = REACH_BINS) -> list[float]:
    """Mean |pin displacement| (px) in `bins` equal bins of the rest pins' position along the
    edge normal in the image, from beyond the edge (far) to the object side, over the
    largest bin; over the usable samples within `half_width_mm` of `lateral_mm`."""
    ok = usable(run) & (np.abs(run.label("lateral_mm") - lateral_mm) <= half_width_mm + 1e-9)
    if not ok.any():
        raise UserError(f"{run.path}: no usable sample within {half_width_mm} mm of l = {lateral_mm} mm")
    normal = edge_normal_in_image(run)
    total = np.zeros(bins)
    for pins, theta in zip(run.pins_px[ok], run.label("theta_deg")[ok]):
        index = normal_bins(run.rest_pins_px, normal, theta, bins)
        magnitude = np.linalg.norm(pins - run.rest_pins_px, axis=-1)
        total += np.bincount(index, magnitude, bins) / np.maximum(np.bincount(index, minlength=bins), 1)
    return (total / total.max()).tolist()


def edge_figures(taps: Run, slides: Run | None = None, reach_at: tuple[float, ...] = REACH_AT_MM) -> dict:
    """Every figure of this module for one sensor: a tap run (plain or sheared) and, for
    plain taps, a slides run for the along-edge drag (its slides at their first lateral
    position). `reach_at`: the l (mm) of the reach profiles; those with no tap within 0.5 mm
    are left out. Keys: signal_profile, signal_by_depth, signal_shift_share, reach (l → ten
    bins), signal_rings (at the reach's l and l = 0), closest_pins, pcs_explained,
    pcs_turned, pair_rings, drag_over_signal, along_edge (l → figures; sheared taps, or
    plain taps with slides) and across_edge (l → figures; sheared taps)."""
    fits = sheared_fits(taps) if is_sheared(taps) else None
    pcs = tap_pcs(taps, fits)
    lateral = taps.label("lateral_mm")[usable(taps)]
    figures = {
        "name": taps.meta["scenario"]["name"],
        "kind": taps.meta["scenario"]["protocol"]["kind"],
        "signal_profile": signal_profile(taps, fits=fits),
        "signal_by_depth": signal_by_depth(taps),
        "signal_shift_share": signal_shift_share(taps, fits),
        "reach": {l: reach_profile(taps, l) for l in reach_at if np.any(np.abs(lateral - l) <= NEAR_L_MM + 1e-9)},
        "signal_rings": signal_rings(taps, (*reach_at, 0.0), fits),
        "closest_pins": closest_pins(taps),
        "pcs_explained": pcs.explained.tolist(),
        "pcs_turned": pcs.turned,
        "pair_rings": pair_rings(pcs, taps.rest_pins_px),
        "drag_over_signal": {},
        "along_edge": {},
        "across_edge": {},
    }
    if is_sheared(taps):
        figures["drag_over_signal"] = drag_over_signal(taps, fits)
        figures["along_edge"] = along_edge_turn_sheared(taps, pcs, fits)
        figures["across_edge"] = across_edge_turn_sheared(taps, pcs, fits)
    elif slides is not None:
        starts = np.isin(slides.label("direction_deg"), (90, 270)) & (slides.label("sample_in_slide") == 0)
        for l in sorted(set(slides.label("lateral_mm")[starts].tolist())):
            turn = along_edge_turn_slides(taps, slides, l, pcs)
            if turn is not None:
                figures["along_edge"][float(l)] = turn
    return figures
