"""The seam between a scene and its dome model: what every dome model provides.

A dome model is a subpackage of twin.world.dome (``flex/``, ``compliant/``) exporting a
`DomeBuilder`; twin.world.dome.registry maps the scenario's `dome:` name to it. A
scene asks the builder for the model's parameters (its fidelity level with the
scenario's `physics` settings and a calibration's dome material applied), lets it add
its bodies to the MuJoCo spec, and starts the running dome, a `DomeModel`: it moves
the sensor, settles, and reports `Frame`s. Nothing outside twin.world.dome knows
which model runs.

Shared by the models: `Frame`, `physics_error` (the PhysicsError every model raises),
the stimulus carrier (twin.world.dome.carrier) and the calibrated material's names
(twin.world.dome.material).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import mujoco
import numpy as np

from twin.core.errors import PhysicsError
from twin.core.poses import Pose
from twin.core.sensor import CameraModel
from twin.core.validation import StrictModel


@dataclass(frozen=True)
class Frame:
    """One settled sensor reading.

    pins_tool: (127, 3) pin tip positions in the tool frame (m), pin order of twin.core.sensor.
    time: simulation time (s) when the frame settled.
    contact_force: magnitude of the total contact force on the dome (N).
    contact_force_tool: (3,) total contact force on the dome in the tool frame (N).
    n_steps: physics steps since the previous frame (move + settle).
    settled: True if the settling criterion was met (always True: otherwise settle raises).
    tool2world: 4×4 pose of the tool frame at this frame (m).
    settle_steps: steps spent in `settle` for this frame (part of n_steps).
    last_motion_px: the settling band met: largest pin motion (px, u or v) over the last
      `settle_steps` steps, in the physics' camera model.
    """

    pins_tool: np.ndarray
    time: float
    contact_force: float
    contact_force_tool: np.ndarray
    n_steps: int
    settled: bool
    tool2world: np.ndarray
    settle_steps: int = 0
    last_motion_px: float = 0.0


def physics_error(
    scenario_name: str, where: str, time_s: float, world2work: np.ndarray, tool2world: np.ndarray, what: str
) -> PhysicsError:
    """The PhysicsError of a dome model: scenario, `where` ("step 12"), simulated time (s),
    the commanded pose in the lab convention (work frame, mm/deg) and what failed."""
    lab = Pose.from_matrix(world2work @ tool2world)
    return PhysicsError(f"[{scenario_name}] {where} (t = {time_s:.4f} s) at pose {lab}: {what}")


class DomeParameters(Protocol):
    """A dome model's parameters: a frozen dataclass in SI units (its fidelity levels are
    instances). `max_poisson`: the largest Poisson's ratio (–) the model can take."""

    max_poisson: ClassVar[float]

    def with_(self, **changes: Any) -> DomeParameters: ...


class PhysicsSettings(StrictModel):
    """Base of a dome model's scenario `physics` block (pydantic; each field with its unit
    and bounds): overrides of the fidelity level's parameters, for sweeps."""

    def changes(self) -> dict[str, Any]:
        """The settings given, as the model's parameter fields in SI units."""
        raise NotImplementedError


class SceneHandles(Protocol):
    """What a model added to a MuJoCo spec, by name; `resolve` gives its ids in the compiled model."""

    def resolve(self, model: mujoco.MjModel) -> Any: ...


class DomeModel(Protocol):
    """A running dome: what a scene steps. Poses are lab poses (tool2world, 4×4, m).

    rest_pins: (127, 3) m, the undeformed pin tips, tool frame.
    steps: physics steps (flex) or contact increments (compliant) taken so far.
    step_seconds: wall time spent stepping (s), for benchmarks.
    """

    rest_pins: np.ndarray
    step_seconds: float

    @property
    def steps(self) -> int: ...

    def move(self, target_tool2world: np.ndarray, speed_mm_s: float) -> int:
        """Move the sensor along a straight line at `speed_mm_s` (mm/s); returns the steps taken."""
        ...

    def settle(self) -> Frame:
        """The settled frame at the commanded pose (PhysicsError if it does not settle)."""
        ...

    def converged_pins(self, settle_px: float | None = None, max_steps: int = 400) -> np.ndarray:
        """(127, 3) m, tool frame: the pins of the equilibrium the current frame settles
        towards; the simulation goes on as if this had not been called."""
        ...


class DomeBuilder(Protocol):
    """One dome model as the registry holds it.

    name: the scenario's `dome:` value. parameters: its DomeParameters class. levels: its
    fidelity levels (scenario `fidelity`: fast, default, reference). settings: its
    scenario `physics` schema. presets: named `physics` settings worth measuring (the
    sweep's and the benchmark's variants). quasi_static: every increment ends in
    equilibrium (no time step, nothing to settle).
    """

    name: str
    parameters: type
    levels: Mapping[str, DomeParameters]
    settings: type[PhysicsSettings]
    presets: Mapping[str, Mapping[str, Any]]
    quasi_static: bool

    def params(
        self, fidelity: str, settings: PhysicsSettings, material: Mapping[str, float], source: str
    ) -> DomeParameters:
        """The `fidelity` level with `settings` and a calibration's dome `material` (units of
        twin.core.calibration.DOME_MATERIAL) applied; UserError naming `source` for a
        combination the model cannot take."""
        ...

    def add_to_scene(self, spec: mujoco.MjSpec, params: DomeParameters, friction: bool) -> SceneHandles | None:
        """Add the model's bodies to the physics scene (tool frame: the sensor at the
        origin); `friction`: frictional contacts. None when the model adds none."""
        ...

    def start(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        handles: Any,
        params: DomeParameters,
        *,
        friction: float,
        name: str,
        start_tool2world: np.ndarray,
        stimulus2world: np.ndarray,
        work2world: np.ndarray,
        camera: CameraModel,
    ) -> DomeModel:
        """The running dome in the compiled scene, at `start_tool2world` (out of contact).
        handles: `add_to_scene`'s, resolved. friction: the skin–object Coulomb coefficient
        (0 = no friction). name: named in every PhysicsError. camera: the camera whose
        pixels settling is measured in."""
        ...

    def precompute(self, params: DomeParameters) -> tuple[float, float]:
        """The one-off work before the model's first contact, done now: (s computing and
        storing it, s loading it once stored); (0, 0) for a model that has none."""
        ...

    def resolution(self, params: DomeParameters) -> dict[str, Any]:
        """How finely `params` resolve the dome, for the sweep's table: cellcount (a label),
        timestep_s (s, None when quasi-static), settle_px (px, None when nothing settles)."""
        ...
