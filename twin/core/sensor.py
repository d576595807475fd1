"""TacTip geometry and the internal camera model.

Everything is in the tool frame (m): origin at the undeformed dome apex (the TCP),
+z along the sensor axis pointing out of the tip, +x and +y matching the camera's
image u (right) and v (down). Sources for each number: assets/tactip/README.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

N_PINS = 127
PIN_RINGS = 6  # rings 1+6+12+18+24+30+36 = 127 on a hexagonal grid


@dataclass(frozen=True)
class TacTipGeometry:
    """Dimensions of the TacTip dome (all in m)."""

    dome_outer_radius: float = 0.020  # 40 mm dome (paper §III-A)
    skin_thickness: float = 0.0015  # rubber-like skin over the gel
    pin_length: float = 0.002  # pins protrude inwards from the skin
    pin_radius: float = 0.0006  # 1.2 mm pin tips
    pin_spacing: float = 0.0033  # arc length between neighbouring pins on the inner skin
    base_length: float = 0.018  # cylindrical part between the dome's equator and the camera mount
    camera_to_apex: float = 0.045  # camera optical centre to apex, along the axis

    @property
    def sphere_centre_z(self) -> float:
        """z of the dome's sphere centre in the tool frame (m)."""
        return -self.dome_outer_radius

    @property
    def skin_inner_radius(self) -> float:
        return self.dome_outer_radius - self.skin_thickness

    @property
    def pin_tip_radius(self) -> float:
        """Radius of the sphere the white pin tips lie on (m)."""
        return self.skin_inner_radius - self.pin_length

    @cached_property
    def pin_lattice(self) -> np.ndarray:
        """(127, 2) hexagonal lattice coordinates in units of the pin spacing.

        Ordered ring by ring from the centre; within a ring counter-clockwise from +x.
        This order is the pin identity everywhere in the twin.
        """
        return hexagonal_lattice(PIN_RINGS)

    def pin_tip_points(self) -> np.ndarray:
        """(127, 3) undeformed pin tips (what the camera sees), tool frame (m)."""
        return self._on_sphere(self.pin_tip_radius)

    def pin_base_points(self) -> np.ndarray:
        """(127, 3) where the pins leave the skin (its inner surface), tool frame (m)."""
        return self._on_sphere(self.skin_inner_radius)

    def _on_sphere(self, radius: float) -> np.ndarray:
        # Azimuthal-equidistant wrap of the planar lattice onto the dome: the arc length
        # from the apex equals the planar distance, so neighbouring pins stay evenly spaced.
        planar = self.pin_lattice * self.pin_spacing
        arc = np.linalg.norm(planar, axis=1)
        polar = arc / self.skin_inner_radius
        azimuth = np.arctan2(planar[:, 1], planar[:, 0])
        return np.column_stack(
            [
                radius * np.sin(polar) * np.cos(azimuth),
                radius * np.sin(polar) * np.sin(azimuth),
                self.sphere_centre_z + radius * np.cos(polar),
            ]
        )


def hexagonal_lattice(rings: int) -> np.ndarray:
    """Points of a hexagonal lattice (unit spacing) within `rings` hex rings, 1+6+…+6·rings.

    Ring k has 6k points; each ring starts on +x and runs counter-clockwise.
    """
    directions = np.array([[np.cos(a), np.sin(a)] for a in np.radians(np.arange(0, 360, 60))])
    points = [np.zeros(2)]
    for k in range(1, rings + 1):
        for side in range(6):
            start = directions[side] * k
            step = directions[(side + 2) % 6]
            points.extend(start + step * j for j in range(k))
    return np.array(points)


