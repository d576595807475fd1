"""The orientation signal across edge angles: a 2.7 mm press at each of −45 … 45° (5° steps)
with the sensor's centre 4 mm off the object, on the edge and 4 mm onto it; each pin's
spread over the angles, RMS over the pins (and per ring, centre → rim), over its value with
the edge through the centre.

    python angles.py SPACING_MM WITHIN(1|0) '{"physics": "overrides"}'
"""

import json
import sys

import numpy as np

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment

spacing, within, physics = float(sys.argv[1]), sys.argv[2] == "1", json.loads(sys.argv[3])
scenario = scenario_from_dict(
    {
        "name": "edge-angles",
        "object": {"name": "rectangle"},
        "dome": "compliant",
        "effects": ["contact", "friction"],
        "physics": {**physics, "surface_spacing_mm": spacing, "edge_within_node": within},
    }
)
rings = np.repeat(np.arange(7), [1, 6, 12, 18, 24, 30, 36])
signal = {}
for l_mm in (4.0, 0.0, -4.0):  # l > 0: the centre off the object (the rectangle ends at x = 60 mm)
    pins = []
    for angle in np.arange(-45, 46, 5):
        env = SimEnvironment(scenario, start_pose=Pose(60 + l_mm, 0, -2, 0, 0, float(angle)))
        env.reset()
        env.move_to(Pose(60 + l_mm, 0, 2.7, 0, 0, float(angle)))
        pins.append(env.observe().pins_px)
    pins = np.array(pins)
    spread = np.sqrt(((pins - pins.mean(axis=0)) ** 2).sum(axis=2).mean(axis=0))
    signal[l_mm] = (np.sqrt(np.mean(spread**2)), [np.sqrt(np.mean(spread[rings == r] ** 2)) for r in range(7)])
at_centre = signal[0.0][0]
for l_mm, (whole, by_ring) in signal.items():
    print(f"l = {l_mm:+.0f} mm: {whole / at_centre:.2f}; rings " + " ".join(f"{r / at_centre:.2f}" for r in by_ring))
