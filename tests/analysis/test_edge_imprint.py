"""The edge figures (twin.analysis.edge_imprint) on synthetic runs whose pins are built
from known fields, so every figure has a value worked out beforehand."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.analysis import edge_imprint as E
from twin.analysis.calibration_fit.figures import figure_values
from twin.core.poses import wrap_deg
from twin.core.scenario import ShearedTapProtocol
from twin.runs.protocols import drawn_sheared_taps
from twin.runs.record import Run
from twin.sensing.perception import pca_fit, pins_to_vectors
from twin.sensing.tracker import template_pins_px

REST = template_pins_px()
#: the orientation signal's size per lateral bin (× its value at l = 0): the edge fades onto the object
FADE = {-2.0: 0.4, -1.0: 0.7, 0.0: 1.0, 1.0: 1.2, 2.0: 1.3}
K_DEG_PER_MM = 6.0  # the along-edge drag's part along the orientation field at l = 0, deg of θ per mm


def _fields(seed: int = 1) -> dict[str, np.ndarray]:
    """Fixed displacement fields (127, 2) px: θ (per 45°), along-edge drag (per mm) = a
    part along θ's field plus a rigid shift orthogonal to it, across-edge drag, twist, depth."""
    rng = np.random.default_rng(seed)
    theta = rng.normal(0, 1.0, REST.shape)
    shift = np.tile([1.0, -0.5], (127, 1))
    shift -= (shift.ravel() @ theta.ravel()) / (theta.ravel() @ theta.ravel()) * theta  # orthogonal to θ's field
    return {
        "theta": theta,
        "shift": shift,
        "along": K_DEG_PER_MM / 45.0 * theta + shift,
        "across": rng.normal(0, 1.0, REST.shape),
        "twist": rng.normal(0, 0.3, REST.shape),
        "depth": rng.normal(0, 0.5, REST.shape),
    }


def _sheared(displacement, n: int, seed: int, noise_px: float, noise_seed: int | None = None) -> Run:
    """A sheared-taps run (lateral −2.5 … 2.5 mm, θ ±45°) with pins = rest +
    `displacement(tap)` (127, 2) px + Gaussian noise (drawn from `noise_seed`; default
    seed + 1): the taps are the seed's, so two runs of one seed hold the same taps."""
    protocol = ShearedTapProtocol(taps=n, seed=seed, lateral_range_mm=[-2.5, 2.5])
    rng = np.random.default_rng(seed + 1 if noise_seed is None else noise_seed)
    samples = []
    for k, tap in enumerate(drawn_sheared_taps(protocol)):
        pins = REST + displacement(tap) + rng.normal(0, noise_px, REST.shape)
        labels = {**tap.model_dump(), "depth_mm": protocol.depth_mm + tap.depth_offset_mm, "tap": k}
        samples.append(
            {"index": k, "target": [0.0] * 6, "labels": labels, "pins_px": pins.tolist(), "found": [True] * 127}
        )
    meta = {"scenario": {"name": "synthetic", "protocol": protocol.model_dump()}, "rest_pins_px": REST.tolist()}
    return Run(Path("synthetic"), meta, samples)


def sheared_run(
    n: int = 1500, seed: int = 0, noise_px: float = 0.01, fade: dict | None = None, noise_seed: int | None = None
) -> Run:
    """A sheared-taps run with pins = rest + the fields × the tap's values (`fade`: the
    signal's size per lateral bin, FADE unless given)."""
    f = _fields()
    fades = FADE if fade is None else fade

    def displacement(tap) -> np.ndarray:
        fade = fades[float(np.round(tap.lateral_mm)) + 0.0]
        return (
            fade * tap.theta_deg / 45.0 * f["theta"]
            + tap.slide_along_mm / fade * f["along"]
            + tap.slide_lateral_mm * f["across"]
            + tap.twist_deg * f["twist"]
            + tap.depth_offset_mm * f["depth"]
        )

    return _sheared(displacement, n, seed, noise_px, noise_seed)


@pytest.fixture(scope="module")
def run() -> Run:
    return sheared_run()


def test_the_fit_separates_the_drag_from_the_orientation(run: Run) -> None:
    f = _fields()
    fits = {b.lateral_mm: b for b in E.sheared_fits(run)}
    assert sorted(fits) == sorted(FADE)
    for l, fade in FADE.items():
        g = fits[l].gradients
        np.testing.assert_allclose(g["theta_deg"], (fade / 45.0 * f["theta"]).ravel(), atol=2e-3)
        np.testing.assert_allclose(g["slide_along_mm"], (f["along"] / fade).ravel(), atol=2e-3)
        np.testing.assert_allclose(g["twist_deg"], f["twist"].ravel(), atol=2e-3)
        assert fits[l].residual_px < 0.02


def test_signal_profile_is_the_fade_relative_to_the_edge_through_the_centre(run: Run) -> None:
    """The θ term's spread in a bin is fade × the spread of the bin's angles × the field's RMS."""
    profile = E.signal_profile(run)
    theta, bins = run.label("theta_deg"), np.round(run.label("lateral_mm")) + 0.0
    spread = {l: fade * np.std(theta[bins == l]) for l, fade in FADE.items()}
    assert list(profile) == [3.0]
    assert profile[3.0] == pytest.approx({l: v / spread[0.0] for l, v in spread.items()}, rel=0.01)


def test_the_signal_by_depth_is_its_growth_with_the_press() -> None:
    """An orientation field that grows by 30 % per mm of depth offset: each band of the taps'
    offsets reads fade × (1 + 0.3 × the band's mean offset) × its angles' spread, over the
    bands' mean at l = 0; the one pooled row cannot show that growth."""
    growth = 0.3
    f = _fields()

    def displacement(tap) -> np.ndarray:
        fade = FADE[float(np.round(tap.lateral_mm)) + 0.0] * (1.0 + growth * tap.depth_offset_mm)
        return (
            fade * tap.theta_deg / 45.0 * f["theta"]
            + tap.slide_lateral_mm * f["across"]
            + tap.depth_offset_mm * f["depth"]
        )

    run = _sheared(displacement, 3000, 5, 0.01)
    table = E.signal_by_depth(run)
    offset, theta = run.label("depth_offset_mm"), run.label("theta_deg")
    bins = np.round(run.label("lateral_mm")) + 0.0
    edges = np.linspace(offset.min(), offset.max(), E.DEPTH_BANDS + 1)
    band = np.clip(np.searchsorted(edges, offset, side="right") - 1, 0, E.DEPTH_BANDS - 1)
    expected = [
        {
            l: fade * (1 + growth * offset[m].mean()) * theta[m].std()
            for l, fade in FADE.items()
            if (m := (band == k) & (bins == l)).any()
        }
        for k in range(E.DEPTH_BANDS)
    ]
    centre = np.mean([row[0.0] for row in expected])
    assert list(table) == [round(3.0 + 0.5 * (edges[k] + edges[k + 1]), 2) for k in range(E.DEPTH_BANDS)]
    for row, want in zip(table.values(), expected):
        assert row == pytest.approx({l: v / centre for l, v in want.items()}, rel=0.02)
    shallow, _, deep = table.values()
    assert deep[0.0] / shallow[0.0] == pytest.approx((1 + growth * 2 / 3) / (1 - growth * 2 / 3), rel=0.05)
    plain = Run(Path("synthetic"), {"scenario": {"protocol": {"kind": "taps"}}, "rest_pins_px": REST.tolist()}, [])
    assert E.signal_by_depth(plain) == {}  # plain taps: their profile is per depth already


