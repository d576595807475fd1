"""The inside-camera frame without OpenGL: each pin's exact silhouette, drawn in numpy.

Unlit (no `lighting` effect, no anti-aliasing), twin.world.render's scene is flat: white
pin spheres in front of a uniformly dark skin disc that fills the circular aperture,
black beyond it. Such a frame is fixed by which pixel centres see a sphere, and that has
a closed form: the ray through pixel (u, v) of the nominal pinhole camera,
d = ((u − cx)/f, (v − cy)/f, 1), meets a sphere of centre C and radius r when
(d·C)² ≥ |d|²(|C|² − r²) with d·C > 0. This renderer evaluates that test on the pixels of
each pin's bounding box (the box from the sphere's tangent planes through the camera,
exact), so its cost is the pins' area, not a GL pipeline's fixed cost: at 128×128 it
takes a fraction of the GL renderer's time (`twin bench pixels`). The spheres are exact
where GL draws polygons inscribed in them (16 slices at 640×480, fewer in small frames:
twin.world.render.pin_sphere_slices), so a silhouette pin covers a few per cent more pixels
than a GL one, all along its outline; tracked pins differ from the GL frame's by
≈ 0.1 px at 640×480 and ≈ 0.25 px at 128×128 (tests/world/test_silhouette.py).

Frames and units: pins in the tool frame (m); the camera is the nominal one
(twin.core.sensor.CameraModel.nominal: a calibrated camera's pins are placed for it by
twin.runs.sim_env, as for the GL renderer).
"""

from __future__ import annotations

import cv2
import numpy as np

from twin.core.sensor import CameraModel
from twin.world.render import PIN_GREY, SKIN_GREY, add_camera_noise


class SilhouetteRenderer:
    """Renders the unlit inside-camera frame (H, W, 3) uint8 RGB from pin tips in the tool
    frame, as twin.world.render.PinRenderer does without lighting or anti-aliasing (module
    docstring), through `camera`'s pinhole (the nominal camera, as the GL renderer's).
    `noise_std` (grey levels) adds per-pixel Gaussian camera noise drawn from the generator
    passed to `render`."""

    def __init__(self, camera: CameraModel) -> None:
        self.camera = camera
        k = self.camera.intrinsics
        self._focal, self._centre = float(k[0, 0]), np.array([k[0, 2], k[1, 2]])
        self._radius = self.camera.geometry.pin_radius
        v, u = np.mgrid[0 : self.camera.height, 0 : self.camera.width]
        aperture = (u - self._centre[0]) ** 2 + (v - self._centre[1]) ** 2 <= self.camera.aperture_radius_px**2
        self._background = np.where(aperture, SKIN_GREY, 0).astype(np.uint8)

    def _boxes(self, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n, 2) first and last pixel (u, v) of each sphere's silhouette, from the tangent
        planes through the camera that contain the other image axis."""
        z = centres[:, 2:3]
        lateral = centres[:, :2]
        half_angle = np.arcsin(np.minimum(1.0, self._radius / np.hypot(lateral, z)))
        axis_angle = np.arctan2(lateral, z)
        low = self._focal * np.tan(axis_angle - half_angle) + self._centre
        high = self._focal * np.tan(axis_angle + half_angle) + self._centre
        return np.ceil(low).astype(int), np.floor(high).astype(int)

    def render(
        self,
        pins_tool: np.ndarray,
        noise_std: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> np.ndarray:
        """Frame for (127, 3) pin tips in the tool frame (m)."""
        centres = self.camera.in_nominal_camera(pins_tool)
        if not np.all(np.isfinite(centres)):
            raise ValueError(f"pin tips must be finite, got {np.count_nonzero(~np.isfinite(centres))} NaN/Inf values")
        if not np.all(centres[:, 2] > self._radius):
            raise ValueError("a pin sphere reaches the camera's plane: no silhouette to draw")
        first, last = self._boxes(centres)
        steps = np.arange(int(np.max(last - first)) + 1)
        u = first[:, 0:1] + steps  # (n, size) pixel columns of each pin's box
        v = first[:, 1:2] + steps  # (n, size) pixel rows
        du = (u - self._centre[0]) / self._focal
        dv = (v - self._centre[1]) / self._focal
        # d·C and |d|² over each box, (n, rows, columns), from their row and column parts
        along = (du * centres[:, 0:1])[:, None, :] + (dv * centres[:, 1:2] + centres[:, 2:3])[:, :, None]
        length2 = (du * du)[:, None, :] + (dv * dv + 1.0)[:, :, None]
        beyond = np.sum(centres**2, axis=1) - self._radius**2  # |C|² − r²
        height, width = self._background.shape
        in_frame = ((v >= 0) & (v < height))[:, :, None] & ((u >= 0) & (u < width))[:, None, :]
        pin, row, column = np.nonzero(in_frame & (along > 0) & (along * along >= length2 * beyond[:, None, None]))
        grey = self._background.copy()
        grey[v[pin, row], u[pin, column]] = PIN_GREY
        frame = cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB)  # the grey on all three channels, 20–40× np.repeat's speed
        return add_camera_noise(frame, noise_std, rng)

    def close(self) -> None:
        """Nothing to release (no GL context): InsideRenderer's close (twin.world.render)."""
