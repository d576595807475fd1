"""Scenario files: everything about one run (object, placement, sensor, protocol,
fidelity, effects), validated with pydantic. Errors name the file, field and value."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from twin.core.calibration import Calibration, load_calibration
from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.resources import scenario_path
from twin.core.sensor import CameraModel
from twin.core.validation import (
    PoseList,
    RunName,
    StrictModel,
    bounded,
    bounded_list,
    no_link_out,
    read_yaml,
    validate_mapping,
)

EFFECTS = ("contact", "friction", "arm_dynamics", "render", "camera_noise", "lighting")
#: Approach choreography shared by every protocol (work frame, docs/conventions.md):
#: an episode starts at START_POSE, out of contact; the sensor approaches and leaves a
#: surface by hovering at HOVER_Z_MM (5 mm above the object's top), at DEFAULT_SPEED_MM_S.
START_POSE = Pose(0.0, 0.0, -10.0, 0.0, 0.0, 0.0)
HOVER_Z_MM = -5.0
DEFAULT_SPEED_MM_S = 20.0


def hover_over(x_mm: float, y_mm: float, gamma_deg: float) -> Pose:
    """The no-contact pose above (x, y) with the sensor pointing down at orientation γ."""
    return Pose(x_mm, y_mm, HOVER_Z_MM, 0.0, 0.0, gamma_deg)


BUILTIN_OBJECTS = ("rectangle", "large_circle", "small_circle", "flower", "spiral", "tape_measure")


class ObjectSpec(StrictModel):
    """The stimulus: a built-in name, a user STL, or a user outline CSV extruded."""

    name: str | None = None
    stl: str | None = None
    outline: str | None = None
    thickness_mm: float | None = bounded(0, 200, "mm", "outline extrusion height", None, open_lo=True)
    material: str | None = None
    friction: float | None = bounded(0, 3, "dimensionless", "sliding friction coefficient", None)
    edge_radius_mm: float = bounded(0, 10, "mm", "radius of the top edge all round (0: sharp)", 0.0)

    @model_validator(mode="after")
    def _one_source(self) -> ObjectSpec:
        given = [k for k in ("name", "stl", "outline") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one of name, stl, outline (got {given or 'none'})")
        if self.name is not None and self.name not in BUILTIN_OBJECTS:
            raise ValueError(f"unknown object {self.name!r}; built-ins are {', '.join(BUILTIN_OBJECTS)}")
        if self.outline is not None and self.thickness_mm is None:
            raise ValueError("an outline needs thickness_mm")
        return self


class Placement(StrictModel):
    """Where the object's reference point sits on the table (robot base frame)."""

    position_mm: bounded_list(-1000, 1000, "mm", length=2) = [400.0, 0.0]
    yaw_deg: float = bounded(-360, 360, "deg", "object yaw about the table normal", 0.0)


class CameraSpec(StrictModel):
    width: int = bounded(64, 4096, "px", "image width", 640)
    height: int = bounded(48, 4096, "px", "image height", 480)
    fov_y_deg: float = Field(
        default=56.0,
        gt=10,
        lt=150,
        description="field of view across the frame's short side, the vertical one of a landscape frame (deg; (10, 150))",
    )
    msaa: int = bounded(0, 16, "samples per px", "anti-aliasing", 0)
    noise_std: float = bounded(0, 50, "grey levels", "pixel noise sigma, with camera_noise", 2.0)
    renderer: Literal["auto", "gl", "silhouette"] = Field(
        default="auto",
        description="silhouette: the pins' exact silhouettes drawn without GL, for unlit frames without "
        "msaa (twin.world.silhouette); gl: MuJoCo's OpenGL renderer, every effect (twin.world.render); "
        "auto: silhouette unless the scenario asks for lighting or msaa",
    )


def calibrated_camera(camera: CameraSpec, calibration: Calibration | None) -> CameraModel:
    """`camera`'s resolution and field of view with the calibration's intrinsics,
    distortion and pose (the nominal camera without a calibration)."""
    nominal = CameraModel(width=camera.width, height=camera.height, fov_y_deg=camera.fov_y_deg)
    return nominal if calibration is None else calibration.camera_model(nominal)