def test_along_edge_drag_in_degrees_per_mm(run: Run) -> None:
    """g_a·g_θ / |g_θ|² = (K/45 / fade) / (fade / 45) deg/mm = K / fade²; the rigid shift is
    orthogonal to θ's field, so it adds nothing but is most of the drag's energy."""
    f = _fields()
    for l, figures in E.along_edge_turn_sheared(run).items():
        assert figures["raw_deg_per_mm"] == pytest.approx(K_DEG_PER_MM / FADE[l] ** 2, rel=0.01)
        expected_shift = np.sum(f["along"].mean(axis=0) ** 2) * 127 / np.sum(f["along"] ** 2)  # > 0.9 by design
        assert figures["translation_share"] == pytest.approx(expected_shift, rel=0.01)
        assert 0.0 <= figures["plane_share"] <= 1.0


def test_across_edge_drag_in_degrees_per_mm(run: Run) -> None:
    """g_x·g_θ / |g_θ|² with g_x the across-edge field and g_θ = fade/45 × θ's field, and the
    calibration's figure is the same turn through θ_PC23."""
    f = _fields()
    across = E.across_edge_turn_sheared(run)
    assert sorted(across) == sorted(FADE)
    for l, figures in across.items():
        expected = abs(np.sum(f["across"] * f["theta"])) / (FADE[l] / 45.0 * np.sum(f["theta"] ** 2))
        assert figures["raw_deg_per_mm"] == pytest.approx(expected, rel=0.01)
    values = figure_values(run)
    assert {l: v["pc23_deg_per_mm"] for l, v in across.items()} == {l: values["theta_pc23_across", l] for l in across}


def test_drag_over_signal_is_the_slides_pin_motion_against_the_angles(run: Run) -> None:
    """Drag: the RMS pin motion of each tap's slide and twist (from the known fields) about
    the bin's mean; signal: that of its angle."""
    f = _fields()
    bins = np.round(run.label("lateral_mm")) + 0.0
    x = {k: run.label(k) for k in ("theta_deg", "slide_along_mm", "slide_lateral_mm", "twist_deg")}
    figures = E.drag_over_signal(run)
    for l, fade in FADE.items():
        m = bins == l
        c = {k: v[m] - v[m].mean() for k, v in x.items()}
        drag = (
            c["slide_along_mm"][:, None, None] / fade * f["along"]
            + c["slide_lateral_mm"][:, None, None] * f["across"]
            + c["twist_deg"][:, None, None] * f["twist"]
        )
        signal = c["theta_deg"][:, None, None] * fade / 45.0 * f["theta"]
        rms = {"drag_px": np.sqrt(np.mean(np.sum(drag**2, -1))), "signal_px": np.sqrt(np.mean(np.sum(signal**2, -1)))}
        assert figures[l]["drag_px"] == pytest.approx(rms["drag_px"], rel=0.01)
        assert figures[l]["signal_px"] == pytest.approx(rms["signal_px"], rel=0.01)
        assert figures[l]["ratio"] == pytest.approx(rms["drag_px"] / rms["signal_px"], rel=0.02)
    assert figures[-2.0]["ratio"] > figures[0.0]["ratio"] > figures[2.0]["ratio"]


def test_the_signal_is_not_inflated_by_the_fits_noise() -> None:
    """With 2 px of noise on every pin coordinate and ~300 taps a bin, the fitted θ
    gradient's error adds about (2 × 2² / 300)^½ = 0.16 px to a spread of 0.33–1.1 px in
    quadrature: 12 % at l = −2 mm. The figure is the true spread (fade × std θ / 45 × the
    field's RMS, worked out from the fields) within its own scatter (~3 %)."""
    noisy = sheared_run(noise_px=2.0, seed=4)
    f = _fields()
    theta, bins = noisy.label("theta_deg"), np.round(noisy.label("lateral_mm")) + 0.0
    field_rms = np.sqrt(np.mean(np.sum(f["theta"] ** 2, axis=-1)))
    figures = E.drag_over_signal(noisy)
    for l, fade in FADE.items():
        true = fade * np.std(theta[bins == l]) / 45.0 * field_rms
        assert figures[l]["signal_px"] == pytest.approx(true, rel=0.07), l


def test_plane_and_shift_shares() -> None:
    comps = np.zeros((3, 254))
    comps[0, 0] = comps[1, 1] = comps[2, 2] = 1.0
    pcs = E.TapPCs(np.zeros(254), comps, np.array([0.5, 0.2, 0.2]), False)
    field = np.zeros(254)
    field[[0, 1, 2, 3]] = [1.0, 1.0, 1.0, 1.0]  # energy 4: 2 of it on PC2 and PC3
    assert pcs.plane_share(field) == pytest.approx(0.5)
    assert E.translation_share(np.tile([0.3, -0.2], 127)) == pytest.approx(1.0)
    assert E.translation_share(np.ravel(REST - REST.mean(axis=0))) == pytest.approx(0.0, abs=1e-12)
    # a field that moves nothing (a frictionless slide's) has no shares, rather than 0 / 0
    assert pcs.plane_share(np.zeros(254)) is None and E.translation_share(np.zeros(254)) is None


def test_a_sixth_of_a_turn_maps_the_grid_onto_itself() -> None:
    perm, rot, centre = E.grid_turn(REST, 1)
    np.testing.assert_allclose((REST - centre) @ rot.T + centre, REST[perm], atol=0.35 * 32.6)
    six = E.turned_frames(REST[None], REST)
    assert six.shape == (6, 127, 2)
    np.testing.assert_allclose(six, np.broadcast_to(REST, six.shape), atol=1e-9)
    squashed = REST * [1.0, 0.8]
    with pytest.raises(Exception, match="does not map the rest pins onto themselves"):
        E.grid_turn(squashed, 1)


def test_a_turn_adds_no_pattern_of_its_own_where_the_grid_is_nearly_symmetric() -> None:
    """Rest pins scattered by 0.5 px about the grid (the DigiTac set's map onto themselves
    under a sixth of a turn only to within 0.7 px RMS): the turns of a frame at rest are
    that frame, so the scatter adds no fixed pattern to the turned frames (turning the pins
    themselves added one as large as the edge's signal), and a displaced frame's turns
    keep its displacement's size."""
    rng = np.random.default_rng(3)
    rest = REST + rng.normal(0.0, 0.5, REST.shape)
    six = E.turned_frames(rest[None], rest)
    np.testing.assert_allclose(six, np.broadcast_to(rest, six.shape), atol=1e-9)
    displacement = rng.normal(0.0, 1.0, REST.shape)
    turned = E.turned_frames((rest + displacement)[None], rest) - rest
    np.testing.assert_allclose(np.linalg.norm(turned, axis=(1, 2)), np.linalg.norm(displacement), rtol=1e-9)


