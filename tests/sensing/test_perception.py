"""PCA → spherical coordinates → GP perception on a synthetic labelled tap set (288 points)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from twin.core.errors import UserError
from twin.core.sensor import N_PINS, CameraModel
from twin.sensing.perception import (
    NO_CONTACT,
    GPConfig,
    PerceptionModel,
    angle_error_deg,
    make_kernel,
    paper_training_labels,
    pins_to_vectors,
    rebuild_gp,
    synthetic_tap_pins,
    tukey_keep,
    wrap_deg,
)
from twin.sensing.tracker import PinTracker, render_pins_frame

FAST = GPConfig(n_restarts=0)


@pytest.fixture(scope="module")
def train():
    th, la, de = paper_training_labels()
    pins = synthetic_tap_pins(th, la, de, noise_px=0.02, rng=np.random.default_rng(10))
    return pins, th, la, de


@pytest.fixture(scope="module")
def model(train) -> PerceptionModel:
    pins, th, la, de = train
    return PerceptionModel(gp=FAST).fit(pins, th, la, de, np.random.default_rng(0))


@pytest.fixture(scope="module")
def heldout():
    rng = np.random.default_rng(11)
    n = 120
    th, la, de = rng.uniform(-180, 180, n), rng.uniform(-5, 5, n), rng.uniform(2.2, 3.8, n)
    return synthetic_tap_pins(th, la, de), th, la, de


def test_data_vector_is_interleaved() -> None:
    pins = np.arange(N_PINS * 2, dtype=float).reshape(N_PINS, 2)
    z = pins_to_vectors(pins)
    assert z.shape == (1, 254)
    assert z[0, 0] == pins[0, 0] and z[0, 1] == pins[0, 1] and z[0, 2] == pins[1, 0]


def test_pca_and_heldout_accuracy(model: PerceptionModel, heldout) -> None:
    assert model.variance_explained.shape == (3,)
    assert 0.5 < model.variance_explained.sum() <= 1.0 + 1e-12
    pins, th, la, _ = heldout
    pred = model.predict(pins)
    assert pred.ok.all()
    theta_rms = np.sqrt(np.mean(angle_error_deg(pred.theta_deg, th) ** 2))
    lat_rms = np.sqrt(np.mean((pred.lateral_mm - la) ** 2))
    assert theta_rms < 2.0
    assert lat_rms < 0.6
    assert np.all(pred.std > 0) and np.all(np.isfinite(pred.std))


def test_depth_shift_makes_mid_lateral_phi_depth_invariant(model: PerceptionModel, train) -> None:
    pins, th, la, de = train
    v = model.spherical(pins)
    mid = la == 2.0  # label nearest the middle of [−6, 9.9]
    for t in (-160.0, 0.0, 100.0):
        sel = mid & (th == t)
        assert np.ptp(v[sel, 2]) < 0.01  # rad


def test_pruning(model: PerceptionModel, train) -> None:
    _, _, la, _ = train
    summary = model.training_summary
    keep_lat, keep_or = summary["keep_lateral"], summary["keep_orientation"]
    contact = la < 9.9
    assert keep_lat[contact].mean() >= 0.9
    assert not keep_or[~contact].any() and not keep_lat[~contact].any()  # no-contact frames removed
    assert keep_or.sum() < contact.sum()  # the Tukey rule pruned some weak contacts
    assert model.info["n_lateral_kept"] == keep_lat.sum()


def test_tukey_rule_and_floor() -> None:
    s = np.array([1.0, 1.1, 0.9, 1.05, 0.95, 0.01, 0.0, np.nan])
    keep = tukey_keep(s)
    assert keep.tolist() == [True, True, True, True, True, False, False, True]
    assert tukey_keep(s, 0.9).sum() == 8  # ceil(0.9·8) = 8


def test_save_load_reproduces_predictions(model: PerceptionModel, heldout, tmp_path) -> None:
    path = model.save(tmp_path / "model.npz")
    with np.load(path, allow_pickle=False) as data:
        header = json.loads(bytes(data["header"]).decode())
    assert header["format_version"] == 2 and header["n_pins"] == N_PINS
    assert header["camera_resolution"] == [640, 480] and header["source"] == "sim"
    loaded = PerceptionModel.load(path)
    a, b = model.predict(heldout[0]), loaded.predict(heldout[0])
    np.testing.assert_allclose(b.theta_deg, a.theta_deg, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b.lateral_mm, a.lateral_mm, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b.std, a.std, rtol=0, atol=1e-9)
    assert b.ok.tolist() == a.ok.tolist()
    assert header["gp_inputs"] == {"cos": [0, 1, 2, 3], "sin": [0, 1, 2, 3], "lat": [1, 2, 3]}
    assert loaded.gp_inputs == model.gp_inputs and loaded._gps["lat"].X_train_.shape[1] == 3


def _rewrite_header(src, dst, **changes) -> None:
    with np.load(src, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(bytes(arrays["header"]).decode()) | changes
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    np.savez(dst, **arrays)


def test_load_refuses_a_model_whose_header_and_gps_disagree(model: PerceptionModel, tmp_path) -> None:
    """A version-1 file (every GP on all four inputs) is refused with what to do; a header
    that names other inputs than a GP was trained on is refused by name."""
    path = model.save(tmp_path / "model.npz")
    _rewrite_header(path, tmp_path / "v1.npz", format_version=1)
    with pytest.raises(UserError, match="format_version 1.*fit a new model"):
        PerceptionModel.load(tmp_path / "v1.npz")
    _rewrite_header(
        path, tmp_path / "inputs.npz", gp_inputs={"cos": [0, 1, 2, 3], "sin": [0, 1, 2, 3], "lat": [0, 1, 2, 3]}
    )
    with pytest.raises(UserError, match="GP 'lat' was trained on 3 inputs"):
        PerceptionModel.load(tmp_path / "inputs.npz")


def test_load_rejects_other_files(tmp_path) -> None:
    bad = tmp_path / "bad.npz"
    np.savez(bad, header=np.frombuffer(b'{"format": "x"}', np.uint8))
    with pytest.raises(UserError, match="format"):
        PerceptionModel.load(bad)
    with pytest.raises(UserError, match="not found"):
        PerceptionModel.load(tmp_path / "none.npz")


def test_no_contact_is_flagged_and_finite(model: PerceptionModel) -> None:
    pred = model.predict(model.reference_pins_px)
    assert np.isfinite(pred.theta_deg).all() and np.isfinite(pred.lateral_mm).all() and np.isfinite(pred.std).all()
    assert not pred.ok[0] and NO_CONTACT in pred.reason[0]
    v = model.spherical(model.reference_pins_px[None])
    assert np.isfinite(v).all()


def test_duplicate_training_points(train) -> None:
    pins, th, la, de = train
    idx = np.arange(0, len(pins), 3)
    dup = lambda a: np.concatenate([a[idx], a[idx], a[idx]])  # noqa: E731
    cfg = GPConfig(n_restarts=0, noise_bounds=(1e-9, 1.0), noise_init=1e-9)
    m = PerceptionModel(gp=cfg).fit(dup(pins), dup(th), dup(la), dup(de), np.random.default_rng(1))
    pred = m.predict(pins[::7])
    assert np.isfinite(pred.theta_deg).all() and np.isfinite(pred.lateral_mm).all()


def test_ill_conditioned_kernels_stay_finite(model: PerceptionModel, train, heldout) -> None:
    pins, th, la, de = train
    cfg = GPConfig(n_restarts=0, length_scale_bounds=(1e-5, 1e5), constant_bounds=(1e-5, 1e5))
    m = PerceptionModel(gp=cfg).fit(pins, th, la, de, np.random.default_rng(2))
    pred = m.predict(heldout[0])
    assert np.isfinite(pred.theta_deg).all() and np.isfinite(pred.std).all()
    # Extreme fixed hyperparameters: huge and tiny length scales, huge amplitude.
    x = np.random.default_rng(3).normal(size=(50, 4))
    x = np.concatenate([x, x])
    y = np.sin(x[:, 0])
    kernel = make_kernel(4, True, cfg)
    for length in (1e5, 1e-5):
        theta = np.log([1e5, length, length, length, length, 1e-6])
        gp = rebuild_gp(x, y, kernel, theta, 1e-10)
        mean, sd = gp.predict(x[:5] + 0.1, return_std=True)
        assert np.isfinite(mean).all() and np.isfinite(sd).all()


def test_angle_wrap(model: PerceptionModel) -> None:
    assert angle_error_deg(179.0, -179.0) == pytest.approx(-2.0)
    assert wrap_deg(180.0) == pytest.approx(-180.0)
    th = np.array([175.0, -175.0, 179.0, -179.5, 170.0, -165.0])
    la = np.full(len(th), -2.0)
    pred = model.predict(synthetic_tap_pins(th, la, np.full(len(th), 3.0)))
    assert np.max(np.abs(angle_error_deg(pred.theta_deg, th))) < 3.0
    assert np.all((pred.theta_deg >= -180) & (pred.theta_deg < 180))


def test_missing_pins(model: PerceptionModel, heldout) -> None:
    pins = heldout[0][:3].copy()
    full = model.predict(pins)
    few = pins.copy()
    few[:, [3, 50, 90, 100, 126]] = np.nan
    pred = model.predict(few)
    assert np.isfinite(pred.theta_deg).all() and np.isfinite(pred.lateral_mm).all()
    assert pred.ok.all() and all("5/127 pins missing" in r for r in pred.reason)
    assert np.max(np.abs(angle_error_deg(pred.theta_deg, full.theta_deg))) < 20.0
    found = np.ones((3, N_PINS), bool)
    found[:, :40] = False
    pred = model.predict(pins, found)
    assert not pred.ok.any() and all("too many missing" in r for r in pred.reason)


@pytest.mark.parametrize("size", [(1280, 960), (480, 640), (120, 160)])
def test_other_resolution_is_rescaled(model: PerceptionModel, heldout, size: tuple[int, int]) -> None:
    """Another size or shape (portrait: the field of view spans the short side) of the
    training camera gives the same predictions."""
    _, th, la, de = heldout
    cam = CameraModel(width=size[0], height=size[1])
    big = synthetic_tap_pins(th[:10], la[:10], de[:10], camera=cam)
    a = model.predict(heldout[0][:10])
    b = model.predict(big, resolution=size)
    np.testing.assert_allclose(b.theta_deg, a.theta_deg, atol=1e-6)
    np.testing.assert_allclose(b.lateral_mm, a.lateral_mm, atol=1e-6)


def test_baseline_single_length_scale(train, heldout) -> None:
    pins, th, la, de = train
    m = PerceptionModel(method="baseline", gp=FAST).fit(pins, th, la, de, np.random.default_rng(4))
    for gp in m._gps.values():
        assert np.ndim(gp.kernel_.k1.k2.length_scale) == 0
    pred = m.predict(heldout[0])
    assert np.isfinite(pred.theta_deg).all() and np.isfinite(pred.lateral_mm).all()


def test_fit_is_deterministic(train) -> None:
    pins, th, la, de = train
    sel = slice(None, None, 2)
    cfg = GPConfig(n_restarts=1)
    a = PerceptionModel(gp=cfg).fit(pins[sel], th[sel], la[sel], de[sel], np.random.default_rng(5))
    b = PerceptionModel(gp=cfg).fit(pins[sel], th[sel], la[sel], de[sel], np.random.default_rng(5))
    for k in a._gps:
        np.testing.assert_array_equal(a._gps[k].kernel_.theta, b._gps[k].kernel_.theta)


def test_tracker_to_perception_on_frames(model: PerceptionModel, heldout) -> None:
    pins, th, la, _ = heldout
    tracker = PinTracker(render_pins_frame(model.reference_pins_px))
    for k in range(3):
        tracker.reset()
        res = tracker.track(render_pins_frame(pins[k], noise_std=2.0, rng=np.random.default_rng(k)))
        pred = model.predict(res.pins_px, res.found)
        assert pred.ok[0]
        assert abs(angle_error_deg(pred.theta_deg[0], th[k])) < 5.0
        assert abs(pred.lateral_mm[0] - la[k]) < 1.0


def test_fit_rejects_bad_input(train) -> None:
    pins, th, la, de = train
    with pytest.raises(UserError, match=r"pins must be \(N, 127, 2\) px, got shape \(\d+, 100, 2\)"):
        PerceptionModel().fit(pins[:, :100], th, la, de, np.random.default_rng(0))
    with pytest.raises(UserError, match="no-contact"):
        PerceptionModel().fit(pins, th, np.minimum(la, 6.0), de, np.random.default_rng(0))


def test_no_contact_is_measured_not_labelled(train) -> None:
    # On the twin the 40 mm dome pressed 4 mm deep at l = 9.9 mm touches the edge. Those
    # frames are contact frames; the contact threshold must not swallow the 2 mm taps.
    pins, th, la, de = train
    touching = (la == 9.9) & (de == 4.0)
    pins = pins.copy()
    pins[touching] = synthetic_tap_pins(th[touching], np.full(touching.sum(), 6.0), de[touching])
    m = PerceptionModel(gp=FAST).fit(pins, th, la, de, np.random.default_rng(0))
    assert m.info["n_no_contact"] == 18 and m.info["n_labelled_no_contact_touching"] == 18
    nc = m.training_summary["no_contact"]
    assert nc[(la == 9.9) & (de == 2.0)].all() and not nc[touching].any()
    assert np.allclose(m.reference_pins_px, pins[0])
    light = (la <= 4.0) & (de == 2.0)  # the lightest real contacts of the training set
    assert m.predict(pins[light]).ok.all()
    assert not m.predict(pins[(la == 9.9) & (de == 2.0)]).ok.any()


@pytest.mark.parametrize("mode", ["pooled", "none"])
def test_depth_shift_modes(train, mode: str) -> None:
    pins, th, la, de = train
    m = PerceptionModel(gp=FAST, depth_shift_mode=mode).fit(pins, th, la, de, np.random.default_rng(0))
    assert len(m.depth_shift.shifts) == (1 if mode == "pooled" else 0)
    assert m.info["depth_shift"] == mode
    pred = m.predict(synthetic_tap_pins([30.0, -100.0], [0.0, 3.0], [3.0, 3.0]))
    assert pred.ok.all() and np.max(np.abs(angle_error_deg(pred.theta_deg, [30.0, -100.0]))) < 5.0
    with pytest.raises(UserError, match="depth_shift_mode"):
        PerceptionModel(depth_shift_mode="sideways")
