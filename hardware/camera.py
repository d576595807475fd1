"""The TacTip's internal USB camera (or a recorded video standing in for it).

`TactipCamera(source)`:

* ``source: int`` — a V4L2 device index (/dev/video<N>). Opened with `cv2.CAP_V4L2`,
  MJPG at width×height (default 640×480), driver buffer size 1, and — when `exposure` is
  given — manual exposure: V4L2 `exposure_absolute` in **units of 100 µs** (so 156 means
  15.6 ms), with auto exposure switched to manual (V4L2 value 1).
* ``source: str`` — a video file (read frame by frame, in order) or a stream URL
  (``scheme://...``), opened with `cv2.VideoCapture(source)`.

Freshness (`read_fresh`): V4L2 keeps a queue of filled buffers (~4), so the first frame
read after a move may have been exposed *before* the move. We **grab and discard**
(no background thread): for a device, buffers are grabbed until one whose driver
timestamp (CLOCK_MONOTONIC, the clock of `time.monotonic`) is later than the call; if
the driver gives no usable timestamp, `flush_frames` buffers (default 4) are discarded
first. A video file has no stale buffers: each call returns the next frame. A stream URL
is treated like a device without timestamps.

Every frame is stamped with `time.monotonic()` (s) when it was read, and returned as RGB
(H, W, 3) uint8 (OpenCV delivers BGR; we convert), the frame layout of
`twin.core.environment.Observation.frame`. Live sources (device, URL) are warmed up with `warmup`
frames on open (auto gain / exposure settle); a file starts at its first frame.

Failures raise `HardwareError`: the device cannot be opened ("camera 0 not found
(unplugged?)"), no frame comes back (end of a video, camera unplugged), the frame size
is not width×height, or `max_identical` consecutive frames are bit-identical (a frozen
driver re-delivering one buffer — a live TacTip image always has sensor noise).
"""

from __future__ import annotations

import hashlib
import os
import time
from dataclasses import dataclass

import cv2
import numpy as np

from twin.core.errors import HardwareError

#: V4L2 auto-exposure menu value for manual exposure, as passed through by OpenCV's V4L2 backend
V4L2_EXPOSURE_MANUAL = 1


@dataclass(frozen=True)
class Frame:
    """One camera frame.

    | field       | type / unit                                                          |
    |-------------|----------------------------------------------------------------------|
    | image       | (H, W, 3) uint8, RGB, pixel (0, 0) top-left                          |
    | time        | s, time.monotonic() when the frame was read                          |
    | index       | frames delivered by `read_fresh` since open, from 0                  |
    | source_time | s, driver timestamp (device: CLOCK_MONOTONIC; file: position in the  |
    |             | video), None when the backend gives none                             |
    """

    image: np.ndarray
    time: float
    index: int
    source_time: float | None = None


