"""Rendering: golden no-contact frame per GL backend, pins all found, overview image."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from tests.golden.frames import GOLDEN_FRAMES
from twin.core.scenario import load_scenario
from twin.core.sensor import CameraModel
from twin.runs.sim_env import SimEnvironment, first_pose, render_scenario_view
from twin.sensing.tracker import PinTracker
from twin.world import gl
from twin.world.render import PinRenderer, pin_sphere_slices

GOLDEN_DIR = Path(__file__).resolve().parents[1] / "golden"
FAILURES = GOLDEN_DIR / "failures"
RMS_TOLERANCE = 2.0  # grey levels; llvmpipe vs GPU rasterisation differ by < 1 on edges
SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "rectangle_render.yaml"


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(float) - b.astype(float)) ** 2)))


@pytest.mark.parametrize("name", sorted(GOLDEN_FRAMES))
def test_golden_frame(name: str) -> None:
    expected_path = GOLDEN_DIR / gl.GL_BACKEND / f"{name}.png"
    if not expected_path.exists():
        pytest.fail(
            f"no golden image for backend {gl.GL_BACKEND}: run tests/golden/regenerate.py with MUJOCO_GL={gl.GL_BACKEND}"
        )
    expected = cv2.imread(str(expected_path))[..., ::-1]
    actual = GOLDEN_FRAMES[name]()
    rms = _rms(actual, expected) if actual.shape == expected.shape else float("inf")
    if rms > RMS_TOLERANCE:
        FAILURES.mkdir(exist_ok=True)
        cv2.imwrite(str(FAILURES / f"{gl.GL_BACKEND}_{name}_expected.png"), expected[..., ::-1])
        cv2.imwrite(str(FAILURES / f"{gl.GL_BACKEND}_{name}_actual.png"), actual[..., ::-1])
        if actual.shape == expected.shape:
            diff = np.abs(actual.astype(int) - expected.astype(int)).astype(np.uint8)
            cv2.imwrite(str(FAILURES / f"{gl.GL_BACKEND}_{name}_diff.png"), (diff * 8).clip(0, 255)[..., ::-1])
    assert rms <= RMS_TOLERANCE, f"{name}: RMS {rms:.2f} > {RMS_TOLERANCE}; images saved in {FAILURES}"


def test_golden_check_detects_a_changed_frame() -> None:
    frame = GOLDEN_FRAMES["no_contact"]()
    shifted = np.roll(frame, 3, axis=1)
    assert _rms(frame, shifted) > RMS_TOLERANCE


def test_no_contact_frame_has_all_pins() -> None:
    scenario = load_scenario(SCENARIO)
    with SimEnvironment(scenario) as env:
        env.move_to(first_pose(scenario))
        obs = env.observe()
        tracker = PinTracker(obs.frame)
        result = tracker.track(obs.frame)
    assert result.found.sum() == 127
    err = np.linalg.norm(result.pins_px - obs.truth["pins_px"], axis=1)
    assert np.sqrt(np.mean(err**2)) < 0.5


def test_frame_looks_like_a_tactip() -> None:
    """White pins on a dark background inside a circular aperture."""
    frame = GOLDEN_FRAMES["no_contact"]()
    grey = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)
    h, w = grey.shape
    assert grey[0, 0] == 0 and grey[h - 1, w - 1] == 0  # outside the aperture: black
    assert 5 < np.median(grey[h // 2 - 40 : h // 2 + 40, w // 2 - 40 : w // 2 + 40]) < 60  # dark skin
    assert grey.max() > 200  # white pins


def test_overview_image(tmp_path: Path) -> None:
    out = render_scenario_view(load_scenario(SCENARIO), tmp_path / "scene.png", view="scene")
    image = cv2.imread(str(out))
    assert image is not None and image.shape[0] > 100 and image.std() > 10


def test_pin_spheres_are_coarser_only_below_the_default_frame() -> None:
    """640×480 and larger frames keep today's 16-slice pins (their frames are unchanged);
    smaller frames get fewer slices, never fewer than 6, fewer the smaller the frame."""
    shapes = [(96, 96), (128, 128), (160, 120), (120, 160), (320, 240), (640, 480), (1280, 960)]
    slices = {(w, h): pin_sphere_slices(CameraModel(width=w, height=h)) for w, h in shapes}
    assert slices[(640, 480)] == slices[(1280, 960)] == 16
    assert slices[(96, 96)] < slices[(320, 240)] < 16
    assert slices[(120, 160)] == slices[(160, 120)]  # same short side, same pin size
    assert min(slices.values()) >= 6
    ordered = [slices[shape] for shape in sorted(slices, key=min)]
    assert ordered == sorted(ordered)


@pytest.mark.parametrize("shape", [(96, 96), (128, 128), (120, 160)])
def test_small_frames_with_coarse_pins_track_every_pin(shape: tuple[int, int]) -> None:
    camera = CameraModel(width=shape[0], height=shape[1])
    renderer = PinRenderer(camera)
    try:
        frame = renderer.render(camera.geometry.pin_tip_points())
    finally:
        renderer.close()
    assert frame.shape == (shape[1], shape[0], 3)
    assert PinTracker(frame).track(frame).found.sum() == 127
