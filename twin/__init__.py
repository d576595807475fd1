"""TacTip digital twin: the public API (README "Scripting the twin").

    import twin
    scenario = twin.load_scenario("contour_small_circle")   # a shipped scenario, or a path
    with twin.make_environment(scenario, seed=0) as env:    # sim, or the real rig (backend)
        reader = twin.PinReader(env.reset())                # pins from frames or projections
        pins = reader.read(env.step(twin.Pose(0, -30, 3))).pins_px

Everything else lives in the layers below: twin.core (conventions, scenario, interfaces),
twin.world (the simulated rig), twin.sensing, twin.control, twin.runs, twin.tools.
"""
from twin.world import gl as _gl  # noqa: F401  (sets the headless GL backend before mujoco loads)

from twin.control.contour import ContourFollower, ContourStep
from twin.control.controllers import Controller, PaperController, Percept
from twin.core.environment import Environment, Observation
from twin.core.errors import PhysicsError, TwinError, UserError
from twin.core.poses import Pose
from twin.core.scenario import Scenario, load_scenario, scenario_from_dict
from twin.runs.backends import make_environment
from twin.runs.gym_env import GYM_ID, ContourFollowingEnv, register as _register_gym
from twin.runs.run import run_scenario
from twin.runs.training import model_for_scenario as tap_model
from twin.sensing.perception import PerceptionModel
from twin.sensing.pins import PinReader, PinReading

_register_gym()

__all__ = [
    "GYM_ID", "ContourFollower", "ContourFollowingEnv", "ContourStep", "Controller", "Environment", "Observation",
    "PaperController", "Percept", "PerceptionModel", "PhysicsError", "PinReader", "PinReading", "Pose", "Scenario",
    "TwinError", "UserError", "load_scenario", "make_environment", "run_scenario", "scenario_from_dict", "tap_model",
]
