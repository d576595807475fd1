"""TactipCamera on a real MJPG video written with cv2.VideoWriter and read back through
cv2.VideoCapture (no mocks), and on a device index that does not exist."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from hardware.camera import TactipCamera
from twin.core.errors import HardwareError

W, H = 640, 480
BITS = 8
N_FRAMES = 12


def tactip_like_frame(counter: int, width: int = W, height: int = H) -> np.ndarray:
    """BGR frame: bright pins on a dark disc, the counter as 8 black/white blocks at the
    top, and a red square top-left (to check the BGR → RGB conversion)."""
    img = np.full((height, width, 3), 20, np.uint8)
    cv2.circle(img, (width // 2, height // 2 + 20), int(height * 0.42), (60, 60, 60), -1)
    rng = np.random.default_rng(counter)
    for i in range(-5, 6):
        for j in range(-4, 5):
            u = width // 2 + 30 * i + (15 if j % 2 else 0) + int(rng.integers(-2, 3))
            v = height // 2 + 20 + 26 * j
            cv2.circle(img, (u, v), 5, (235, 235, 235), -1)
    for b in range(BITS):
        on = (counter >> b) & 1
        img[0:24, 160 + 40 * b : 160 + 40 * b + 32] = 255 if on else 0
    img[0:24, 0:24] = (0, 0, 255)  # red in BGR
    return img


def decode_counter(rgb: np.ndarray) -> int:
    value = 0
    for b in range(BITS):
        if rgb[4:20, 164 + 40 * b : 164 + 40 * b + 24].mean() > 128:
            value |= 1 << b
    return value


def write_video(path: Path, frames: list[np.ndarray], fps: float = 30.0) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (frames[0].shape[1], frames[0].shape[0]))
    assert writer.isOpened(), "OpenCV cannot write MJPG .avi"
    for f in frames:
        writer.write(f)
    writer.release()
    return path


@pytest.fixture(scope="module")
def video(tmp_path_factory) -> Path:
    return write_video(tmp_path_factory.mktemp("cam") / "tactip.avi", [tactip_like_frame(i) for i in range(N_FRAMES)])


def test_frames_in_order_with_increasing_timestamps_then_end_of_video(video):
    with TactipCamera(str(video)) as cam:
        frames = [cam.read_fresh() for _ in range(N_FRAMES)]
        assert [decode_counter(f.image) for f in frames] == list(range(N_FRAMES))
        assert [f.index for f in frames] == list(range(N_FRAMES))
        times = [f.time for f in frames]
        assert all(b > a for a, b in zip(times, times[1:]))
        assert times[-1] <= time.monotonic()
        for f in frames:
            assert f.image.shape == (H, W, 3) and f.image.dtype == np.uint8
        r, g, b = frames[0].image[4:20, 4:20].reshape(-1, 3).mean(axis=0)
        assert r > 200 and g < 60 and b < 60, "frames are RGB"
        with pytest.raises(HardwareError, match=r"end of video after 12 frames"):
            cam.read_fresh()


def test_read_after_close_and_double_close(video):
    cam = TactipCamera(video)
    cam.read_fresh()
    cam.close()
    cam.close()
    with pytest.raises(HardwareError, match="closed"):
        cam.read_fresh()


def test_stale_repeated_frame_is_an_error(tmp_path):
    frozen = tactip_like_frame(3)
    path = write_video(tmp_path / "frozen.avi", [tactip_like_frame(0)] + [frozen] * 6)
    with TactipCamera(str(path), max_identical=3) as cam:
        # (the MJPG encoder may code the first repeat differently; the rest are identical)
        with pytest.raises(HardwareError, match=r"same \(stale\) frame 4 times"):
            for _ in range(7):
                cam.read_fresh()
        assert cam._index < 7, "raised before the end of the video"


def test_wrong_frame_size_is_an_error(video):
    with TactipCamera(str(video), width=320, height=240) as cam:
        with pytest.raises(HardwareError, match=r"frame is 640×480, expected 320×240"):
            cam.read_fresh()


def test_missing_file():
    with pytest.raises(HardwareError, match="no such video file"):
        TactipCamera("/nonexistent/tactip.avi")


def test_missing_device_fails_fast():
    t0 = time.monotonic()
    with pytest.raises(HardwareError, match=r"camera 97 not found \(unplugged\?\)"):
        TactipCamera(97)
    assert time.monotonic() - t0 < 2.0
