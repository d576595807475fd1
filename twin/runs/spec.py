"""A scenario resolved once into what the simulation runs on: `SimSpec`, plain immutable
values (the object, its placement and the work frame, the dome model and its parameters,
the calibrated camera, the effects, the calibration's offsets), so that twin.world and
twin.control take values, not the scenario, and the calibration file is read once.

The scenario's `physics` block is checked here against its dome model's own schema
(twin.world.dome.registry: the model named by `dome:` owns its settings, units and
bounds); errors name the file and `physics.<field>` (UserError, exit 2).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from twin.core.calibration import Calibration
from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.scenario import ObjectSpec, Scenario, calibrated_camera
from twin.core.scenario import load_scenario as load_scenario_file
from twin.world.dome.base import DomeBuilder, DomeParameters, PhysicsSettings
from twin.world.dome.registry import DOME_MODELS
from twin.world.scene import SceneSpec, object_and_work_frames
from twin.world.stimuli import Stimulus, load_stimulus
from twin.world.stimuli.objects import MATERIALS, with_edge_radius


@dataclass(frozen=True)
class SimSpec:
    """Everything a simulated environment is built from, resolved from one scenario.

    scene: the physics scene's values (twin.world.scene.SceneSpec: object, frames, dome
    model and parameters, camera, contact and friction). effects: the scenario's effects.
    seed: its seed. renderer (gl or silhouette, `auto` resolved by `inside_renderer`), msaa
    (samples per px), noise_std (grey levels; 0 without camera_noise): the renderer's.
    rest_offsets_px: (127, 2) px the sensor's rest layout differs from the lattice
    (calibration), None without one. tcp2apex: 4×4 (m), the dome apex relative to the
    commanded TCP (calibration's tcp_offset_mm and tcp_roll_deg). arm_yield: (3,) m/N, work frame, how far
    the TCP yields per newton of contact normal force (calibration's arm_yield_mm_per_n;
    zeros: a rigid arm).
    """

    scene: SceneSpec
    effects: tuple[str, ...]
    seed: int
    renderer: str
    msaa: int
    noise_std: float
    rest_offsets_px: np.ndarray | None
    tcp2apex: np.ndarray
    arm_yield: np.ndarray

    def has(self, effect: str) -> bool:
        return effect in self.effects


def _read_only(array: np.ndarray | None) -> np.ndarray | None:
    """A copy of `array` that cannot be written to (a spec's arrays are values too)."""
    if array is None:
        return None
    frozen = np.array(array, dtype=float)
    frozen.flags.writeable = False
    return frozen


def _builder(name: str, source: str) -> DomeBuilder:
    """The builder of the dome model `name`; UserError naming `source` and `dome` otherwise."""
    builder = DOME_MODELS.get(name)
    if builder is None:
        raise UserError(f"{source}: field 'dome': no dome model {name!r} (known: {', '.join(DOME_MODELS)})")
    return builder


def _settings(builder: DomeBuilder, physics: Mapping[str, Any], source: str) -> PhysicsSettings:
    """`physics` validated against the model's schema; UserError naming `source` and each
    `physics.<field>` otherwise."""
    try:
        return builder.settings.model_validate(dict(physics))
    except ValidationError as err:
        lines = []
        for e in err.errors():
            field = ".".join(str(p) for p in ("physics", *e["loc"]))
            shown = repr(e.get("input"))
            shown = shown if len(shown) <= 80 else shown[:77] + "…"
            why = f"not a setting of the {builder.name} dome" if e["type"] == "extra_forbidden" else e["msg"]
            lines.append(f"field '{field}' = {shown}: {why}")
        if any(e["type"] == "extra_forbidden" for e in err.errors()):
            lines.append(f"(dome: {builder.name} has {', '.join(builder.settings.model_fields)})")
        raise UserError(f"{source}: " + "; ".join(lines)) from None


def _params(
    builder: DomeBuilder, fidelity: str, physics: Mapping[str, Any], calibration: Calibration | None, source: str
) -> DomeParameters:
    material = {} if calibration is None else calibration.dome_material
    return builder.params(fidelity, _settings(builder, physics, source), material, source)


def _stimulus(o: ObjectSpec, path: Path | None, calibration: Calibration | None, source: str) -> Stimulus:
    """The object `o` (`path`: its STL or outline file, resolved), with the calibration's
    friction; `source` names the scenario in errors."""
    kwargs = {}
    if o.material is not None and o.material not in MATERIALS:
        raise UserError(
            f"{source}: field 'object.material' = {o.material!r}: not a known material ({', '.join(sorted(MATERIALS))})"
        )
    if o.material is not None:
        kwargs["material"] = o.material
    if o.friction is not None:
        kwargs["friction"] = o.friction
    if calibration is not None and calibration.friction is not None:
        kwargs["friction"] = calibration.friction  # the sensor's fitted skin–stimulus friction
    stimulus = (
        load_stimulus(o.name, **kwargs)
        if o.name is not None
        else load_stimulus(path, thickness_mm=o.thickness_mm, **kwargs)
    )
    try:
        return with_edge_radius(stimulus, o.edge_radius_mm)
    except UserError as exc:
        raise UserError(f"{source}: field 'object.edge_radius_mm': {exc}") from None


def _object_file(scenario: Scenario) -> Path | None:
    o = scenario.object
    return None if o.name is not None else scenario.resolve(o.stl or o.outline)


def dome_builder(scenario: Scenario) -> DomeBuilder:
    """The builder of the scenario's dome model; UserError naming the file and `dome` otherwise."""
    return _builder(scenario.dome, scenario.source)


def dome_settings(scenario: Scenario) -> PhysicsSettings:
    """The scenario's `physics` validated against its dome model's schema; UserError naming
    the file and each `physics.<field>` otherwise."""
    return _settings(dome_builder(scenario), scenario.physics, scenario.source)


def dome_params(scenario: Scenario) -> DomeParameters:
    """The scenario's dome model at its fidelity level with its `physics` settings and its
    calibration's dome material applied."""
    return _params(dome_builder(scenario), scenario.fidelity, scenario.physics, scenario.calibration(), scenario.source)


def check_scenario(scenario: Scenario) -> Scenario:
    """`scenario` once its dome model takes its `physics` settings and its calibration's
    dome material (UserError otherwise)."""
    dome_params(scenario)
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """twin.core.scenario.load_scenario, with the dome model and its `physics` checked."""
    return check_scenario(load_scenario_file(path))


def load_scenario_stimulus(scenario: Scenario) -> Stimulus:
    """The scenario's object (built-in, STL or outline, paths relative to the scenario),
    with the calibration's skin–stimulus friction where it has one."""
    return _stimulus(scenario.object, _object_file(scenario), scenario.calibration(), scenario.source)


def scene_spec(scenario: Scenario, calibration: Calibration | None = None) -> SceneSpec:
    """The physics scene's values for `scenario`; `calibration`: the scenario's (read here
    when not given)."""
    calibration = scenario.calibration() if calibration is None else calibration
    stimulus = _stimulus(scenario.object, _object_file(scenario), calibration, scenario.source)
    work_pose = None if scenario.work_frame == "object" else Pose.from_array(scenario.work_frame)
    object2world, work2world = object_and_work_frames(
        scenario.placement.position_mm, scenario.placement.yaw_deg, stimulus.thickness_mm, work_pose
    )
    builder = _builder(scenario.dome, scenario.source)
    return SceneSpec(
        name=scenario.name,
        source=scenario.source,
        stimulus=stimulus,
        object2world=_read_only(object2world),
        work2world=_read_only(work2world),
        dome=builder,
        dome_params=_params(builder, scenario.fidelity, scenario.physics, calibration, scenario.source),
        camera=calibrated_camera(scenario.sensor.camera, calibration),
        contact=scenario.has("contact"),
        friction=scenario.has("friction"),
    )


def inside_renderer(scenario: Scenario) -> str:
    """The inside camera's renderer: `sensor.camera.renderer`, with `auto` resolved to the
    silhouette renderer (twin.world.silhouette) for unlit frames without anti-aliasing and
    to GL (twin.world.render) when the scenario asks for lighting or MSAA."""
    renderer = scenario.sensor.camera.renderer
    if renderer != "auto":
        return renderer
    return "gl" if scenario.needs_gl_renderer() else "silhouette"


def sim_spec(scenario: Scenario) -> SimSpec:
    """`scenario` resolved for the simulator, its calibration read once."""
    calibration = scenario.calibration()
    scene = scene_spec(scenario, calibration)
    camera = scenario.sensor.camera
    return SimSpec(
        scene=scene,
        effects=tuple(scenario.effects),
        seed=scenario.seed,
        renderer=inside_renderer(scenario),
        msaa=camera.msaa,
        noise_std=camera.noise_std if scenario.has("camera_noise") else 0.0,
        rest_offsets_px=_read_only(None if calibration is None else calibration.rest_offsets_px(scene.camera.width)),
        tcp2apex=_read_only(np.eye(4) if calibration is None else calibration.tcp2apex),
        arm_yield=_read_only(np.zeros(3) if calibration is None else calibration.arm_yield_m_per_n),
    )