CENTRED = REST - REST.mean(axis=0)
RHO = float(np.sqrt(np.mean(np.sum(CENTRED**2, axis=1))))  # the rest pins' RMS radius, px
EDGE_SHIFT_PX = 5.0  # the taps' rigid shift along the edge normal
ORIENT_PX = 2.0  # the orientation imprint at the RMS radius
DEPTH_PX_PER_MM = 3.0  # the radial dilation per mm of depth offset, at the RMS radius


def _pattern(phi_rad: float) -> np.ndarray:
    """S(φ)·r/ρ (127, 2): S(φ) = [[cos φ, sin φ], [sin φ, −cos φ]], r the rest pin about the
    centre; S(2θ) turns with an edge at θ, and S(0), S(90°) span the rotating pair."""
    s = np.array([[np.cos(phi_rad), np.sin(phi_rad)], [np.sin(phi_rad), -np.cos(phi_rad)]])
    return CENTRED @ s.T / RHO


def _imprint_run(n: int = 1500, seed: int = 3, extra=None) -> Run:
    """Sheared taps over θ ±45° whose pins hold: a rigid shift b·n(θ) along the edge normal
    n = (cos θ, sin θ); an orientation imprint a·S(2θ)·r/ρ (`_pattern`); a radial dilation
    with the depth offset; slides along and across the edge that shift every pin rigidly; a
    twist that turns them; and `extra(tap)` (127, 2) px where given."""

    def displacement(tap) -> np.ndarray:
        t = np.radians(tap.theta_deg)
        return (
            EDGE_SHIFT_PX * np.array([np.cos(t), np.sin(t)])
            + ORIENT_PX * _pattern(2 * t)
            + tap.depth_offset_mm * DEPTH_PX_PER_MM * CENTRED / RHO
            + tap.slide_along_mm * np.array([1.0, -0.5])
            + tap.slide_lateral_mm * np.array([0.5, 1.0])
            + tap.twist_deg * 0.3 * CENTRED[:, ::-1] * [-1.0, 1.0] / RHO
            + (0.0 if extra is None else extra(tap))
        )

    return _sheared(displacement, n, seed, 0.01)


def test_turned_taps_read_the_orientation_without_the_rigid_shifts() -> None:
    """Turned by the grid's six-fold symmetry, the rigid shift b·n(θ) would be a rotating
    pair as large as b²/2 per pin and take PC1 and PC2. Without each frame's uniform shift
    the PCs are, in closed form over the six turns (2θ + k·120° averages cos² to ½ and cos
    to 0 exactly), the depth's dilation (variance s²·var(d) per pin) and the orientation's
    pair (a²/2 each): θ_PC23 = ±2θ + const, and a slide along the edge (a rigid shift) has
    none of its energy in PC2–PC3 and turns θ_PC23 by nothing."""
    run = _imprint_run()
    pcs = E.tap_pcs(run)
    assert pcs.turned
    shifts = np.stack([np.tile([1.0, 0.0], 127), np.tile([0.0, 1.0], 127)])
    np.testing.assert_allclose(pcs.components @ shifts.T, 0.0, atol=1e-9)
    depth_var = DEPTH_PX_PER_MM**2 * np.var(run.label("depth_offset_mm"))
    variances = np.array([depth_var, ORIENT_PX**2 / 2, ORIENT_PX**2 / 2])
    np.testing.assert_allclose(pcs.explained, variances / (depth_var + ORIENT_PX**2), rtol=0.01)
    theta = run.label("theta_deg")
    read = pcs.theta_pc23_deg(pins_to_vectors(run.pins_px))
    spread = min(
        np.std(wrap_deg(read - sign * 2 * theta - np.mean(wrap_deg(read - sign * 2 * theta)))) for sign in (1, -1)
    )
    assert spread < 0.5
    for figures in E.along_edge_turn_sheared(run, pcs).values():
        assert figures["translation_share"] == pytest.approx(1.0, abs=1e-3)
        assert figures["plane_share"] < 1e-3
        assert figures["pc23_deg_per_mm"] < 0.5


def test_a_slide_across_the_edge_turns_the_pair_by_its_part_in_it() -> None:
    """`_imprint_run`'s taps, whose across-edge slide shifts every pin (a turned plane holds
    no shift, so it turns θ_PC23 by nothing), with C px per mm of the pair's other pattern
    S(90°)·r/ρ added to it. The bin's mean frame sits in the pair at ORIENT_PX × (mean cos 2θ,
    mean sin 2θ) plus C × the mean slide along S(90°); the slide moves it by C along S(90°),
    so θ_PC23 turns by the angle between the two (S(0) and S(90°) are orthogonal and of one size)."""
    rigid = E.across_edge_turn_sheared(_imprint_run())
    assert max(v["pc23_deg_per_mm"] for v in rigid.values()) < 0.5
    c_px = 0.4
    run = _imprint_run(extra=lambda tap: tap.slide_lateral_mm * c_px * _pattern(np.pi / 2))
    turns = E.across_edge_turn_sheared(run)
    theta, slide = np.radians(run.label("theta_deg")), run.label("slide_lateral_mm")
    bins = np.round(run.label("lateral_mm")) + 0.0
    for l, figures in turns.items():
        m = E.usable(run) & (bins == l)
        mean = np.array([ORIENT_PX * np.mean(np.cos(2 * theta[m])), ORIENT_PX * np.mean(np.sin(2 * theta[m]))])
        mean[1] += c_px * np.mean(slide[m])
        moved = mean + [0.0, c_px]
        expected = abs(np.degrees(np.arctan2(moved[1], moved[0]) - np.arctan2(mean[1], mean[0])))
        assert expected > 10.0  # the case is exercised
        # within the fitted gradient's sampling error: the bin's ~300 taps leave the curvature
        # of S(2θ), which its linear θ term cannot take, in the residual (0.1–3 % here)
        assert figures["pc23_deg_per_mm"] == pytest.approx(expected, rel=0.05), l


