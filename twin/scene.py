"""Scene assembly: a scenario in, a compiled MuJoCo model out, with only what its
effects need (DESIGN §3).

| effect        | built into the scene                                              |
|---------------|-------------------------------------------------------------------|
| contact       | the object's convex collision pieces (else the object is visual)   |
| friction      | frictional (condim 3, elliptic) dome contacts (else condim 1)      |
| arm_dynamics  | the IRB120 with position actuators carrying the TacTip (else the   |
|               | TacTip rides a kinematic mount that follows the commanded pose)    |
| render, camera_noise, lighting | nothing here: see twin.render                    |

World = robot base frame on the table top (README "Conventions").
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from twin import gl  # noqa: F401
import mujoco

from twin.dome import FIDELITY_LEVELS, DomeParams, TacTipHandles, add_sensor_mount, add_tactip, configure_options
from twin.errors import UserError
from twin.kinematics import IRB120_XML, Irb120Kinematics
from twin.poses import Pose, make_transform
from twin.scenario import Scenario
from twin.stimuli import Stimulus, load_stimulus
from twin.tactip import CameraModel, TacTipGeometry

#: Flange (ABB tool0) to the undeformed dome apex along the flange's +z (m): the TacTip's
#: mounting adapter, camera housing and dome stacked (assets/tactip/README.md).
FLANGE_TO_APEX = 0.101
TOOL2FLANGE = make_transform(np.eye(3), np.array([0.0, 0.0, FLANGE_TO_APEX]))
TABLE_SIZE = (0.6, 0.5, 0.02)  # half sizes (m)
FLIP_X = np.diag([1.0, -1.0, -1.0])  # work frame: object frame turned 180° about x (z into the object)


@dataclass
class Scene:
    """A compiled scene and the handles the simulation needs."""

    scenario: Scenario
    model: mujoco.MjModel
    data: mujoco.MjData
    stimulus: Stimulus
    tactip: TacTipHandles
    dome_params: DomeParams
    camera: CameraModel
    object2world: np.ndarray
    work2world: np.ndarray
    arm_qpos_adr: np.ndarray | None  # qpos addresses of joint1..6 when arm_dynamics is on


def load_scenario_stimulus(scenario: Scenario) -> Stimulus:
    """The scenario's object (built-in, STL or outline, paths relative to the scenario)."""
    o = scenario.object
    kwargs = {}
    if o.material is not None:
        kwargs["material"] = o.material
    if o.friction is not None:
        kwargs["friction"] = o.friction
    if o.name is not None:
        return load_stimulus(o.name, **kwargs)
    path = scenario.resolve(o.stl or o.outline)
    return load_stimulus(path, thickness_mm=o.thickness_mm, **kwargs)


def object_and_work_frames(scenario: Scenario, stimulus: Stimulus) -> tuple[np.ndarray, np.ndarray]:
    """(object2world, work2world) 4×4 (m) for the scenario's placement."""
    px, py = np.asarray(scenario.placement.position_mm) * 1e-3
    yaw = np.radians(scenario.placement.yaw_deg)
    rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    object2world = make_transform(rz, np.array([px, py, stimulus.thickness_mm * 1e-3]))
    if scenario.work_frame == "object":
        work2world = make_transform(rz @ FLIP_X, object2world[:3, 3])
    else:
        work2world = Pose.from_array(scenario.work_frame).to_matrix()
    return object2world, work2world


def camera_model(scenario: Scenario) -> CameraModel:
    c = scenario.sensor.camera
    return CameraModel(width=c.width, height=c.height, fov_y_deg=c.fov_y_deg)


def _quat(rotation: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rotation).ravel())
    return q


@lru_cache(maxsize=1)
def kinematics() -> Irb120Kinematics:
    return Irb120Kinematics()


def _add_housing(body: mujoco.MjsBody, geometry: TacTipGeometry, tool_in_body: np.ndarray) -> None:
    """The TacTip's camera housing and mounting adapter between the dome's base and the
    flange: visual only (the simulated dome carries the physics)."""
    top = FLANGE_TO_APEX
    bottom = geometry.dome_outer_radius + geometry.base_length
    centre = tool_in_body @ np.array([0.0, 0.0, -(top + bottom) / 2, 1.0])
    body.add_geom(name="tactip_housing", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                  size=[0.9 * geometry.dome_outer_radius, (top - bottom) / 2], pos=centre[:3],
                  quat=_quat(tool_in_body[:3, :3]), rgba=[0.1, 0.1, 0.1, 1], contype=0, conaffinity=0, mass=0)


