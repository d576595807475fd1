"""How well a recording's no-contact frame fixes the camera's distance: the twin's rest pin
tips projected through the lab camera with its offset along the axis held at each z (mm
towards the apex from the twin's nominal 45 mm behind it) and the focal length, radial
distortion and roll fitted to the recorded rest pins; then how far a pin tip moving 1 mm
along the axis moves in the image through that camera (rings 3 and 5 of the layout).
usage: camera_distance.py IMPORTED_RUN FOCAL_PX CX CY K1 K2 RZ_DEG Z_MM [Z_MM...]
(the camera the recording was fitted with first, as the start)"""

import sys

import numpy as np
from scipy.optimize import least_squares

from twin.analysis.edge_imprint import pin_rings
from twin.core.sensor import CameraModel, TacTipGeometry
from twin.runs.record import load_run

rest = load_run(sys.argv[1]).rest_pins_px
focal, cx, cy, k1, k2, rz = map(float, sys.argv[2:8])
geometry = TacTipGeometry()
tips = geometry.pin_tip_points()
rings = pin_rings(rest)


def camera(p: np.ndarray, z_mm: float) -> CameraModel:
    return CameraModel(
        256,
        256,
        geometry=geometry,
        focal_override_px=p[0],
        principal_point_px=(cx, cy),
        distortion=(p[1], p[2], 0.0, 0.0),
        offset_mm=(0.0, 0.0, z_mm),
        rotation_deg=(0.0, 0.0, p[3]),
    )


start = np.array([focal, k1, k2, rz])
print("z mm | rest RMS px | focal px | k1 | k2 | 1 mm along the axis: ring 3 / ring 5, px")
for z in map(float, sys.argv[8:]):
    fit = least_squares(
        lambda p, z=z: (camera(p, z).project_tool_points(tips) - rest).ravel(), start, x_scale=[10, 0.05, 0.01, 1]
    )
    cam = camera(fit.x, z)
    rms = np.sqrt(np.mean(np.sum((cam.project_tool_points(tips) - rest) ** 2, axis=1)))
    moved = np.linalg.norm(cam.project_tool_points(tips - [0, 0, 1e-3]) - cam.project_tool_points(tips), axis=1)
    print(
        f"{z:5.1f} | {rms:.3f} | {fit.x[0]:.2f} | {fit.x[1]:+.4f} | {fit.x[2]:+.4f} | "
        f"{moved[rings == 3].mean():.2f} / {moved[rings == 5].mean():.2f}"
    )
