"""Headless rendering: the TacTip's inside-camera frame and an overview of the scene.

The inside view is rendered from a small dedicated MuJoCo model (pins + dark skin seen
from the camera), fed with the pin tips computed by the physics. Rendering only what the
camera can see keeps the frame rate high and the image identical whichever physics
fidelity produced the pins. Scenes draw unlit frames without anti-aliasing with
twin.world.silhouette by default (scenario `sensor.camera.renderer`); this renderer
draws every frame that asks for it, lighting and MSAA included.
"""

from __future__ import annotations

from typing import Protocol

import mujoco
import numpy as np

from twin.core.sensor import N_PINS, CameraModel

# MuJoCo cameras look along −z with +y up; OpenCV cameras along +z with +y down.
_OPENCV_TO_MUJOCO_CAMERA_QUAT = "0 1 0 0"

#: Slices round a pin sphere in the default 640×480 frame, and the most any frame gets
_PIN_SLICES = 16

#: Grey levels of an unlit frame (no `lighting`): the pins, and the skin inside the aperture
#: as GL draws its material (rgba 0.08, emission 1: MuJoCo lights an emissive material at 1.3×
#: its colour, tests/world/test_silhouette.py); beyond the aperture the frame is black
PIN_GREY = 255
SKIN_GREY = 27


def add_camera_noise(frame: np.ndarray, noise_std: float, rng: np.random.Generator | None) -> np.ndarray:
    """`frame` (H, W, 3) uint8 with per-pixel Gaussian noise of `noise_std` grey levels, the
    same on the three channels, drawn from `rng` (required when noise_std > 0)."""
    if noise_std <= 0:
        return frame
    if rng is None:
        raise ValueError("camera noise needs a seeded numpy Generator")
    grey = rng.standard_normal(frame.shape[:2], dtype=np.float32) * np.float32(noise_std)
    return np.clip(frame + grey[..., None], 0, 255).astype(np.uint8)


class InsideRenderer(Protocol):
    """What twin.runs.sim_env asks of an inside-camera renderer: this module's PinRenderer
    (GL, every effect) or twin.world.silhouette.SilhouetteRenderer (unlit, no MSAA)."""

    def render(
        self, pins_tool: np.ndarray, noise_std: float = 0.0, rng: np.random.Generator | None = None
    ) -> np.ndarray:
        """Frame (H, W, 3) uint8 RGB for (127, 3) pin tips in the tool frame (m), with
        `noise_std` grey levels of camera noise drawn from `rng`."""
        ...

    def close(self) -> None:
        """Release what the renderer holds (a GL context), if anything."""
        ...


def _pin_apex_radius_px(camera: CameraModel) -> float:
    """Apparent radius (px) of the pin nearest the camera, the largest in the frame."""
    return camera.pin_radius_px(camera.geometry.camera_to_apex)


def pin_sphere_slices(camera: CameraModel) -> int:
    """Slices round each pin sphere (stacks are half as many): as few as keep a pin's
    outline within the distance (px) it strays from a true circle in the default
    640×480 frame, at most 16. The spheres' triangles are most of a frame's render time
    whatever its size, so small frames get coarser spheres; 640×480 and larger frames
    keep 16 and so are unchanged."""
    radius_px = _pin_apex_radius_px(camera)
    reference_px = _pin_apex_radius_px(CameraModel())
    max_stray_px = reference_px * (1 - np.cos(np.pi / _PIN_SLICES)) * (1 + 1e-9)
    for slices in range(6, _PIN_SLICES, 2):
        if radius_px * (1 - np.cos(np.pi / slices)) <= max_stray_px:
            return slices
    return _PIN_SLICES