class TactipCamera:
    """Frames of the TacTip camera, each captured after the call that returns it."""

    def __init__(
        self,
        source: int | str,
        width: int = 640,
        height: int = 480,
        exposure: float | None = None,
        warmup: int = 8,
        *,
        flush_frames: int = 4,
        max_identical: int = 3,
        max_grabs: int = 30,
        read_timeout_s: float = 2.0,
    ) -> None:
        self.source = source
        self.width, self.height = int(width), int(height)
        self.exposure = exposure
        self.flush_frames = int(flush_frames)
        self.max_identical = int(max_identical)
        self.max_grabs = int(max_grabs)
        self._index = 0
        self._last_digest: bytes | None = None
        self._identical = 0
        self._device_clock_ok: bool | None = None
        self._cap: cv2.VideoCapture | None = None
        if isinstance(source, (int, np.integer)) and not isinstance(source, bool):
            self.kind = "device"
            self._cap = self._open_device(int(source), read_timeout_s)
        elif isinstance(source, (str, os.PathLike)):
            path = os.fspath(source)
            self.kind = "stream" if "://" in path else "file"
            if self.kind == "file" and not os.path.isfile(path):
                raise HardwareError(f"camera {path!r}: no such video file")
            cap = cv2.VideoCapture(path)
            if not cap.isOpened():
                cap.release()
                raise HardwareError(f"camera {path!r}: OpenCV cannot open it (codec or URL not supported?)")
            self._cap = cap
        else:
            raise HardwareError(f"camera source must be a device index or a path/URL, got {source!r}")
        if self.kind != "file":
            for _ in range(max(0, int(warmup))):
                self._grab_retrieve()

    @property
    def name(self) -> str:
        return f"camera {self.source!r}" if self.kind != "device" else f"camera {self.source}"

    # ------------------------------------------------------------------ open
    def _open_device(self, index: int, read_timeout_s: float) -> cv2.VideoCapture:
        if os.name == "posix" and not os.path.exists(f"/dev/video{index}"):
            raise HardwareError(f"camera {index} not found (unplugged?): no /dev/video{index}")
        cap = cv2.VideoCapture(index, cv2.CAP_V4L2)
        if not cap.isOpened():
            cap.release()
            raise HardwareError(f"camera {index} not found (unplugged?): V4L2 cannot open /dev/video{index}")
        # FOURCC before the size: some UVC drivers only offer 640×480@30 in MJPG.
        cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*"MJPG"))
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
        cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)
        if hasattr(cv2, "CAP_PROP_READ_TIMEOUT_MSEC"):
            cap.set(cv2.CAP_PROP_READ_TIMEOUT_MSEC, read_timeout_s * 1e3)
        if self.exposure is not None:
            cap.set(cv2.CAP_PROP_AUTO_EXPOSURE, V4L2_EXPOSURE_MANUAL)
            cap.set(cv2.CAP_PROP_EXPOSURE, float(self.exposure))  # 100 µs units
        return cap

    # ------------------------------------------------------------------ read
    def read_fresh(self) -> Frame:
        """A frame captured after this call (RGB, stamped with time.monotonic())."""
        if self._cap is None:
            raise HardwareError(f"{self.name} is closed")
        t_call = time.monotonic()
        if self.kind == "file":
            image, source_time = self._grab_retrieve()
        elif self.kind == "device" and self._device_clock_ok is not False:
            image, source_time = self._read_after(t_call)
        else:
            for _ in range(self.flush_frames):
                self._grab()
            image, source_time = self._grab_retrieve()
        self._check_not_frozen(image)
        frame = Frame(cv2.cvtColor(image, cv2.COLOR_BGR2RGB), time.monotonic(), self._index, source_time)
        self._index += 1
        return frame

    def _read_after(self, t_call: float) -> tuple[np.ndarray, float | None]:
        """Grab until the driver's buffer timestamp is later than t_call."""
        for _ in range(self.max_grabs):
            self._grab()
            stamp_ms = self._cap.get(cv2.CAP_PROP_POS_MSEC)
            now = time.monotonic()
            if self._device_clock_ok is None:
                # usable only if the driver stamps with CLOCK_MONOTONIC (within 10 s of now)
                self._device_clock_ok = bool(stamp_ms > 0 and abs(stamp_ms * 1e-3 - now) < 10.0)
                if not self._device_clock_ok:
                    for _ in range(self.flush_frames):
                        self._grab()
                    return self._retrieve(), None
            if stamp_ms * 1e-3 >= t_call:
                return self._retrieve(), stamp_ms * 1e-3
        raise HardwareError(
            f"{self.name}: no frame newer than the request after {self.max_grabs} grabs (camera stalled?)"
        )

    def _grab(self) -> None:
        if not self._cap.grab():
            raise self._no_frame()

    def _retrieve(self) -> np.ndarray:
        ok, image = self._cap.retrieve()
        if not ok or image is None:
            raise self._no_frame()
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        if image.shape[:2] != (self.height, self.width):
            raise HardwareError(
                f"{self.name}: frame is {image.shape[1]}×{image.shape[0]}, expected {self.width}×{self.height}"
            )
        return image

    def _grab_retrieve(self) -> tuple[np.ndarray, float | None]:
        self._grab()
        image = self._retrieve()
        stamp_ms = self._cap.get(cv2.CAP_PROP_POS_MSEC)
        return image, (stamp_ms * 1e-3 if stamp_ms > 0 else None)

    def _no_frame(self) -> HardwareError:
        if self.kind == "file":
            return HardwareError(f"{self.name}: end of video after {self._index} frames (no more frames to read)")
        return HardwareError(f"{self.name}: returned no frame (unplugged or stalled?) after {self._index} frames")

    def _check_not_frozen(self, image: np.ndarray) -> None:
        digest = hashlib.blake2b(image.tobytes(), digest_size=16).digest()
        self._identical = self._identical + 1 if digest == self._last_digest else 0
        self._last_digest = digest
        if self.max_identical and self._identical >= self.max_identical:
            raise HardwareError(
                f"{self.name}: the same (stale) frame {self._identical + 1} times in a row — frozen driver or camera?"
            )

    # ------------------------------------------------------------------ close
    def close(self) -> None:
        """Release the device or file. Safe to call twice."""
        cap, self._cap = self._cap, None
        if cap is not None:
            cap.release()

    def __enter__(self) -> TactipCamera:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        self.close()
