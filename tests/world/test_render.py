"""Rendering: golden no-contact frame per GL backend, pins all found, overview image."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from tests.golden.frames import GOLDEN_FRAMES
from twin.core.scenario import load_scenario
from twin.runs.sim_env import SimEnvironment, first_pose, render_scenario_view
from twin.sensing.tracker import PinTracker
from twin.world import gl

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