class SensorSpec(StrictModel):
    camera: CameraSpec = CameraSpec()
    calibration: str | Calibration | None = Field(
        default=None, description="calibration file (twin.core.calibration; relative to the scenario) or inline mapping"
    )


class RenderProtocol(StrictModel):
    """Observe at a list of poses (no-contact frame by default)."""

    kind: Literal["render"] = "render"
    poses: Annotated[list[PoseList], Field(min_length=1, max_length=10_000)] = [[0.0, 0.0, HOVER_Z_MM, 0.0, 0.0, 0.0]]
    speed_mm_s: float = bounded(0, 250, "mm/s", "TCP speed", DEFAULT_SPEED_MM_S, open_lo=True)


class _EdgeProtocol(StrictModel):
    """Where the straight edge lies and how the sensor moves to it (every edge protocol)."""

    edge_point_mm: bounded_list(-500, 500, "mm", length=2) = [60.0, 0.0]
    edge_normal_deg: float = bounded(-360, 360, "deg", "edge's outward normal", 0.0)
    approach_mm: float = bounded(0, 50, "mm", "hover height above the surface", -HOVER_Z_MM, open_lo=True)
    speed_mm_s: float = bounded(0, 250, "mm/s", "TCP speed in contact", DEFAULT_SPEED_MM_S, open_lo=True)
    free_speed_mm_s: float = bounded(0, 250, "mm/s", "moves above the object, out of contact", 50.0, open_lo=True)


class _StraightEdgeProtocol(_EdgeProtocol):
    """Fields shared by the paper's two data sets on the rectangle's straight edge."""

    orientations_deg: bounded_list(-360, 360, "deg", max_length=360) = [float(a) for a in range(-160, 181, 20)]
    lateral_mm: bounded_list(-50, 50, "mm", max_length=100) = [9.9, 6, 4, 2, 0, -2, -4, -6]


class TapProtocol(_StraightEdgeProtocol):
    """The paper's tap training set (§III-A2)."""

    kind: Literal["taps"] = "taps"
    depths_mm: bounded_list(-50, 6, "mm", max_length=20) = [2.0, 4.0]


class SlideProtocol(_StraightEdgeProtocol):
    """The paper's multi-directional sliding set (§III-C)."""

    kind: Literal["slides"] = "slides"
    directions_deg: bounded_list(-360, 360, "deg", max_length=72) = [float(a) for a in range(0, 360, 45)]
    depth_mm: float = bounded(0, 6, "mm", "indentation while sliding", 3.0)


#: where a sheared-taps run records its no-contact frame (mm, + off the object): the paper's
#: lateral position off the object, where the perception model looks for no-contact frames
NO_CONTACT_LATERAL_MM = 9.9


class ShearedTap(StrictModel):
    """One sheared tap: where the frame is taken (lateral, along, θ, depth offset) and the
    in-contact slide and twist made just before it (twin.runs.protocols.sheared_tap_moves)."""

    lateral_mm: float = bounded(-50, 50, "mm", "lateral position l at the frame (+ off the object)")
    along_mm: float = bounded(-100, 100, "mm", "position along the edge at the frame (+ along the tangent t)", 0.0)
    theta_deg: float = bounded(-360, 360, "deg", "sensor orientation θ at the frame")
    depth_offset_mm: float = bounded(-5, 5, "mm", "depth at the frame minus the protocol's depth_mm (+ deeper)", 0.0)
    slide_along_mm: float = bounded(-20, 20, "mm", "in-contact slide before the frame, along the edge", 0.0)
    slide_lateral_mm: float = bounded(-20, 20, "mm", "in-contact slide before the frame, along the normal", 0.0)
    twist_deg: float = bounded(-45, 45, "deg", "in-contact turn before the frame", 0.0)


#: a sheared tap's in-contact motion before its frame (ShearedTap's fields, mm, mm, deg)
SHEARED_TAP_MOTION = ("slide_along_mm", "slide_lateral_mm", "twist_deg")


