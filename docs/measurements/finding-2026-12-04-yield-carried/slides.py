"""Single sheared taps of a replay scenario, each 4 mm deep at θ = 0 with the edge 4.5 mm
from the centre onto the object and off it, slid 3 mm along the edge (±) or across it
(+: towards off the object, −: onto it): the contact's normal and tangential force (N)
and the pins' mean shift from the unslid tap (px).
usage: python slides.py SCENARIO.yaml   (a variant: variants.sh, by
../finding-2026-11-29-pin-posts/variant.py)"""

import sys

import numpy as np
import yaml

from twin.core.scenario import scenario_from_dict
from twin.runs.protocols import protocol_moves
from twin.runs.sim_env import SimEnvironment

MOVES = {"none": (0, 0), "along+": (3, 0), "along−": (-3, 0), "lateral+": (0, 3), "lateral−": (0, -3)}

doc = yaml.safe_load(open(sys.argv[1]))
taps = [
    {"lateral_mm": lateral, "theta_deg": 0.0, "slide_along_mm": a, "slide_lateral_mm": b}
    for lateral in (-4.5, 4.5)
    for a, b in MOVES.values()
]
doc["protocol"] = {"kind": "sheared_taps", "depth_mm": 4, "given": taps, "rest_frame": False}
scenario = scenario_from_dict(doc)
env = SimEnvironment(scenario)
env.reset()
rows = []
for move in protocol_moves(scenario.protocol):
    env.move_to(move.pose, move.speed_mm_s)
    if move.record:
        force = env.physics.contact_force_tool()
        rows.append((env.observe().truth["pins_px"], float(np.linalg.norm(force[:2])), float(-force[2])))
print(doc["name"])
for side, lateral in enumerate((-4.5, 4.5)):
    block = rows[side * len(MOVES) : (side + 1) * len(MOVES)]
    unslid = np.asarray(block[0][0])
    cells = []
    for name, (pins, tangential, normal) in zip(MOVES, block):
        shift = float(np.linalg.norm((np.asarray(pins) - unslid).mean(axis=0)))
        cells.append(f"{name} {tangential:.2f}/{normal:.2f} N {shift:.1f} px")
    print(f"  l {lateral:+.1f}: " + "; ".join(cells))
