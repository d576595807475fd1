"""Pins on a 3 mm press and a 3 mm slide along the rectangle's straight edge, with the edge
at 11 places between the nodes (the sensor's centre 1.5 mm onto … 1.5 mm off the object).

    python edge_scan.py SPACING_MM WITHIN(1|0) OUT.json ['{"physics": "overrides"}']

Writes {edge_mm: [press pins (127, 2) px, slide pins]} for summary.py.
"""

import json
import sys

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment

spacing, within, out = float(sys.argv[1]), sys.argv[2] == "1", sys.argv[3]
physics = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
pins = {}
for edge in (-1.5, -1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5):
    scenario = scenario_from_dict(
        {
            "name": "edge-scan",
            "object": {"name": "rectangle"},
            "dome": "compliant",
            "effects": ["contact", "friction"],
            "physics": {**physics, "surface_spacing_mm": spacing, "edge_within_node": within},
        }
    )
    x = 60.0 + edge  # the rectangle's edge is at x = 60 mm
    env = SimEnvironment(scenario, start_pose=Pose(x, 0, -2, 0, 0, 0))
    env.reset()
    env.move_to(Pose(x, 0, 3, 0, 0, 0))
    press = env.observe().pins_px.tolist()
    env.move_to(Pose(x, 3, 3, 0, 0, 0))
    pins[edge] = [press, env.observe().pins_px.tolist()]
with open(out, "w") as f:
    json.dump(pins, f)