class ShearedTapProtocol(_EdgeProtocol):
    """Taps sheared before their frame, like the lab's edge sets (twin.runs.lab_recording):
    press at the slid-back pose, slide and twist in contact to the tap's pose, record.
    The taps are `given` in order, or `taps` drawn uniformly with `seed` from the ranges."""

    kind: Literal["sheared_taps"] = "sheared_taps"
    depth_mm: float = bounded(0, 6, "mm", "nominal indentation of the taps", 3.0)
    taps: int = bounded(1, 10_000, "frames", "how many taps to draw, a frame each (without `given`)", 100)
    seed: int = bounded(0, 2**32 - 1, "dimensionless", "seed of the taps' draw", 0)
    lateral_range_mm: bounded_list(-50, 50, "mm", length=2) = [-5.0, 5.0]
    angle_range_deg: bounded_list(-360, 360, "deg", length=2) = [-45.0, 45.0]
    depth_offset_mm: float = bounded(0, 5, "mm", "drawn depth offsets lie in ±this", 1.0)
    slide_mm: float = bounded(0, 20, "mm", "drawn slides lie in ±this along the edge and along the normal", 5.0)
    twist_deg: float = bounded(0, 45, "deg", "drawn twists lie in ±this", 5.0)
    rest_frame: bool = Field(
        default=True,
        description="record a no-contact frame first, hovering off the object "
        "at l = NO_CONTACT_LATERAL_MM (the perception model's reference)",
    )
    given: Annotated[list[ShearedTap], Field(max_length=10_000)] | None = Field(
        default=None,
        description="the taps in order (an imported lab recording's: twin run --taps-from RUN); none = draw `taps`",
    )

    def without_slides(self) -> ShearedTapProtocol:
        """The same taps at the same poses, without their in-contact slide and twist (drawn
        taps: the same draw, the slides and twists drawn from ±0)."""
        if self.given is None:
            return self.model_copy(update={"slide_mm": 0.0, "twist_deg": 0.0})
        still = dict.fromkeys(SHEARED_TAP_MOTION, 0.0)
        return self.model_copy(update={"given": [tap.model_copy(update=still) for tap in self.given]})

    @model_validator(mode="after")
    def _ranges_in_order(self) -> ShearedTapProtocol:
        for name in ("lateral_range_mm", "angle_range_deg"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"{name} = [{lo:g}, {hi:g}]: the first value is the lower bound")
        return self


class ContourProtocol(StrictModel):
    """Contour following with the paper's controller (§III-D)."""

    kind: Literal["contour"] = "contour"
    depth_mm: float = bounded(0, 6, "mm", "indentation", 3.0)
    step_mm: float = bounded(0, 20, "mm", "step along the edge", 3.0, open_lo=True)
    gain: float = bounded(0, 2, "dimensionless", "lateral correction gain K", 0.35)
    lateral_target_mm: float = bounded(-10, 10, "mm", "desired lateral position l_d", 0.0)
    max_steps: int = bounded(1, 100_000, "steps", "step budget", 400)
    model: str | None = None
    controller: str = "paper"
    orientation_deg: float = bounded(-360, 360, "deg", "sensor orientation γ at the start", 0.0)
    speed_mm_s: float = bounded(0, 250, "mm/s", "TCP speed", DEFAULT_SPEED_MM_S, open_lo=True)


Protocol = Annotated[
    RenderProtocol | TapProtocol | SlideProtocol | ShearedTapProtocol | ContourProtocol, Field(discriminator="kind")
]


#: the dome model a scenario without `dome:` runs (twin.world.dome.registry): the compliant
#: dome, fitted to a real TacTip (docs/dome/compliant.md)
DEFAULT_DOME = "compliant"


