"""The suite's hardest friction case (tests/world/test_dome_compliant.py,
test_frictionless_and_very_high_friction) on one dome: μ = 3, press 3 mm on the
rectangle's edge, slide 6 mm along it, reverse 12 mm, come back. Prints each move's
seconds and the contact force (N, tool frame) after it.

    python hard_case.py LEVEL [physics_key=value ...]
"""

import sys
import time

import yaml

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment

level, physics = sys.argv[1], {k: yaml.safe_load(v) for k, v in (a.split("=", 1) for a in sys.argv[2:])}
spec = {
    "name": "hard_case",
    "object": {"name": "rectangle", "friction": 3.0},
    "dome": "compliant",
    "fidelity": level,
    "effects": ["contact", "friction"],
    "physics": physics,
}
env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(60, 0, -2, 0, 0, 0))
env.reset()
for y in (0.0, 6.0, -6.0, 0.0):
    t0 = time.perf_counter()
    env.move_to(Pose(60, y, 3.0, 0, 0, 0), 20.0)
    force = env.observe_frame().contact_force_tool
    print(
        f"  y {y:+4.0f} mm: {time.perf_counter() - t0:7.1f} s, force ({force[0]:+.2f}, {force[1]:+.2f}, {force[2]:+.2f}) N",
        flush=True,
    )
