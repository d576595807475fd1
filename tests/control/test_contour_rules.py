"""The contour-following loop's stop rules on the simulated rig, with a scripted controller
(a user plug-in file, as a researcher would write one): a path that goes out along the
edge and comes back to the start has travelled far enough but traced a fraction of the
contour, so it must not count as a closed loop."""

from __future__ import annotations

import numpy as np

from twin.core.scenario import scenario_from_dict
from twin.runs.contour_run import ScenarioFollower
from twin.runs.sim_env import SimEnvironment
from twin.sensing.perception import GPConfig, PerceptionModel, paper_training_labels, synthetic_tap_pins

OUT_AND_BACK = '''
from twin.core.poses import Pose

class OutAndBack:
    """8 steps of 3 mm along +x of the work frame, then 8 back: 48 mm travelled."""

    def reset(self, start):
        self.start, self.k = start, 0

    def next_pose(self, percept):
        self.k += 1
        out = self.k if self.k <= 8 else 16 - self.k
        return Pose(self.start.x + 3.0 * out, self.start.y, self.start.z, 0.0, 0.0, self.start.gamma)
'''


def test_a_path_back_to_the_start_is_not_a_closed_loop(tmp_path) -> None:
    (tmp_path / "out_and_back.py").write_text(OUT_AND_BACK)
    th, la, de = paper_training_labels()
    model = PerceptionModel(gp=GPConfig(n_restarts=0)).fit(
        synthetic_tap_pins(th, la, de), th, la, de, np.random.default_rng(0)
    )
    scenario = scenario_from_dict(
        {
            "name": "out_and_back",
            "object": {"name": "rectangle"},
            "placement": {"position_mm": [400, 0], "yaw_deg": 0},
            "effects": ["contact"],
            "protocol": {
                "kind": "contour",
                "max_steps": 17,
                "controller": str(tmp_path / "out_and_back.py") + ":OutAndBack",
            },
        },
        str(tmp_path / "inline.yaml"),
    )
    env = SimEnvironment(scenario)
    follower = ScenarioFollower(env, scenario, model)
    poses = [step.observation.pose for step in follower]
    start = np.array([poses[0].x, poses[0].y])
    assert np.linalg.norm(np.array([poses[-1].x, poses[-1].y]) - start) < 1.0  # it did come back
    assert follower.stop_reason == "step limit", follower.stop_reason
