"""Scene assembly: a resolved scene (`SceneSpec`: values, resolved from a scenario once by
twin.runs.spec) in, compiled MuJoCo models out, with only what its effects need.

The **physics scene** is built in the tool frame (twin.world.dome.carrier.add_stimulus_carrier
says why): the TacTip sits still at the origin and the object rides a free "stimulus
carrier" that the dome model (twin.world.dome.base.DomeModel) moves along the commanded path. The **overview scene** is the lab as
a person sees it — table, IRB120, TacTip, object — for `twin render --view scene`; it is
only rendered, never stepped.

| effect        | what it builds                                                      |
|---------------|---------------------------------------------------------------------|
| contact       | the object's convex collision pieces (else the object has none)      |
| friction      | frictional dome contacts (else condim 1, no friction rows at all;    |
|               | the dome model gets friction coefficient 0)                          |
| render, camera_noise, lighting | nothing here: twin.world.render, twin.world.silhouette    |

World = robot base frame on the table top (docs/conventions.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import mujoco
import numpy as np

from twin.core.errors import UserError
from twin.core.poses import Pose, make_transform, matrix_to_quat_wxyz
from twin.core.sensor import CameraModel, TacTipGeometry
from twin.world.dome.base import DomeBuilder, DomeModel, DomeParameters
from twin.world.dome.carrier import add_stimulus_carrier
from twin.world.kinematics import IRB120_XML, Irb120Kinematics
from twin.world.stimuli import Stimulus

#: Flange (ABB tool0) to the undeformed dome apex along the flange's +z (m): the TacTip's
#: mounting adapter, camera housing and dome stacked (assets/tactip/README.md).
FLANGE_TO_APEX = 0.101
TOOL2FLANGE = make_transform(np.eye(3), np.array([0.0, 0.0, FLANGE_TO_APEX]))
TABLE_HALF_SIZE = (0.6, 0.5, 0.02)  # m
FLIP_X = np.diag([1.0, -1.0, -1.0])  # work frame = object frame turned 180° about x (z into the object)
SCREEN_HEIGHT_M, SCREEN_DISTANCE_M = 0.4, 0.3  # Overview's screen: height, distance beyond the object (m)
OBJECT_PRIORITY = 1  # object geoms win the friction mix against the skin (contact μ = the object's)


@dataclass(frozen=True)
class SceneSpec:
    """What the physics scene is built from: values resolved from a scenario once
    (twin.runs.spec.sim_spec).

    name: named in the model and in every PhysicsError. source: the scenario file, named
    in errors. stimulus: the object. object2world, work2world: 4×4 (m), its placement and
    the work frame. dome: the dome model's builder (twin.world.dome.registry), dome_params:
    its parameters. camera: the (calibrated) camera, whose pixels the dome settles in.
    contact, friction: the scenario's effects of those names.
    """

    name: str
    source: str
    stimulus: Stimulus
    object2world: np.ndarray
    work2world: np.ndarray
    dome: DomeBuilder
    dome_params: DomeParameters
    camera: CameraModel
    contact: bool
    friction: bool


@dataclass
class Scene:
    """The compiled physics scene and what the simulation needs to drive it.

    dome_handles: what the dome model added to the scene, resolved against `model`
    (twin.world.dome.flex's TacTipHandles); None where it adds no body."""

    spec: SceneSpec
    model: mujoco.MjModel
    data: mujoco.MjData
    dome_handles: object | None

    @property
    def stimulus(self) -> Stimulus:
        return self.spec.stimulus

    @property
    def dome_params(self) -> DomeParameters:
        return self.spec.dome_params

    @property
    def camera(self) -> CameraModel:
        return self.spec.camera

    @property
    def object2world(self) -> np.ndarray:
        return self.spec.object2world

    @property
    def work2world(self) -> np.ndarray:
        return self.spec.work2world


def object_and_work_frames(
    position_mm: tuple[float, float], yaw_deg: float, thickness_mm: float, work_pose: Pose | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(object2world, work2world) 4×4 (m): the object's reference point at `position_mm`
    (x, y) on the table, turned by `yaw_deg` about the table normal, its top
    `thickness_mm` above the table; the work frame is `work_pose` (world, mm/deg), or the
    object frame turned over (z into the object) when None."""
    px, py = np.asarray(position_mm, float) * 1e-3
    yaw = np.radians(yaw_deg)
    rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    object2world = make_transform(rz, np.array([px, py, thickness_mm * 1e-3]))
    if work_pose is None:
        work2world = make_transform(rz @ FLIP_X, object2world[:3, 3])
    else:
        work2world = work_pose.to_matrix()
    return object2world, work2world


@lru_cache(maxsize=1)
def kinematics() -> Irb120Kinematics:
    return Irb120Kinematics()


def _add_object(spec: mujoco.MjSpec, body: mujoco.MjsBody, stimulus: Stimulus, collide: bool, friction: bool) -> None:
    colour = {"acrylic": [0.75, 0.85, 0.95, 1.0], "abs": [0.95, 0.75, 0.1, 1.0]}.get(
        stimulus.material, [0.2, 0.45, 0.8, 1.0]
    )
    for g in stimulus.add_to_spec(spec, body, prefix="object"):
        g.rgba = colour
        g.priority = OBJECT_PRIORITY if friction else 0
        if not collide:
            g.contype = g.conaffinity = 0


def build_scene(spec: SceneSpec) -> Scene:
    """Compile the physics scene: the object on the stimulus carrier and the dome model's bodies."""
    model_spec = mujoco.MjSpec()
    model_spec.modelname = f"twin_{spec.name}"
    carrier = add_stimulus_carrier(model_spec)
    _add_object(model_spec, carrier, spec.stimulus, collide=spec.contact, friction=spec.friction)
    added = spec.dome.add_to_scene(model_spec, spec.dome_params, spec.friction)
    try:
        model = model_spec.compile()
    except ValueError as err:
        raise UserError(f"{spec.source}: the scene does not compile: {err}") from None
    data = mujoco.MjData(model)
    return Scene(spec, model, data, None if added is None else added.resolve(model))


def sensor_physics(scene: Scene, start_tool2world: np.ndarray) -> DomeModel:
    """The scene's dome model running, from `start_tool2world` (lab pose of the dome apex,
    4×4 m)."""
    spec = scene.spec
    return spec.dome.start(
        scene.model,
        scene.data,
        scene.dome_handles,
        spec.dome_params,
        friction=spec.stimulus.friction if spec.friction else 0.0,
        name=spec.name,
        start_tool2world=start_tool2world,
        stimulus2world=spec.object2world,
        work2world=spec.work2world,
        camera=spec.camera,
    )


def _add_tactip_visual(body: mujoco.MjsBody, geometry: TacTipGeometry) -> None:
    """The TacTip as seen from outside (body frame = flange): adapter, housing, dome."""
    apex = FLANGE_TO_APEX
    dome_centre = apex - geometry.dome_outer_radius
    base_top = dome_centre - geometry.base_length
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.9 * geometry.dome_outer_radius, base_top / 2],
        pos=[0, 0, base_top / 2],
        rgba=[0.1, 0.1, 0.1, 1],
        contype=0,
        conaffinity=0,
        mass=0,
    )
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[geometry.dome_outer_radius, geometry.base_length / 2],
        pos=[0, 0, base_top + geometry.base_length / 2],
        rgba=[0.15, 0.15, 0.15, 1],
        contype=0,
        conaffinity=0,
        mass=0,
    )
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[geometry.dome_outer_radius],
        pos=[0, 0, dome_centre],
        rgba=[0.05, 0.05, 0.05, 1],
        contype=0,
        conaffinity=0,
        mass=0,
    )