@pytest.mark.parametrize("fixed_deg", [90.0, -90.0, 0.0])
def test_a_fixed_imprint_onto_the_object_offsets_the_mean_frame_from_a_turn(fixed_deg: float) -> None:
    """`_imprint_run`'s taps, whose orientation imprint a·S(2θ)·r/ρ turns about the plane's
    centre (its shifts, dilation and twist lie outside the pair), plus, onto the object
    (l < −0.5 mm), a fixed imprint c·S(φ)·r/ρ (a tilted mount's). In one scale the
    pair's coordinates are a·(cos 2θ, sin 2θ) + c·(cos φ, sin φ), so a bin's mean frame is
    a·(mean cos 2θ, mean sin 2θ) + c·(cos φ, sin φ) and the θ term points along the slope of
    (cos 2θ, sin 2θ) on θ, nearly (0, 1): with the bin's own θ the offset is about
    atan2(c sin φ, a·2/π + c cos φ) = ±38° for φ = ±90°, none for φ = 0 (the fixed imprint
    only moves the frame outwards), and none off the object."""
    fixed = 1.0  # px, c
    phi = np.radians(fixed_deg)
    run = _imprint_run(extra=lambda tap: fixed * _pattern(phi) if tap.lateral_mm < -0.5 else 0.0)
    theta, bins = np.radians(run.label("theta_deg")), np.round(run.label("lateral_mm")) + 0.0
    figures = E.along_edge_turn_sheared(run)
    assert sorted(figures) == [-2.0, -1.0, 0.0, 1.0, 2.0]
    for l, f in figures.items():
        t = theta[bins == l]
        pair = ORIENT_PX * np.column_stack([np.cos(2 * t), np.sin(2 * t)])
        mean = pair.mean(axis=0) + (fixed * np.array([np.cos(phi), np.sin(phi)]) if l < 0 else 0.0)
        ahead = (t - t.mean()) @ (pair - pair.mean(axis=0))
        ahead /= np.linalg.norm(ahead)
        outwards = np.array([ahead[1], -ahead[0]]) * np.sign(mean @ [ahead[1], -ahead[0]])
        expected = np.degrees(np.arctan2(mean @ ahead, mean @ outwards))
        # the bin's draw of θ moves it by about 4° (a·0.71/√300 along the θ term against a·2/π)
        assert abs(expected - (38.1 * np.sin(phi) if l < 0 else 0.0)) < 10.0
        assert f["offset_deg"] == pytest.approx(expected, abs=0.5), l


def _outer_pattern(phi_rad: float) -> np.ndarray:
    """`_pattern` with each pin's displacement weighted by w(|r|), scaled back to its norm: a
    rotating pair weighted to the rim (w = |r|² − Σ|r|⁴/Σ|r|²), orthogonal to every
    `_pattern` (Σ rᵀ S(φ)ᵀ S(φ') r w = cos(φ' − φ) Σ|r|² w = 0)."""
    r2 = np.sum(CENTRED**2, axis=1)
    pattern = _pattern(phi_rad)
    field = pattern * (r2 - np.sum(r2**2) / np.sum(r2))[:, None]
    return field * np.linalg.norm(pattern) / np.linalg.norm(field)


@pytest.mark.parametrize(
    ("slide", "turns", "read_key", "angle_tolerance_deg"),
    [
        ("slide_along_mm", E.along_edge_turn_sheared, "pc23_deg_per_mm", 0.3),
        # measured 20.8°: the planes' angle is not what this case is about, the turns are
        ("slide_lateral_mm", E.across_edge_turn_sheared, "across_pc23_deg_per_mm", 1.0),
    ],
)
def test_a_turn_read_in_another_runs_plane_splits_the_plane_from_the_drag(
    slide, turns, read_key, angle_tolerance_deg
) -> None:
    """A's imprint is a·S(2θ)·r/ρ; B's adds tan α times a rim-weighted pair orthogonal to it
    (`_outer_pattern`), so B's PC2–PC3 plane lies α from A's and projects onto A's as A's
    imprint. Both runs' slides along the edge (or across it) add the same non-rigid field,
    part in A's pair and part in the rim's: in A's plane B's taps and drag are A's, so B's
    turn read there is A's own, while in its own plane B turns otherwise."""
    alpha = np.radians(20.0)
    phi_a, phi_b = np.radians(60.0), np.radians(-30.0)

    def drag(tap) -> np.ndarray:
        return getattr(tap, slide) * (0.3 * _pattern(phi_a) + 1.5 * _outer_pattern(phi_b))

    a = _imprint_run(extra=drag)
    b = _imprint_run(
        extra=lambda tap: drag(tap) + np.tan(alpha) * ORIENT_PX * _outer_pattern(np.radians(2 * tap.theta_deg))
    )
    own_a, own_b = turns(a), turns(b)
    read, itself = E.turn_in_reference_plane(a, b), E.turn_in_reference_plane(a, a)
    assert read["angle_deg"] == pytest.approx(20.0, abs=angle_tolerance_deg)
    assert itself["angle_deg"] == pytest.approx(0.0, abs=1e-3)
    assert sorted(read[read_key]) == sorted(own_a)
    for l, turn in read[read_key].items():
        assert own_a[l]["pc23_deg_per_mm"] > 1.0  # the case is exercised: A's drag turns it
        assert itself[read_key][l] == pytest.approx(own_a[l]["pc23_deg_per_mm"], rel=1e-9)
        # the grid's turns map it onto itself to within its projection, so A's plane holds a
        # trace of the rim's pair: 1 % of the turn
        assert turn == pytest.approx(own_a[l]["pc23_deg_per_mm"], rel=0.02), l
        assert abs(own_b[l]["pc23_deg_per_mm"] / own_a[l]["pc23_deg_per_mm"] - 1.0) > 0.3, l


def test_taps_over_a_full_turn_are_not_turned_and_keep_their_shifts() -> None:
    """Taps whose angles span a full turn: their PCs are those of their frames as recorded."""
    thetas = np.arange(-180.0, 180.0, 20.0)
    pins = np.stack(
        [
            REST + EDGE_SHIFT_PX * np.array([np.cos(t), np.sin(t)]) + np.sin(t) * CENTRED / RHO
            for t in np.radians(thetas)
        ]
    )
    samples = [
        {"pins_px": p.tolist(), "found": None, "labels": {"theta_deg": t, "lateral_mm": 0.0, "depth_mm": 3.0}}
        for p, t in zip(pins, thetas)
    ]
    run = Run(Path("synthetic"), {"scenario": {"protocol": {"kind": "taps"}}, "rest_pins_px": REST.tolist()}, samples)
    pcs = E.tap_pcs(run)
    mean, components, explained = pca_fit(pins_to_vectors(pins), 3)
    assert not pcs.turned
    np.testing.assert_array_equal(pcs.components, components)
    np.testing.assert_array_equal(pcs.mean, mean)
    np.testing.assert_array_equal(pcs.explained, explained)


def test_a_full_turns_signal_shift_share_is_the_rotating_shifts_energy() -> None:
    """Frames rest + b·n(θ) + sin θ·r/ρ over a turn in 20° steps: about their mean over θ,
    the shift's energy is N·b² a frame and the pattern's sin²θ·Σ|r/ρ|² (N pins, its mean over
    the turn ½·N), and they are orthogonal (r has no mean), so the share is b² / (b² + ½).
    The three PCs hold all of it (the shift's pair and the pattern), so their shift shares
    weighted by their variances are that share too."""
    thetas = np.arange(-180.0, 180.0, 20.0)
    pins = np.stack(
        [
            REST + EDGE_SHIFT_PX * np.array([np.cos(t), np.sin(t)]) + np.sin(t) * CENTRED / RHO
            for t in np.radians(thetas)
        ]
    )
    samples = [
        {"pins_px": p.tolist(), "found": None, "labels": {"theta_deg": t, "lateral_mm": -2.0, "depth_mm": 3.0}}
        for p, t in zip(pins, thetas)
    ]
    run = Run(Path("synthetic"), {"scenario": {"protocol": {"kind": "taps"}}, "rest_pins_px": REST.tolist()}, samples)
    share = EDGE_SHIFT_PX**2 / (EDGE_SHIFT_PX**2 + 0.5)
    assert E.signal_shift_share(run) == {3.0: {-2.0: pytest.approx(share, rel=1e-9)}}
    pcs = E.tap_pcs(run)
    in_pcs = sum(v * E.translation_share(c) for v, c in zip(pcs.explained, pcs.components)) / pcs.explained.sum()
    assert in_pcs == pytest.approx(share, rel=1e-6)