class Scenario(StrictModel):
    """One run. docs/scenarios.md shows a whole file; every field's unit and range is in
    its model's description here (ObjectSpec, SensorSpec, the protocols) and, for `physics`,
    in the dome model's settings (twin.world.dome.flex.FlexSettings,
    twin.world.dome.compliant.CompliantSettings)."""

    name: RunName
    description: str = ""
    backend: Literal["sim", "hardware"] = "sim"
    seed: int = bounded(0, 2**32 - 1, "dimensionless", "random seed", 0)
    object: ObjectSpec
    placement: Placement = Placement()
    work_frame: Literal["object"] | PoseList = "object"
    sensor: SensorSpec = SensorSpec()
    fidelity: Literal["fast", "default", "reference"] = "default"
    #: the dome model's name (twin.world.dome.registry: flex, MuJoCo's flex grid, or compliant,
    #: the compliant contact model)
    dome: str = DEFAULT_DOME
    #: overrides of the dome model's fidelity level, for sweeps: its own settings, units and
    #: bounds (the model's schema, twin.world.dome.<model>; checked by twin.runs.spec)
    physics: dict[str, Any] = {}
    effects: list[str] = ["contact", "friction", "render"]
    protocol: Protocol = RenderProtocol()
    hardware_config: str | None = None

    @field_validator("effects")
    @classmethod
    def _known_effects(cls, effects: list[str]) -> list[str]:
        for e in effects:
            if e not in EFFECTS:
                raise ValueError(f"unknown effect {e!r}; known effects are {', '.join(EFFECTS)}")
        if "friction" in effects and "contact" not in effects:
            raise ValueError("effect 'friction' needs 'contact'")
        if "camera_noise" in effects and "render" not in effects:
            raise ValueError("effect 'camera_noise' needs 'render'")
        return sorted(set(effects), key=EFFECTS.index)

    @model_validator(mode="after")
    def _renderer_draws_effects(self) -> Scenario:
        if self.sensor.camera.renderer == "silhouette" and self.needs_gl_renderer():
            raise ValueError(
                "sensor.camera.renderer 'silhouette' draws unlit frames without anti-aliasing: "
                "drop effect 'lighting' and set sensor.camera.msaa to 0, or use renderer 'gl'"
            )
        return self

    def has(self, effect: str) -> bool:
        return effect in self.effects

    def needs_gl_renderer(self) -> bool:
        """Whether the frames ask for what only the GL renderer draws: lighting or MSAA."""
        return self.has("lighting") or self.sensor.camera.msaa > 0

    @property
    def source_dir(self) -> Path:
        return Path(getattr(self, "_source", ".")).parent

    @property
    def source(self) -> str:
        return getattr(self, "_source", "<inline>")

    def resolve(self, relative: str) -> Path:
        """A path named in the scenario, relative to the scenario file; a symbolic link
        out of the folder that holds the link is refused (UserError naming the field's path)."""
        p = Path(relative).expanduser()
        return no_link_out(p if p.is_absolute() else (self.source_dir / p), self.source)

    def camera_model(self) -> CameraModel:
        """The sensor's camera model (resolution and field of view of `sensor.camera`, with
        the intrinsics, distortion and pose of `sensor.calibration` when it names one)."""
        return calibrated_camera(self.sensor.camera, self.calibration())

    def calibration(self) -> Calibration | None:
        """The sensor's calibration (`sensor.calibration`: a file relative to the scenario,
        or inline), None without one."""
        given = self.sensor.calibration
        if given is None or isinstance(given, Calibration):
            return given
        path = self.resolve(given)
        if not path.is_file():
            raise UserError(f"{self.source}: field 'sensor.calibration': no calibration file {str(path)!r}")
        return load_calibration(path)

    def with_changes(self, **changes) -> Scenario:
        """A copy with top-level fields replaced and re-validated (keeps the source path)."""
        data = self.model_dump()
        data.update(changes)
        return scenario_from_dict(data, self.source)


def scenario_from_dict(data: dict, source: str = "<inline>") -> Scenario:
    """Validate a scenario given as a dict; `source` names it in errors."""
    scenario = validate_mapping(Scenario, data, source, "scenario")
    object.__setattr__(scenario, "_source", source)
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file: a path, or the name of a shipped scenario
    (``contour_flower``; twin.core.resources.shipped_scenarios)."""
    given = Path(path)
    if not given.suffix and not given.exists() and given.name == str(path):
        given = scenario_path(str(path))
    return scenario_from_dict(read_yaml(given, "scenario"), str(given))