class Overview:
    """The lab for pictures: table, IRB120, TacTip and object, compiled once; `pose_sensor`
    re-poses the arm by inverse kinematics (no recompilation), so a sequence of poses
    costs one IK solve and one forward pass each."""

    def __init__(
        self, scene: SceneSpec, screen_px: tuple[int, int] | None = None, screen_azimuth_deg: float = 120.0
    ) -> None:
        """scene: the object, its placement and the work frame (twin.runs.spec.sim_spec).
        screen_px: (width, height) of an RGB texture shown on a screen standing beyond
        the object as seen from a free camera at `screen_azimuth_deg` (deg), facing it
        (`screen_texture`): where `twin view` shows the sensor's frame."""
        stimulus = scene.stimulus
        self.object2world, self.work2world = scene.object2world, scene.work2world
        spec = mujoco.MjSpec()
        spec.modelname = f"overview_{scene.name}"
        spec.visual.global_.offwidth, spec.visual.global_.offheight = 1280, 960
        spec.worldbody.add_light(pos=[0.3, -0.3, 1.5], dir=[-0.2, 0.2, -1], diffuse=[0.7, 0.7, 0.7])
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=list(TABLE_HALF_SIZE),
            pos=[0.35, 0, -TABLE_HALF_SIZE[2]],
            rgba=[0.55, 0.45, 0.35, 1],
            contype=0,
            conaffinity=0,
        )
        obj = spec.worldbody.add_body(
            name="object", pos=self.object2world[:3, 3], quat=matrix_to_quat_wxyz(self.object2world[:3, :3])
        )
        _add_object(spec, obj, stimulus, collide=False, friction=False)
        arm = mujoco.MjSpec.from_file(str(IRB120_XML))
        _add_tactip_visual(arm.body("flange"), TacTipGeometry())
        spec.worldbody.add_frame().attach_body(arm.body("base"), "arm_", "")
        if screen_px is not None:
            self._add_screen(spec, *screen_px, screen_azimuth_deg)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.screen_texture_id = self.model.texture("screen").id if screen_px is not None else None
        self._qpos = [self.model.jnt_qposadr[self.model.joint(f"arm_joint{i}").id] for i in range(1, 7)]
        self._q: np.ndarray | None = None

    def _add_screen(self, spec: mujoco.MjSpec, width: int, height: int, azimuth_deg: float) -> None:
        """A SCREEN_HEIGHT_M-high screen of aspect width:height, SCREEN_DISTANCE_M beyond
        and to the right of the object as seen by a free camera at `azimuth_deg`, facing it."""
        spec.add_texture(
            name="screen",
            type=mujoco.mjtTexture.mjTEXTURE_2D,
            width=width,
            height=height,
            nchannel=3,
            data=[0] * (width * height * 3),
        )
        material = spec.add_material(name="screen", emission=1.0, specular=0.0)
        material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "screen"
        a = np.radians(azimuth_deg)
        forward = np.array([np.cos(a), np.sin(a), 0.0])  # the camera's view direction, horizontal
        up = np.array([0.0, 0.0, 1.0])
        axes = np.column_stack([np.cross(forward, up), up, -forward])  # plane x (right), y (up), normal
        half_h = SCREEN_HEIGHT_M / 2
        centre = (
            self.object2world[:3, 3]
            + SCREEN_DISTANCE_M * (forward + axes[:, 0])  # beyond and to the right
            + np.array([0.0, 0.0, half_h + 0.05])
        )
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            size=[half_h * width / height, half_h, 0.01],
            pos=centre,
            quat=matrix_to_quat_wxyz(axes),
            material="screen",
            contype=0,
            conaffinity=0,
        )

    def screen_texture(self, image: np.ndarray) -> None:
        """Show an RGB image (height, width, 3) uint8 of the screen's size on the screen
        (the model's texture data; a viewer re-uploads it with update_texture)."""
        adr = self.model.tex_adr[self.screen_texture_id]
        self.model.tex_data[adr : adr + image.size] = np.ascontiguousarray(image).ravel()

    def pose_sensor(self, pose: Pose) -> None:
        """Put the sensor at `pose` (work frame, mm/deg); the IK starts from the last
        solution, so consecutive poses keep the same arm configuration."""
        tool2world = self.work2world @ pose.to_matrix()
        self._q = kinematics().inverse(tool2world, TOOL2FLANGE, q_seed=self._q)
        self.data.qpos[self._qpos] = self._q
        mujoco.mj_forward(self.model, self.data)


def build_overview(scene: SceneSpec, pose: Pose) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The overview scene (`Overview`) with the sensor at `pose` (work frame, mm/deg)."""
    overview = Overview(scene)
    overview.pose_sensor(pose)
    return overview.model, overview.data
