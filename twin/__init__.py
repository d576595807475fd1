"""TacTip digital twin: the public API (docs/scripting.md).

    import twin
    scenario = twin.load_scenario("contour_small_circle")   # a shipped scenario, or a path
    with twin.make_environment(scenario, seed=0) as env:    # sim, or the real rig (backend)
        reader = twin.PinReader(env.reset())                # pins from frames or projections
        pins = reader.read(env.step(twin.Pose(0, -30, 3))).pins_px

Everything else lives in the layers below: twin.core (conventions, scenario, interfaces),
twin.world (the simulated rig), twin.sensing, twin.control, twin.runs, twin.tools.

Importing twin (or any module below it) loads none of them: each public name imports its
module the first time it is read (PEP 562), so `import hardware.safety` or
`twin.core.poses` stays free of the simulator. Reading `GYM_ID` registers the Gymnasium
environment. The one thing done here is arranging for the headless GL backend to be
selected (twin.world.gl) just before anything first imports mujoco or PyOpenGL.
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from twin.control.contour import ContourStep
    from twin.control.controllers import Controller, PaperController, Percept
    from twin.core.environment import Environment, Observation
    from twin.core.errors import PhysicsError, TwinError, UserError
    from twin.core.poses import Pose
    from twin.core.scenario import Scenario, load_scenario, scenario_from_dict
    from twin.runs.backends import make_environment
    from twin.runs.contour_run import ScenarioFollower as ContourFollower
    from twin.runs.gym_env import ContourFollowingEnv
    from twin.runs.gym_registration import GYM_ID
    from twin.runs.run import run_scenario
    from twin.runs.training import model_for_scenario as tap_model
    from twin.sensing.perception import PerceptionModel
    from twin.sensing.pins import PinReader, PinReading

#: public name → (module, name there)
_PUBLIC = {
    "ContourFollower": ("twin.runs.contour_run", "ScenarioFollower"),  # the loop of a scenario
    "ContourStep": ("twin.control.contour", "ContourStep"),
    "Controller": ("twin.control.controllers", "Controller"),
    "PaperController": ("twin.control.controllers", "PaperController"),
    "Percept": ("twin.control.controllers", "Percept"),
    "Environment": ("twin.core.environment", "Environment"),
    "Observation": ("twin.core.environment", "Observation"),
    "PhysicsError": ("twin.core.errors", "PhysicsError"),
    "TwinError": ("twin.core.errors", "TwinError"),
    "UserError": ("twin.core.errors", "UserError"),
    "Pose": ("twin.core.poses", "Pose"),
    "Scenario": ("twin.core.scenario", "Scenario"),
    "load_scenario": ("twin.core.scenario", "load_scenario"),
    "scenario_from_dict": ("twin.core.scenario", "scenario_from_dict"),
    "make_environment": ("twin.runs.backends", "make_environment"),
    "ContourFollowingEnv": ("twin.runs.gym_env", "ContourFollowingEnv"),
    "GYM_ID": ("twin.runs.gym_registration", "GYM_ID"),
    "run_scenario": ("twin.runs.run", "run_scenario"),
    "tap_model": ("twin.runs.training", "model_for_scenario"),
    "PerceptionModel": ("twin.sensing.perception", "PerceptionModel"),
    "PinReader": ("twin.sensing.pins", "PinReader"),
    "PinReading": ("twin.sensing.pins", "PinReading"),
}

__all__ = [
    "GYM_ID",
    "ContourFollower",
    "ContourFollowingEnv",
    "ContourStep",
    "Controller",
    "Environment",
    "Observation",
    "PaperController",
    "Percept",
    "PerceptionModel",
    "PhysicsError",
    "PinReader",
    "PinReading",
    "Pose",
    "Scenario",
    "TwinError",
    "UserError",
    "load_scenario",
    "make_environment",
    "run_scenario",
    "scenario_from_dict",
    "tap_model",
]


def __getattr__(name: str) -> Any:
    """Import a public name's module on first use and keep the name here."""
    if name not in _PUBLIC:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, attribute = _PUBLIC[name]
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


#: the packages that read MUJOCO_GL / PYOPENGL_PLATFORM when they are first imported
_GL_READERS = frozenset({"mujoco", "OpenGL", "pyrender"})


class _SelectGLFirst:
    """A `sys.meta_path` entry that runs twin.world.gl's selection just before the first import
    of a GL reader, wherever it happens; it finds no module itself (the import goes on)."""

    def find_spec(self, fullname: str, path: object = None, target: object = None) -> None:
        if fullname in _GL_READERS and self in sys.meta_path:
            sys.meta_path = [finder for finder in sys.meta_path if finder is not self]
            importlib.import_module("twin.world.gl").select_gl_backend()
        return None


if _GL_READERS & sys.modules.keys():  # too late to come first: keep the variables consistent at least
    importlib.import_module("twin.world.gl").select_gl_backend()
else:
    sys.meta_path.insert(0, _SelectGLFirst())