def test_the_signal_without_its_shift_is_the_imprints_pattern() -> None:
    """Taps over a turn at l = 0 and −2 mm with the same pattern sin θ·r/ρ and rigid shifts
    b·n(θ) of 1 and 3 px: each pin's spread is √(b² + ½) px, so the whole signal ratio is
    √(9.5 / 1.5); without the shift both are the pattern's √½ and the ratio is 1."""
    thetas = np.radians(np.arange(-180.0, 180.0, 20.0))
    samples = []
    for l, b in ((0.0, 1.0), (-2.0, 3.0)):
        for t in thetas:
            pins = REST + b * np.array([np.cos(t), np.sin(t)]) + np.sin(t) * CENTRED / RHO
            labels = {"theta_deg": float(np.degrees(t)), "lateral_mm": l, "depth_mm": 3.0}
            samples.append({"pins_px": pins.tolist(), "found": None, "labels": labels})
    run = Run(Path("synthetic"), {"scenario": {"protocol": {"kind": "taps"}}, "rest_pins_px": REST.tolist()}, samples)
    assert E.signal_profile(run)[3.0][-2.0] == pytest.approx(np.sqrt(9.5 / 1.5), rel=1e-9)
    assert E.signal_profile(run, without_shift=True) == {3.0: {0.0: 1.0, -2.0: pytest.approx(1.0, rel=1e-9)}}


def test_a_sheared_runs_signal_shift_share_is_not_the_frames_jitter() -> None:
    """Sheared taps whose θ field is a pattern r/ρ with no rigid shift (share 0) and whose
    frames each jitter rigidly by 1.5 px (a drag the model leaves unexplained). The jitter's
    error in the fitted θ gradient is a rigid shift of about 1.5 / (std θ · √n) px/deg,
    which as a raw share reads ~3 % in every bin. Less the fit's noise the share is 0 on
    average over 60 bins: its scatter is that of a 2-dof χ² about its mean, so the mean is
    within 3 / √60 = 0.39 of the raw mean of 0."""
    raw, shares = [], []
    for seed in range(12):
        jitter = np.random.default_rng(100 + seed)

        def displacement(tap, jitter=jitter) -> np.ndarray:
            return tap.theta_deg / 45.0 * CENTRED / RHO + jitter.normal(0.0, 1.5, 2)

        run = _sheared(displacement, 1500, 200 + seed, 0.05)
        for f in E.sheared_fits(run):
            raw.append(E.translation_share(f.gradients["theta_deg"]))
            shares.append(f.signal_shift_share)
    assert len(shares) == 60 and min(raw) > 0.0
    assert abs(np.mean(shares)) < 0.39 * np.mean(raw)
    assert np.mean(raw) > 0.01


def test_reach_profile_finds_the_edge_side_in_the_image() -> None:
    """Pins move as far as they lie towards the object, whose side in the image turns with
    θ as −(θ + 30°) (camera rolled and mirrored): the fitted direction is that, and the
    profile rises from beyond the edge to the object side."""
    rng = np.random.default_rng(4)
    centred = REST - REST.mean(axis=0)
    reach = centred.max()
    samples = []
    for theta in rng.uniform(-45, 45, 200):
        a = np.radians(-(theta + 30.0))  # the outward normal's direction in the image
        beyond = centred @ np.array([np.cos(a), np.sin(a)])
        magnitude = 1.0 + 0.5 * (1.0 - beyond / reach)  # 1 beyond the edge, 2 at the far object side
        pins = REST + magnitude[:, None] * np.array([np.cos(a), np.sin(a)])
        samples.append(
            {
                "pins_px": pins.tolist(),
                "found": None,
                "labels": {"theta_deg": theta, "lateral_mm": -4.0, "depth_mm": 3.0},
            }
        )
    run = Run(Path("synthetic"), {"scenario": {"protocol": {"kind": "taps"}}, "rest_pins_px": REST.tolist()}, samples)
    phi0, sigma = E.edge_normal_in_image(run)
    assert sigma == -1.0 and phi0 == pytest.approx(-30.0, abs=1.0)
    profile = E.reach_profile(run, -4.0)
    assert profile[-1] == 1.0 and np.all(np.diff(profile) > 0) and profile[0] == pytest.approx(0.55, abs=0.05)


def test_closest_pins_is_the_nearest_pair_against_its_rest_spacing() -> None:
    """Plain taps at two l: at l = 0 the whole pattern magnified 1.2× about its centre
    (every pin 1.2× as far from its neighbours); at l = −2 one pin and its nearest neighbour
    moved towards each other to 0.3 of their rest distance, and in one of those taps a third
    pin lost (not found): the figure is the smallest ratio, 1.2 and 0.3, with the lost share.
    The squeezed pin's rest spacing is the grid's widest (33.4 px against a median of 32.6),
    so a figure taken against one spacing for all pins would read 0.307."""
    from scipy.spatial import cKDTree

    distance, index = cKDTree(REST).query(REST, k=2)
    i = int(np.argmax(distance[:, 1]))
    j = int(index[i, 1])
    middle = (REST[i] + REST[j]) / 2
    squeezed = REST.copy()
    squeezed[[i, j]] = middle + 0.3 * (REST[[i, j]] - middle)
    magnified = REST.mean(axis=0) + 1.2 * (REST - REST.mean(axis=0))
    lost = np.ones(127, bool)
    lost[5] = False
    samples = [
        {"pins_px": p.tolist(), "found": f, "labels": {"theta_deg": t, "lateral_mm": l, "depth_mm": 3.0}}
        for p, f, t, l in (
            (magnified, None, 0.0, 0.0),
            (magnified, None, 45.0, 0.0),
            (squeezed, None, 0.0, -2.0),
            (squeezed, lost.tolist(), 45.0, -2.0),
        )
    ]
    run = Run(Path("synthetic"), {"scenario": {"protocol": {"kind": "taps"}}, "rest_pins_px": REST.tolist()}, samples)
    rows = E.closest_pins(run)[3.0]
    assert rows[0.0] == pytest.approx({"min": 1.2, "median": 1.2, "lost": 0.0})
    assert rows[-2.0] == pytest.approx({"min": 0.3, "median": 0.3, "lost": 0.5})


