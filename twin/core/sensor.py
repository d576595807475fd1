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

    dome_outer_radius: float = 0.020      # 40 mm dome (paper §III-A)
    skin_thickness: float = 0.0015        # rubber-like skin over the gel
    pin_length: float = 0.002             # pins protrude inwards from the skin
    pin_radius: float = 0.0006            # 1.2 mm pin tips
    pin_spacing: float = 0.0033           # arc length between neighbouring pins on the inner skin
    base_length: float = 0.018            # cylindrical part between the dome's equator and the camera mount
    camera_to_apex: float = 0.045         # camera optical centre to apex, along the axis

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
    """Pinhole camera inside the TacTip base (OpenCV model, no distortion).

    The camera frame is the tool frame shifted back by `geometry.camera_to_apex` along z:
    z forward (towards the tip), u right (+x), v down (+y). Intrinsics are scaled with the
    resolution so that the field of view stays the same.
    """

    width: int = 640
    height: int = 480
    fov_y_deg: float = 56.0       # vertical field of view (deg)
    aperture_fraction: float = 0.94  # circular aperture radius / half the frame height
    geometry: TacTipGeometry = field(default_factory=TacTipGeometry)

    @property
    def focal_px(self) -> float:
        return 0.5 * self.height / np.tan(np.radians(self.fov_y_deg) / 2)

    @cached_property
    def intrinsics(self) -> np.ndarray:
        """3×3 matrix K (px)."""
        f = self.focal_px
        # GL puts the optical axis on the frame centre, which is pixel (W−1)/2 in the
        # OpenCV convention (integer coordinates at pixel centres).
        return np.array([[f, 0.0, (self.width - 1) / 2], [0.0, f, (self.height - 1) / 2], [0.0, 0.0, 1.0]])

    def project_tool_points(self, points_tool: np.ndarray) -> np.ndarray:
        """Project (N, 3) tool-frame points (m) to (N, 2) pixels (u right, v down): the
        one pinhole projection of the twin (the camera sits camera_to_apex behind the apex)."""
        k = self.intrinsics
        z = points_tool[:, 2] + self.geometry.camera_to_apex
        return np.column_stack([k[0, 0] * points_tool[:, 0] / z + k[0, 2], k[1, 1] * points_tool[:, 1] / z + k[1, 2]])

    def rescale_px(self, pins_px: np.ndarray, from_width: int) -> np.ndarray:
        """Pixel coordinates measured at another resolution of this camera (same field of
        view), at `from_width` px wide, moved to this one: u' = (u + 0.5)·r − 0.5 with
        r = width / from_width (pixel centres at integer coordinates)."""
        return (np.asarray(pins_px, float) + 0.5) * (self.width / float(from_width)) - 0.5

    @property
    def aperture_radius_px(self) -> float:
        """Radius of the circular aperture of the camera mount (px), centred in the frame."""
        return self.aperture_fraction * self.height / 2

    def pin_radius_px(self, depth_m: float) -> float:
        """Apparent radius (px) of a pin tip at a depth `depth_m` from the camera."""
        return self.focal_px * self.geometry.pin_radius / depth_m
