"""A frictionless 3 mm press with the edge 1 mm onto the sensor … 1.5 mm off it in 0.1 mm
steps, each press on its own, within nodes and at whole nodes: the force at each step and
the pins' bend (second difference, px) between steps."""

import numpy as np

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment

for within in (True, False):
    forces, pins = [], []
    for x in np.round(np.arange(59.0, 61.51, 0.1), 3):
        scenario = scenario_from_dict(
            {
                "name": "edge-steps",
                "object": {"name": "rectangle"},
                "dome": "compliant",
                "effects": ["contact"],
                "physics": {"edge_within_node": within},
            }
        )
        env = SimEnvironment(scenario, start_pose=Pose(float(x), 0, -2, 0, 0, 0))
        env.reset()
        env.move_to(Pose(float(x), 0, 3, 0, 0, 0))
        forces.append(env.observe_frame().contact_force)
        pins.append(env.observe().pins_px)
    bend = np.linalg.norm(np.diff(np.array(pins), n=2, axis=0), axis=2).max(axis=1)
    print(f"edge within nodes: {within}")
    print("  force, N:", " ".join(f"{f:.3f}" for f in forces))
    print("  force change a step, N:", " ".join(f"{d:+.3f}" for d in np.diff(forces)))
    print("  worst bend a step, px:", " ".join(f"{b:.2f}" for b in bend))
