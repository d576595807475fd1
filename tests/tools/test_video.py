"""Run videos and the viewer, headless: `twin video` / `twin run --video` write one H.264
frame per sample whose camera panel is the recorded PNG; `twin compare --video` pairs two
runs with their pin fields in two colours; `twin view` without a display exits 2."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest
import yaml

from twin.core.scenario import scenario_from_dict
from twin.runs.contour_run import run_contour
from twin.runs.record import load_run
from twin.sensing.perception import GPConfig, PerceptionModel, paper_training_labels, synthetic_tap_pins
from twin.tools.cli import main
from twin.tools.video import COMPARE_PANEL, PAIR_COLOURS, PANEL_HEIGHT, SIDE_SIZE, sensor_panel

TAPS = {
    "name": "video_taps",
    "object": {"name": "rectangle"},
    "fidelity": "fast",
    "effects": ["contact", "friction", "render"],
    "protocol": {"kind": "taps", "orientations_deg": [0], "lateral_mm": [9.9, 2, -2], "depths_mm": [3]},
}
#: H.264 (quality 8, 4:2:0 chroma) against the PNG where nothing is drawn over it: the mean
#: absolute error measured 0.5–0.6 grey levels; 2 leaves room for other ffmpeg builds while
#: a neighbouring sample's PNG (pins moved a few px) is ≥ 3× further away (asserted below).
DECODE_MAE_GREY = 2.0


def decoded_frames(path) -> list[np.ndarray]:
    """Every frame of a video, RGB, as OpenCV decodes it."""
    capture = cv2.VideoCapture(str(path))
    assert capture.isOpened(), path
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame[..., ::-1])
    return frames


@pytest.fixture(scope="module")
def contour_run(tmp_path_factory):
    """A 4-step contour run on the small circle (fast dome, rendered and tracked frames)."""
    th, la, de = paper_training_labels()
    model = PerceptionModel(gp=GPConfig(n_restarts=0)).fit(
        synthetic_tap_pins(th, la, de), th, la, de, np.random.default_rng(0)
    )
    scenario = scenario_from_dict(
        {
            "name": "video_circle",
            "object": {"name": "small_circle"},
            "fidelity": "fast",
            "effects": ["contact", "friction", "render"],
            "protocol": {"kind": "contour", "max_steps": 4},
        }
    )
    return run_contour(scenario, tmp_path_factory.mktemp("video") / "run", model=model, progress=False)


def test_run_video_has_one_frame_per_sample_showing_its_png(contour_run) -> None:
    assert main(["video", str(contour_run)]) == 0
    run = load_run(contour_run)
    rest = run.rest_pins_px
    assert rest.shape == (127, 2) and np.all(np.isfinite(rest))
    # rest pins are the no-contact reference, not the first (pressed) sample
    assert np.max(np.linalg.norm(run.pins_px[0] - rest, axis=1)) > 1.0
    frames = decoded_frames(contour_run / "video.mp4")
    assert len(frames) == len(run.samples) == 4
    assert frames[0].shape == (PANEL_HEIGHT, 640 + SIDE_SIZE[0], 3)
    for k, frame in enumerate(frames):
        png = run.frame(k)
        # what the video draws over the camera frame: pins and arrows; text in the top and bottom rows
        drawn = sensor_panel(png, run.resolution, run.pins_px[k], rest, np.asarray(run.samples[k]["found"]))
        overlay = cv2.dilate(np.any(drawn != png, axis=2).astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool)
        clean = ~overlay
        clean[:48], clean[-28:] = False, False
        assert clean.mean() > 0.6
        error = np.abs(frame[:, :640].astype(float) - png.astype(float))[clean].mean()
        print(f"sample {k}: decoded vs PNG {error:.2f} grey levels MAE on {clean.mean():.0%} of the panel")
        assert error < DECODE_MAE_GREY, (k, error)
        other = run.frame((k + 2) % len(frames))
        other_error = np.abs(frame[:, :640].astype(float) - other.astype(float))[clean].mean()
        print(f"  vs another sample's PNG {other_error:.2f}")
        assert other_error > 3 * error


def test_run_and_compare_videos_from_the_command_line(tmp_path, capsys, monkeypatch) -> None:
    """`twin run --video` writes the video (without it, none), `twin compare --video` the
    pairs side by side with both pin fields in their two colours (the two dome models, so
    that the fields lie apart)."""
    for name, dome, flags in (("a", "compliant", ["--video"]), ("b", "flex", [])):
        path = tmp_path / f"{name}.yaml"
        path.write_text(yaml.safe_dump({**TAPS, "dome": dome}))
        assert main(["run", str(path), "--out", str(tmp_path / name), "--workers", "1", "--quiet", *flags]) == 0
    out = capsys.readouterr().out
    assert "× the run's" in out, out
    assert len(decoded_frames(tmp_path / "a" / "video.mp4")) == 3
    assert not (tmp_path / "b" / "video.mp4").exists()
    assert main(["compare", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(tmp_path / "cmp"), "--video"]) == 0
    pairs = json.loads((tmp_path / "cmp" / "comparison.json").read_text())["n_pairs"]
    frames = decoded_frames(tmp_path / "cmp" / "comparison.mp4")
    assert len(frames) == pairs == 3
    w, h = COMPARE_PANEL
    assert frames[0].shape == (h, 3 * w, 3)
    overlay = frames[-1][60:-40, 2 * w :].astype(int)  # the pressed tap, both fields, without the text
    for colour in PAIR_COLOURS:
        assert (np.abs(overlay - colour).max(axis=2) < 50).sum() > 127, colour  # a dot per pin at least
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(tmp_path / "a.yaml")]) == 2
    assert "twin view needs a display" in capsys.readouterr().err


@pytest.mark.skipif(
    shutil.which("Xvfb") is None, reason="needs Xvfb (apt-get install xvfb; the README's test command installs it)"
)
def test_view_runs_a_scenario_on_a_virtual_display(tmp_path) -> None:
    """`twin view` opens mujoco.viewer on a display, shows every sample and closes cleanly.
    In its own process: GLFW keeps its X connection until the process ends."""
    display = ":93"
    server = subprocess.Popen(["Xvfb", display, "-screen", "0", "1280x800x24"], stderr=subprocess.DEVNULL)
    try:
        time.sleep(1.0)
        path = tmp_path / "render.yaml"
        path.write_text(
            yaml.safe_dump({**TAPS, "protocol": {"kind": "render", "poses": [[0, 0, -5, 0, 0, 0], [0, 0, 2, 0, 0, 0]]}})
        )
        done = subprocess.run(
            [sys.executable, "-m", "twin.tools.cli", "view", str(path), "--no-wait"],
            env={**os.environ, "DISPLAY": display},
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
        assert "showed 2 samples" in done.stdout
    finally:
        server.terminate()
        server.wait()