def _write(
    run: Run, out: Path, name: str, x0_mm: float = 0.0, step: int = 1, lost: frozenset[int] = frozenset()
) -> Path:
    """`run` recorded to `out` by the run recorder, after a no-contact frame (as a sheared-taps
    run has), its targets from x = `x0_mm` on; `step`: only every step-th tap, at the target
    it has in the whole run (a replay of every step-th tap of a recording); `lost`: the taps
    whose first pin was not found (as a real tracker loses one)."""
    from twin.core.environment import Observation
    from twin.core.poses import Pose
    from twin.core.scenario import scenario_from_dict
    from twin.runs.record import RunRecorder

    protocol = {**run.meta["scenario"]["protocol"], "given": None}
    scenario = scenario_from_dict({"name": name, "object": {"name": "rectangle"}, "protocol": protocol})
    with RunRecorder(out, scenario, 0, "hardware", scenario.camera_model()) as recorder:
        recorder.set_rest_pins(REST)
        rest = {"lateral_mm": 9.9, "theta_deg": 0.0, "depth_mm": -5.0, "tap": -1, "no_contact": True}
        hover = Pose(x0_mm - 10, 0, -5)
        recorder.add(Observation(0.0, hover), hover, rest, REST, np.ones(127, bool))
        for k, s in list(enumerate(run.samples))[::step]:
            target = Pose(x0_mm + k, 0, 3)
            found = np.ones(127, bool)
            found[0] = k not in lost
            recorder.add(Observation(float(k), target), target, s["labels"], np.array(s["pins_px"]), found)
    return out


def test_compare_and_evaluate_print_the_edge_figures(run: Run, tmp_path: Path, capsys) -> None:
    """Two sheared-tap runs that share no target compare by their edge figures, side by side;
    `twin evaluate` on one prints its drag against its signal."""
    import json

    from twin.tools.cli import main

    a = _write(run, tmp_path / "a", "rig")
    b = _write(sheared_run(600, seed=5), tmp_path / "b", "twin", x0_mm=0.5)  # no target shared with a
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "cmp")]) == 0
    printed = capsys.readouterr().out
    assert "no paired samples" in printed and "drag / orientation signal" in printed
    assert "orientation signal in a rigid shift of the pins, %" in printed
    assert "orientation signal by ring of pins" in printed
    assert "orientation signal / its mean at l = 0 over the depths, the sheared taps 2.33 mm deep:" in printed
    header = next(line for line in printed.splitlines() if line.startswith("edge figures"))
    assert "A: rig" in header and "B: twin" in header
    figures = json.loads((tmp_path / "cmp" / "comparison.json").read_text())["edge_figures"]
    assert figures["a"]["signal_profile"]["3.0"]["-2.0"] == pytest.approx(E.signal_profile(run)[3.0][-2.0])
    shift_share = E.signal_shift_share(run)[3.0][-2.0]
    assert figures["a"]["signal_shift_share"]["3.0"]["-2.0"] == pytest.approx(shift_share)
    # the reach profile where the user asks (the runs span l = -2.5 ... 2.5 mm)
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "cmp_reach"), "--reach-at", "-1", "2"]) == 0
    reach = [line for line in capsys.readouterr().out.splitlines() if line.startswith("  reach at l")]
    assert [line.split(" mm")[0] for line in reach] == ["  reach at l +2", "  reach at l -1"]
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "cmp_bad"), "--reach-at", "nan"]) == 2
    capsys.readouterr()
    # a lab camera's resolution beside the twin's: never paired pin by pin, even on shared targets
    lab = _write(sheared_run(300, seed=6), tmp_path / "lab", "lab")
    meta = json.loads((lab / "run.json").read_text())
    meta["camera"].update(width=256, height=256)
    (lab / "run.json").write_text(json.dumps(meta))
    assert main(["compare", str(lab), str(a), "--out", str(tmp_path / "cmp_lab")]) == 0
    assert "no paired samples" in capsys.readouterr().out
    small = _write(sheared_run(240, seed=7), tmp_path / "small", "rig")  # the GPs' fit grows as n³
    assert main(["evaluate", "--train", str(small), "--test", str(small), "--out", str(tmp_path / "eval")]) == 0
    printed = capsys.readouterr().out
    assert "drag / orientation signal" in printed and (tmp_path / "eval" / "edge_figures.json").is_file()


def test_compare_reads_both_runs_on_the_taps_they_share(run: Run, tmp_path: Path, capsys) -> None:
    """A replay of every fourth tap of a recording that gives the recording's pins: `twin
    compare` takes the recording's figures from those taps, not from all of its own (a
    bin's signal ratio moves with the draw of taps), and every figure's difference is nil
    in every paired resample: the signal's 0 ± 0, the others' factor 1 ×÷ 1 (drawn apart,
    the two runs' figures would scatter by the draw)."""
    import json

    from twin.tools.cli import main

    a = _write(run, tmp_path / "a", "rig")
    b = _write(run, tmp_path / "b", "twin", step=4)
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "cmp"), "--resamples", "4"]) == 0
    printed = capsys.readouterr().out
    quarter = E.signal_profile(Run(run.path, run.meta, run.samples[::4]))[3.0]
    whole = E.signal_profile(run)[3.0]
    assert max(abs(quarter[l] - whole[l]) for l in quarter) > 0.02  # the case is exercised
    result = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert result["shared_taps"] == 1 + len(run.samples[::4])  # the no-contact frame and the replayed taps
    for tag in "ab":
        profile = {float(l): v for l, v in result["edge_figures"][tag]["signal_profile"]["3.0"].items()}
        assert profile == pytest.approx(quarter, abs=1e-6)  # a record keeps 7 significant digits
    differences = result["edge_figure_differences"]
    assert differences["taps"] == len(run.samples[::4]) and differences["resamples"] == 4
    assert {r["figure"] for r in differences["rows"]} == {"signal", "theta_pc23", "theta_pc23_across", "drag/signal"}
    for r in differences["rows"]:
        assert r["b"] == pytest.approx(r["a"], rel=1e-6) and r["spread"] == pytest.approx(0.0, abs=1e-6), r
        if r["figure"].startswith("theta_pc23"):  # read in A's plane too, which is B's own
            assert r["in_a_plane"] == pytest.approx(r["a"], rel=1e-6), r
            assert r["spread_in_a_plane"] == pytest.approx(0.0, abs=1e-6), r
    assert f"B against A on the same {len(run.samples[::4])} taps" in printed and "+0.00 ± 0.00" in printed
    assert differences["b_in_a_plane"]["angle_deg"] == pytest.approx(0.0, abs=1e-3)
    assert "which lies 0.0° from B's" in printed


