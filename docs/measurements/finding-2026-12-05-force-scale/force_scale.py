"""The fitted dome with its stiffness scale set by the edge press force.

The DigiTac taps the dome was fitted to carry no forces, so they fix the ratios between
the dome's stiffnesses but not their scale. Scaling every modulus by k (gel, membrane,
bending) and the sway's compliance by 1/k scales every contact force by k and moves no
pin: linear elasticity, Signorini's gap and Coulomb's cone are all homogeneous in the
force. This takes k from the 4 mm press centred on the edge (4.3 N, the force every
dome of the twin is calibrated to), then presses, slides and turns both domes side by
side and prints the forces, their ratio and the largest pin difference.

    python force_scale.py   # also writes scaled.yaml, the scaled entries
"""

import math
import sys
from pathlib import Path

import numpy as np
import yaml

from twin.core.errors import PhysicsError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment

sys.path.insert(0, str(Path(__file__).parent.parent / "finding-2026-12-05-shipped-scenarios"))
from hard_case import FITTED as FITTED_ENTRIES  # noqa: E402
from hard_case import SCALED_FILE  # noqa: E402

#: the fitted dome's `physics` at its own 1.8 mm nodes
FITTED = FITTED_ENTRIES | {"surface_spacing_mm": 1.8}
#: the force the twin's domes take at a 4 mm press centred on a straight edge (N)
EDGE_PRESS_N = 4.3
MODULI = ("gel_young_kpa", "membrane_young_mpa", "skin_bending_mpa")
#: press 2 and 4 mm on the edge, slide 4 mm along it, turn 10° 2 mm onto the object;
#: then the suite's 6 mm presses on the edge and 6 mm onto the object, each from above
PATHS = [
    [Pose(60, 0, 2, 0, 0, 0), Pose(60, 0, 4, 0, 0, 0), Pose(60, 4, 4, 0, 0, 0), Pose(58, 6, 3, 0, 0, 10)],
    [Pose(60, 0, 6, 0, 0, 0)],
    [Pose(54, 0, -5, 0, 0, 0), Pose(54, 0, 6, 0, 0, 0)],
]


def scaled(physics: dict, k: float) -> dict:
    """`physics` with every modulus × k and the sway's compliance / k."""
    return physics | {key: physics[key] * k for key in MODULI} | {"tip_sway_mm_per_n": physics["tip_sway_mm_per_n"] / k}


def readings(physics: dict) -> list[tuple[Pose, float, np.ndarray | None]]:
    """(pose, |force| N, pins (127, 3) mm) after each move of PATHS on the rectangle (its
    own friction), each path from 2 mm above the edge; where a move raises PhysicsError
    (the 50 N check), its force is NaN, its pins None, and its path ends."""
    spec = {"name": "force_scale", "object": {"name": "rectangle"}, "dome": "compliant", "physics": physics}
    out = []
    for path in PATHS:
        env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(60, 0, -2, 0, 0, 0))
        env.reset()
        for pose in path:
            try:
                env.move_to(pose, 20.0)
            except PhysicsError:
                out.append((pose, math.nan, None))
                break
            frame = env.observe_frame()
            out.append((pose, float(np.linalg.norm(frame.contact_force_tool)), frame.pins_tool * 1e3))
    return out


if __name__ == "__main__":
    fitted = readings(FITTED)
    k = EDGE_PRESS_N / fitted[1][1]
    rounded = {key: float(f"{v:.4g}") for key, v in scaled(FITTED, k).items() if key in (*MODULI, "tip_sway_mm_per_n")}
    print(f"fitted dome: {fitted[1][1]:.3f} N at the 4 mm edge press; k = {EDGE_PRESS_N} / that = {k:.5f}")
    print("scaled entries (4 significant figures):", ", ".join(f"{key}: {v:g}" for key, v in rounded.items()))
    SCALED_FILE.write_text(
        f"# force_scale.py's output: the fitted dome's moduli × {k:.5f} and its sway / that,\n"
        "# to go over ../finding-2026-12-05-shipped-scenarios/fitted.yaml's physics\n"
        + yaml.safe_dump({"physics": rounded}, sort_keys=False)
    )
    scaled_dome = readings(FITTED | rounded)
    print(
        f"{'move (x, y, z mm, gamma deg)':32s} {'fitted N':>9s} {'scaled N':>9s} {'ratio':>7s} {'pins differ (mm)':>17s}"
    )
    for (pose, force, pins), (_, force_k, pins_k) in zip(fitted, scaled_dome, strict=False):
        where = f"({pose.x:g}, {pose.y:g}, {pose.z:g}, {pose.gamma:g})"
        if pins is None:
            print(f"{where:32s} {'raises':>9s} {force_k:9.3f}    (the scaled dome stays under the 50 N check)")
        elif force > 0.0:
            print(f"{where:32s} {force:9.3f} {force_k:9.3f} {force_k / force:7.4f} {np.abs(pins - pins_k).max():17.2e}")