def _pin_scene_xml(camera: CameraModel, lighting: bool, msaa: int) -> str:
    g = camera.geometry
    # Dark skin: a disc just beyond the apex whose image fills the circular aperture.
    skin_depth = g.camera_to_apex + 0.002
    skin_radius = camera.aperture_radius_px / camera.focal_px * skin_depth
    if lighting:
        # LED ring next to the camera: diffuse shading and fall-off with distance.
        pin_material = '<material name="pin" rgba="0.95 0.95 0.92 1" specular="0.3" shininess="0.5" emission="0.35"/>'
        lights = '<light pos="0 0 0" dir="0 0 1" directional="false" diffuse="0.9 0.9 0.85" attenuation="1 8 0" castshadow="false"/>'
        skin_rgba = "0.10 0.10 0.11 1"
    else:
        pin_material = '<material name="pin" rgba="1 1 1 1" emission="1" specular="0"/>'
        lights = ""
        skin_rgba = "0.08 0.08 0.08 1"
    # The skin is a many-sided thin prism (a round aperture) so the spheres can use few slices.
    n = 192
    angles = np.arange(n) * 2 * np.pi / n
    ring = np.column_stack([skin_radius * np.cos(angles), skin_radius * np.sin(angles)])
    disc = np.vstack([np.column_stack([ring, np.zeros(n)]), np.column_stack([ring, np.full(n, 1e-4)])])
    disc_vertices = " ".join(f"{v:.7g}" for v in disc.ravel())
    pins = "\n".join(
        f'<body name="pin{i}" mocap="true"><geom type="sphere" size="{g.pin_radius}" material="pin"/></body>'
        for i in range(N_PINS)
    )
    slices = pin_sphere_slices(camera)
    return f"""
<mujoco model="tactip_inside_view">
  <visual>
    <global offwidth="{camera.width}" offheight="{camera.height}" fovy="{camera.vertical_fov_deg}"/>
    <quality offsamples="{msaa}" numslices="{slices}" numstacks="{slices // 2}"/>
    <headlight active="0" ambient="0 0 0" diffuse="0 0 0" specular="0 0 0"/>
  </visual>
  <default><geom contype="0" conaffinity="0"/></default>
  <asset>
    {pin_material}
    <material name="skin" rgba="{skin_rgba}" emission="1" specular="0"/>
    <mesh name="skin" vertex="{disc_vertices}"/>
  </asset>
  <worldbody>
    {lights}
    <camera name="inside" pos="0 0 0" quat="{_OPENCV_TO_MUJOCO_CAMERA_QUAT}" fovy="{camera.vertical_fov_deg}"/>
    <geom name="skin" type="mesh" mesh="skin" pos="0 0 {skin_depth}" material="skin"/>
    {pins}
  </worldbody>
</mujoco>"""


class PinRenderer:
    """Renders the inside-camera frame (H, W, 3) uint8 RGB from pin tips in the tool frame.

    `lighting` models the LED ring (shaded pins, fall-off); without it pins are flat white
    discs. `noise_std` (grey levels) adds per-pixel Gaussian camera noise drawn from the
    generator passed to `render`.
    """

    def __init__(self, camera: CameraModel, lighting: bool = False, msaa: int = 0) -> None:
        self.camera = camera
        self.model = mujoco.MjModel.from_xml_string(_pin_scene_xml(camera, lighting, msaa))
        self.data = mujoco.MjData(self.model)
        self._renderer = mujoco.Renderer(self.model, camera.height, camera.width)
        self._camera_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, "inside")

    def render(
        self,
        pins_tool: np.ndarray,
        noise_std: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> np.ndarray:
        """Frame for (127, 3) pin tips in the tool frame (m)."""
        self.data.mocap_pos[:] = self.camera.in_nominal_camera(pins_tool)
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)  # the camera pose is computed here, not in mj_kinematics
        self._renderer.update_scene(self.data, self._camera_id)
        return add_camera_noise(self._renderer.render(), noise_std, rng)

    def close(self) -> None:
        self._renderer.close()


class OverviewRenderer:
    """Renders a whole scene from a free camera (RGB uint8, height × width px), keeping
    one GL context for every frame: for sequences of the same scene (videos, the viewer)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int = 960,
        height: int = 720,
        lookat: np.ndarray | None = None,
        distance: float = 1.2,
        azimuth: float = 135.0,
        elevation: float = -25.0,
        shadows: bool = True,
    ) -> None:
        """lookat (m, world), distance (m), azimuth and elevation (deg): the free camera.
        shadows: off saves most of a frame's time on a software (llvmpipe) renderer."""
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self.camera = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, self.camera)
        if lookat is not None:
            self.camera.lookat[:] = lookat
        self.camera.distance, self.camera.azimuth, self.camera.elevation = distance, azimuth, elevation
        self._renderer = mujoco.Renderer(model, height, width)
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows

    def render(self, data: mujoco.MjData) -> np.ndarray:
        self._renderer.update_scene(data, self.camera)
        return self._renderer.render()

    def close(self) -> None:
        self._renderer.close()

    def __enter__(self) -> OverviewRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def render_overview(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    width: int = 960,
    height: int = 720,
    lookat: np.ndarray | None = None,
    distance: float = 1.2,
    azimuth: float = 135.0,
    elevation: float = -25.0,
) -> np.ndarray:
    """One overview image of a whole scene from a free camera (RGB uint8)."""
    with OverviewRenderer(model, width, height, lookat, distance, azimuth, elevation) as renderer:
        return renderer.render(data)