def test_compare_leaves_out_of_both_runs_the_taps_either_lost_a_pin_in(tmp_path: Path, capsys) -> None:
    """A recording that lost a pin in some taps (the DigiTac set's tracker, in a tenth of its
    frames, most at the deepest presses onto the object) beside a replay that lost none:
    the replay's figures come from the taps the recording kept, not from all of its own,
    so that both read the same taps."""
    import json

    from twin.tools.cli import main

    recording, replay = sheared_run(600, seed=8, noise_px=0.3), sheared_run(600, seed=8, noise_px=0.3, noise_seed=99)
    offsets = [s["labels"]["depth_offset_mm"] for s in recording.samples]
    lost = frozenset(k for k, offset in enumerate(offsets) if offset > 0.3)
    a = _write(recording, tmp_path / "a", "rig", lost=lost)
    b = _write(replay, tmp_path / "b", "twin")
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "cmp"), "--resamples", "2"]) == 0
    result = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    kept = [s for k, s in enumerate(replay.samples) if k not in lost]
    assert result["shared_taps"] == 1 + len(kept)  # the no-contact frame and the taps both kept
    expected = E.signal_profile(Run(replay.path, replay.meta, kept))[3.0]
    everything = E.signal_profile(replay)[3.0]
    assert max(abs(expected[l] - everything[l]) for l in expected) > 0.02  # the case is exercised
    profile = {float(l): v for l, v in result["edge_figures"]["b"]["signal_profile"]["3.0"].items()}
    assert profile == pytest.approx(expected, abs=1e-6)
    rows = result["edge_figure_differences"]["rows"]
    pooled = result["edge_figure_differences"]["pooled"]["signal"]  # each side's bins, pooled
    for side, on_side in (("onto", lambda l: l < 0), ("off", lambda l: l >= 0)):
        assert pooled[side]["bins"] == sum(r["figure"] == "signal" and on_side(r["lateral_mm"]) for r in rows)
    assert "pooled onto the object (l < 0)" in capsys.readouterr().out


def test_the_paired_spread_is_the_scatter_of_the_difference_over_new_taps() -> None:
    """B's signal ratio less A's on the same 400 taps (B's edge fades otherwise, each run
    with its own 0.3 px of noise): the standard deviation a paired bootstrap estimates from
    one pair of runs, averaged over 3 such pairs, against the difference's scatter over 16
    pairs each on new taps and new noise: between half and 1.5 times it in every bin
    (measured 0.67–0.80: the bootstrap reads this scatter about a quarter low; one pair's
    estimate alone scatters from 0.44 to 1.47 times it with 500 taps). Resampling A and B
    apart would give 2–12 times the scatter, since the draw of taps moves both ratios alike."""
    from twin.analysis.calibration_fit.figures import paired_figure_spread

    fade_b = {-2.0: 0.6, -1.0: 0.8, 0.0: 1.0, 1.0: 1.1, 2.0: 1.5}

    def pair(seed: int) -> tuple[Run, Run]:
        a = sheared_run(400, seed=seed, noise_px=0.3)
        return a, sheared_run(400, seed=seed, noise_px=0.3, fade=fade_b, noise_seed=10_000 + seed)

    bins = [l for l in FADE if l != 0.0]
    differences = []
    for seed in range(16):
        va, vb = (figure_values(r) for r in pair(seed))
        differences.append([vb["signal", l] - va["signal", l] for l in bins])
    scatter = np.std(differences, axis=0, ddof=1)
    estimates = [paired_figure_spread(*pair(100 + k), 12, seed=k)[0] for k in range(3)]
    estimated = np.mean([[e["signal", l] for l in bins] for e in estimates], axis=0)
    assert np.all((estimated / scatter > 0.5) & (estimated / scatter < 1.5)), (bins, estimated, scatter)


def test_calibration_simulates_a_square_lab_camera(tmp_path: Path) -> None:
    """`twin calibrate`'s physics scenario for a 256×256 lab camera builds its camera (the
    physics-only calibration was a 640×480 one, refused as another aspect ratio)."""
    from twin.analysis.calibration_fit.settings import load_settings
    from twin.analysis.calibration_fit.space import Space
    from twin.core.scenario import scenario_from_dict

    scenario = scenario_from_dict(
        {
            "name": "lab",
            "object": {"name": "rectangle"},
            "fidelity": "fast",
            "sensor": {"camera": {"width": 256, "height": 256}},
            "effects": ["contact"],
            "protocol": {"kind": "sheared_taps"},
        }
    )
    settings = tmp_path / "settings.yaml"  # the camera's bounds at 256×256 px
    settings.write_text(
        "parameters:\n  camera.focal_px: {fit: true, lower: 150.0, upper: 350.0, prior_std: null}\n"
        "  camera.cx_px: {fit: false, lower: 108.0, upper: 148.0, prior_std: null}\n"
        "  camera.cy_px: {fit: false, lower: 108.0, upper: 148.0, prior_std: null}\n"
    )
    physics = Space(scenario, load_settings(settings)).physics_scenario({})
    camera = physics.camera_model()
    assert (camera.width, camera.height) == (256, 256)
    assert camera.intrinsics[0, 0] == pytest.approx(scenario.camera_model().intrinsics[0, 0])


def test_sheared_runs_at_other_nominal_depths_print_side_by_side(run: Run) -> None:
    """A lab set's nominal depth is not recorded, so two sheared-tap runs whose nominal
    depths differ print their depth-keyed figures in one group, both columns filled; plain
    taps keep a group per depth."""
    from twin.tools.edge_figures_report import format_edge_figures

    a = E.edge_figures(run)
    b = {
        **a,
        "signal_profile": {4.0: a["signal_profile"][3.0]},
        "closest_pins": {4.0: a["closest_pins"][3.0]},
    }
    text = format_edge_figures([a, b], ["rig", "twin"])
    assert "orientation signal / its value at l = 0, each run's nominal depth (3 / 4 mm):" in text
    assert "closest pins, each run's nominal depth (3 / 4 mm)" in text
    centre = next(line for line in text.splitlines() if line.strip().startswith("l +0 mm"))
    assert centre.split()[-2:] == ["1.00", "1.00"]
    plain = {**b, "kind": "taps"}
    text = format_edge_figures([a, plain], ["rig", "twin"])
    assert "l = 0, 3 mm deep:" in text and "l = 0, 4 mm deep:" in text


def test_an_orientation_pair_that_outweighs_the_press_is_named(run: Run) -> None:
    """The edge's orientation is a rotating pair of PCs of equal variance: PC2–PC3 where
    the press outweighs it. Where it outweighs the press (a 4 mm pin lever on a stiff skin
    gave 28/28/26 %), it is PC1–PC2 and θ_PC23 reads half of it and the press: the report
    says so for that run alone."""
    from twin.tools.edge_figures_report import format_edge_figures

    assert E.rotating_pair(np.array([0.38, 0.20, 0.20])) == (1, 2)
    assert E.rotating_pair(np.array([0.28, 0.28, 0.26])) == (0, 1)
    figures = E.edge_figures(run)
    a, b = {**figures, "pcs_explained": [0.38, 0.2, 0.199]}, {**figures, "pcs_explained": [0.28, 0.279, 0.26]}
    text = format_edge_figures([a, b], ["rig", "twin"])
    assert "twin: the edge's orientation pair is PC1–PC2 (28/28 %), not PC2–PC3" in text
    assert "rig: the edge's orientation pair" not in text
    energy = " ".join(f"{v:.2f}" for v in figures["pair_rings"]["energy"])
    assert f"    twin: {energy}; radial — " in text.split("orientation pair by ring of pins")[1]