@dataclass(frozen=True)
class CameraModel:
    """Camera inside the TacTip base (OpenCV model: pinhole, radial k1, k2 and tangential
    p1, p2 distortion).

    Nominal camera (the defaults): the camera frame is the tool frame shifted back by
    `geometry.camera_to_apex` along z: z forward (towards the tip), u right (+x), v down
    (+y); no distortion; intrinsics from the field of view across the frame's short side
    (the height of a landscape frame, the width of a portrait one), scaled with the
    resolution so that the field of view stays the same: the circular aperture fits the
    short side whatever the frame's shape. A calibrated camera (twin.core.calibration)
    overrides the focal length (px) and principal point (px), adds distortion and moves the
    camera in the tool by `offset_mm` (mm, tool frame) and `rotation_deg` (deg, extrinsic
    XYZ, camera axes relative to the nominal ones).
    """

    width: int = 640
    height: int = 480
    fov_y_deg: float = 56.0  # field of view across the short side (deg): the vertical one of a landscape frame
    aperture_fraction: float = 0.94  # circular aperture radius / half the frame's short side
    geometry: TacTipGeometry = field(default_factory=TacTipGeometry)
    focal_override_px: float | None = None  # px; None = from fov_y_deg
    principal_point_px: tuple[float, float] | None = None  # px; None = frame centre
    distortion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # OpenCV k1, k2, p1, p2
    offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # optical centre moved in the tool frame (mm)
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)  # camera axes turned (extrinsic XYZ, deg)

    @property
    def focal_px(self) -> float:
        if self.focal_override_px is not None:
            return float(self.focal_override_px)
        return 0.5 * self.short_side_px / np.tan(np.radians(self.fov_y_deg) / 2)

    @property
    def short_side_px(self) -> int:
        """The frame's short side (px): the height of a landscape or square frame."""
        return min(self.width, self.height)

    @property
    def vertical_fov_deg(self) -> float:
        """Vertical field of view (deg) of the nominal camera: `fov_y_deg` unless the frame
        is portrait (what a GL camera, which takes the vertical one, is given)."""
        if self.height <= self.width:
            return self.fov_y_deg
        return float(np.degrees(2.0 * np.arctan(np.tan(np.radians(self.fov_y_deg) / 2) * self.height / self.width)))

    @cached_property
    def intrinsics(self) -> np.ndarray:
        """3×3 matrix K (px)."""
        f = self.focal_px
        # GL puts the optical axis on the frame centre, which is pixel (W−1)/2 in the
        # OpenCV convention (integer coordinates at pixel centres).
        cx, cy = self.principal_point_px or ((self.width - 1) / 2, (self.height - 1) / 2)
        return np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])

    @cached_property
    def is_pinhole(self) -> bool:
        """True when the camera sits at its nominal place without distortion (the fast path)."""
        return not any(self.distortion) and not any(self.offset_mm) and not any(self.rotation_deg)

    @cached_property
    def _tool2camera(self) -> tuple[np.ndarray, np.ndarray]:
        """(R, t): camera-frame point = R · tool point + t (m)."""
        rx, ry, rz = np.radians(self.rotation_deg)
        cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
        camera2tool = (
            np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
            @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        )
        centre = np.array([0.0, 0.0, -self.geometry.camera_to_apex]) + np.asarray(self.offset_mm) * 1e-3
        return camera2tool.T, -camera2tool.T @ centre

    def project_tool_points(self, points_tool: np.ndarray) -> np.ndarray:
        """Project (N, 3) tool-frame points (m) to (N, 2) pixels (u right, v down): the
        one projection of the twin (the nominal camera sits camera_to_apex behind the apex;
        a calibrated one where its offset and rotation put it, through its distortion,
        as cv2.projectPoints with (k1, k2, p1, p2))."""
        k = self.intrinsics
        if self.is_pinhole:
            z = points_tool[:, 2] + self.geometry.camera_to_apex
            return np.column_stack(
                [k[0, 0] * points_tool[:, 0] / z + k[0, 2], k[1, 1] * points_tool[:, 1] / z + k[1, 2]]
            )
        rot, t = self._tool2camera
        p = points_tool @ rot.T + t
        x, y = p[:, 0] / p[:, 2], p[:, 1] / p[:, 2]
        k1, k2, p1, p2 = self.distortion
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + k2 * r2)
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        return np.column_stack([k[0, 0] * xd + k[0, 2], k[1, 1] * yd + k[1, 2]])

    def nominal(self) -> CameraModel:
        """This camera's resolution and field of view without calibration (the GL camera
        the renderer draws with)."""
        return CameraModel(self.width, self.height, self.fov_y_deg, self.aperture_fraction, self.geometry)

    def in_nominal_camera(self, points_tool: np.ndarray) -> np.ndarray:
        """(N, 3) tool-frame points (m) in the nominal camera's frame (m): the tool frame
        moved camera_to_apex along the axis, so the camera sits at the origin looking down +z
        (x right, y down): the frame the inside-camera renderers draw in."""
        return np.asarray(points_tool, float) + np.array([0.0, 0.0, self.geometry.camera_to_apex])

    def place_at_pixels(self, points_tool: np.ndarray, pixels: np.ndarray) -> np.ndarray:
        """(N, 3) tool-frame points (m) moved within their depth plane so that this
        camera's *nominal pinhole* sees them at `pixels` (N, 2): how the renderer shows
        pins where a calibrated camera sees them (twin.runs.sim_env)."""
        nominal = self.nominal().intrinsics
        z = points_tool[:, 2] + self.geometry.camera_to_apex
        x = (pixels[:, 0] - nominal[0, 2]) * z / nominal[0, 0]
        y = (pixels[:, 1] - nominal[1, 2]) * z / nominal[1, 1]
        return np.column_stack([x, y, points_tool[:, 2]])

    def rescale_px(self, pins_px: np.ndarray, from_width: int, from_height: int | None = None) -> np.ndarray:
        """Pixel coordinates measured at another resolution of this camera (same field of
        view across the short side), `from_width` × `from_height` px, moved to this one.
        The same shape (or no height given): u' = (u + 0.5)·r − 0.5 with r = width /
        from_width (pixel centres at integer coordinates). Another shape (a portrait frame
        against a landscape one): scaled by the ratio of the short sides about the frame
        centres ((W − 1)/2, (H − 1)/2), where the optical axis is."""
        pins = np.asarray(pins_px, float)
        if from_height is None or int(from_height) * self.width == int(from_width) * self.height:
            return (pins + 0.5) * (self.width / float(from_width)) - 0.5
        r = self.short_side_px / float(min(from_width, from_height))
        centre_from = np.array([(from_width - 1) / 2, (from_height - 1) / 2])
        return (pins - centre_from) * r + np.array([(self.width - 1) / 2, (self.height - 1) / 2])

    @property
    def aperture_radius_px(self) -> float:
        """Radius of the circular aperture of the camera mount (px), centred in the frame."""
        return self.aperture_fraction * self.short_side_px / 2

    def pin_radius_px(self, depth_m: float) -> float:
        """Apparent radius (px) of a pin tip at a depth `depth_m` from the camera."""
        return self.focal_px * self.geometry.pin_radius / depth_m