def build_spec(scenario: Scenario, stimulus: Stimulus | None = None, start_tool2world: np.ndarray | None = None,
               visual_arm: bool = False) -> tuple[mujoco.MjSpec, Stimulus, TacTipHandles, DomeParams, np.ndarray, np.ndarray]:
    """The scene's MjSpec (uncompiled). `visual_arm` adds the arm without collisions for
    overview images of scenes that simulate no arm dynamics."""
    stimulus = stimulus or load_scenario_stimulus(scenario)
    params = FIDELITY_LEVELS[scenario.fidelity]
    object2world, work2world = object_and_work_frames(scenario, stimulus)
    if start_tool2world is None:
        start_tool2world = work2world @ Pose(0, 0, -10, 0, 0, 0).to_matrix()

    spec = mujoco.MjSpec()
    spec.modelname = f"twin_{scenario.name}"
    spec.visual.global_.offwidth = 1280
    spec.visual.global_.offheight = 960
    spec.worldbody.add_light(pos=[0.3, -0.3, 1.5], dir=[-0.2, 0.2, -1], diffuse=[0.7, 0.7, 0.7])
    # The table top is z = 0; the dome never reaches it (objects are ≥ 5 mm thick and
    # presses ≤ 6 mm deep), so it carries no collision.
    spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(TABLE_SIZE),
                            pos=[0.35, 0, -TABLE_SIZE[2]], rgba=[0.55, 0.45, 0.35, 1], contype=0, conaffinity=0)

    obj = spec.worldbody.add_body(name="object", pos=object2world[:3, 3], quat=_quat(object2world[:3, :3]))
    colour = {"acrylic": [0.75, 0.85, 0.95, 1.0], "tape_measure": [0.9, 0.75, 0.1, 1.0]}.get(stimulus.material, [0.2, 0.45, 0.8, 1.0])
    geoms = stimulus.add_to_spec(spec, obj, prefix="object")
    for g in geoms:
        g.rgba = colour
        if not scenario.has("contact"):
            g.contype = g.conaffinity = 0

    geometry = TacTipGeometry()
    arm_on = scenario.has("arm_dynamics")
    if arm_on or visual_arm:
        arm = mujoco.MjSpec.from_file(str(IRB120_XML))
        configure_options(spec, params)
        arm.option.integrator = spec.option.integrator  # the dome's options win; avoid an attach conflict
        arm.option.timestep = spec.option.timestep
        if visual_arm and not arm_on:
            for g in arm.geoms:
                g.contype = g.conaffinity = 0
        frame = spec.worldbody.add_frame()
        frame.attach_body(arm.body("base"), "arm_", "")
    if arm_on:
        flange = spec.body("arm_flange")
        _add_housing(flange, geometry, TOOL2FLANGE)
        handles = add_tactip(spec, flange, geometry, params, friction=scenario.has("friction"),
                             tool_in_parent=TOOL2FLANGE)
    else:
        mount = add_sensor_mount(spec, tool2world=start_tool2world)
        _add_housing(mount, geometry, np.eye(4))
        handles = add_tactip(spec, mount, geometry, params, friction=scenario.has("friction"))
    return spec, stimulus, handles, params, object2world, work2world


def build_scene(scenario: Scenario, start_pose: Pose | None = None) -> Scene:
    """Compile the scenario's scene with the sensor at `start_pose` (work frame;
    default 10 mm above the object's reference point)."""
    stimulus = load_scenario_stimulus(scenario)
    _, work2world = object_and_work_frames(scenario, stimulus)
    start = work2world @ (start_pose or Pose(0, 0, -10, 0, 0, 0)).to_matrix()
    spec, stimulus, handles, params, object2world, work2world = build_spec(scenario, stimulus, start)
    try:
        model = spec.compile()
    except Exception as err:  # mujoco raises ValueError with the compiler's message
        raise UserError(f"{scenario.source}: the scene does not compile: {err}") from None
    data = mujoco.MjData(model)
    arm_adr = None
    if scenario.has("arm_dynamics"):
        arm_adr = np.array([model.jnt_qposadr[model.joint(f"arm_joint{i}").id] for i in range(1, 7)])
        q = kinematics().inverse(start, TOOL2FLANGE)
        data.qpos[arm_adr] = q
        data.ctrl[:6] = q
    mujoco.mj_forward(model, data)
    return Scene(scenario, model, data, stimulus, handles.resolve(model), params, camera_model(scenario),
                 object2world, work2world, arm_adr)