def test_a_bin_whose_signal_is_within_its_noise_has_no_drag_over_signal() -> None:
    """Pins that carry the slides and the depth but not the edge's angle: the angle term's
    spread, its noise taken out, is 0 px in some bins; their ratio is NaN (no signal to
    weigh the drag against), not a division error, the rest stay finite, and the
    calibration's figures leave it out."""
    f = _fields()
    run = _sheared(lambda tap: tap.slide_along_mm * f["along"] + tap.depth_offset_mm * f["depth"], 600, 3, 0.05)
    figures = E.drag_over_signal(run)
    silent = {l for l, v in figures.items() if v["signal_px"] == 0.0}
    assert silent, "no bin's signal fell within its noise: the case is not exercised"
    assert {l for l, v in figures.items() if np.isnan(v["ratio"])} == silent
    assert all(v["drag_px"] > 0.1 for v in figures.values())
    assert E.edge_figures(run)["drag_over_signal"] is not None
    # `twin calibrate` counts such a bin's ratio as a figure the run lacks, not as a NaN miss
    values = figure_values(run)
    assert all(("drag/signal", l) not in values for l in silent)
    assert all(np.isfinite(v) for v in values.values())


#: each template pin's hexagonal ring: the template is ordered ring by ring from the centre (twin.core.sensor)
TEMPLATE_RINGS = np.repeat(np.arange(7), [1, 6, 12, 18, 24, 30, 36])


def test_pin_rings_are_the_hexagonal_rings_about_the_centre() -> None:
    """A hexagonal lattice's points by their hex distance from the centre (axial
    coordinates), seen through a lens that pulls the outer rings in, turned and shuffled,
    fall into the rings of their hex distance; so do the twin's template pins."""
    axial = [(q, r) for q in range(-6, 7) for r in range(-6, 7) if max(abs(q), abs(r), abs(q + r)) <= 6]
    hex_distance = np.array([max(abs(q), abs(r), abs(q + r)) for q, r in axial])
    flat = np.array([[q + r / 2, r * np.sqrt(3) / 2] for q, r in axial])
    radius = np.linalg.norm(flat, axis=1, keepdims=True)
    pulled_in = flat * np.sin(radius / 8.0) * 8.0 / np.maximum(radius, 1e-9)
    turn = np.radians(133.0)
    image = 100.0 + 12.0 * pulled_in @ np.array([[np.cos(turn), np.sin(turn)], [-np.sin(turn), np.cos(turn)]])
    order = np.random.default_rng(0).permutation(len(image))
    assert np.array_equal(E.pin_rings(image[order]), hex_distance[order])
    assert np.array_equal(E.pin_rings(REST), TEMPLATE_RINGS)


def test_pair_rings_split_the_pair_by_ring_and_into_radial_and_round() -> None:
    """A pair whose first component moves ring 5 radially by 3 and round by 4 (a radial
    share of 9/25) and whose second turns ring 2 (share 0), each a unit field: ring 5 and
    ring 2 carry half the pair's energy each; PC1 (the press, in ring 1 alone) counts in
    neither; the centre pin and the rings the pair leaves still have no radial share. A
    pair that outweighs the press (PC1–PC2) is read as that pair."""
    outward = REST - REST[0]
    outward /= np.maximum(np.linalg.norm(outward, axis=1, keepdims=True), 1e-12)
    round_ = outward @ np.array([[0.0, 1.0], [-1.0, 0.0]])

    def unit(field: np.ndarray) -> np.ndarray:
        return field.ravel() / np.linalg.norm(field)

    in_ring = lambda k: (TEMPLATE_RINGS == k)[:, None]  # noqa: E731
    press, mixed, turn = (
        unit(in_ring(1) * outward),
        unit(in_ring(5) * (3 * outward + 4 * round_)),
        unit(in_ring(2) * round_),
    )
    pcs = E.TapPCs(np.zeros(254), np.stack([press, mixed, turn]), np.array([0.5, 0.2, 0.2]), True)
    rings = E.pair_rings(pcs, REST)
    np.testing.assert_allclose(rings["energy"], [0, 0, 0.5, 0, 0, 0.5, 0], atol=1e-12)
    assert rings["radial"][0] is None and [rings["radial"][k] is None for k in (1, 3, 4, 6)] == [True] * 4
    assert rings["radial"][5] == pytest.approx(9 / 25) and rings["radial"][2] == pytest.approx(0.0, abs=1e-12)
    swapped = E.TapPCs(np.zeros(254), np.stack([mixed, turn, press]), np.array([0.3, 0.3, 0.2]), True)
    np.testing.assert_allclose(E.pair_rings(swapped, REST)["energy"], rings["energy"], atol=1e-12)


def test_signal_rings_place_the_signal_where_the_pins_carry_it() -> None:
    """The edge angle moves only the 18 pins of ring 3, by fade(l): ring 3 reads
    fade(l) std θ(l) / (fade(0) std θ(0)) × √(127/18) (the whole array's signal lies in 18
    of its 127 pins; std θ over the bin's taps), every other ring nothing, for sheared taps
    and plain taps alike."""
    field = _fields()["theta"] * (TEMPLATE_RINGS == 3)[:, None]

    def displacement(tap) -> np.ndarray:
        return FADE[float(np.round(tap.lateral_mm)) + 0.0] * tap.theta_deg / 45.0 * field + tap.slide_along_mm * 0.5

    sheared_run = _sheared(displacement, 1500, 8, 0.01)
    sheared = E.signal_rings(sheared_run, at_mm=(-1.5, 0.0, 1.4))
    assert list(sheared) == [3.0] and sorted(sheared[3.0]) == [-1.0, 0.0, 1.0]  # the bins nearest, then nearer l = 0
    rng = np.random.default_rng(9)
    samples = [
        {
            "pins_px": (REST + FADE[l] * theta / 45.0 * field).tolist(),
            "found": None,
            "labels": {"theta_deg": theta, "lateral_mm": l, "depth_mm": 2.0},
        }
        for l in (-2.0, 0.0, 1.0)
        for theta in rng.uniform(-45, 45, 40)
    ]
    plain = Run(Path("synthetic"), {"scenario": {"protocol": {"kind": "taps"}}, "rest_pins_px": REST.tolist()}, samples)
    plain_table = E.signal_rings(plain, at_mm=(-2.0, 0.0, 1.0))[2.0]
    for run, table in ((sheared_run, sheared[3.0]), (plain, plain_table)):
        theta, bins = run.label("theta_deg"), np.round(run.label("lateral_mm")) + 0.0
        spread = {l: FADE[l] * np.std(theta[bins == l]) for l in table}
        for l, rings in table.items():
            expected = np.where(np.arange(7) == 3, spread[l] / spread[0.0] * np.sqrt(127 / 18), 0.0)
            np.testing.assert_allclose(rings, expected, atol=0.02, err_msg=str(l))
