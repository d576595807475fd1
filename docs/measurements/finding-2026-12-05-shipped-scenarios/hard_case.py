"""The suite's hardest friction case (tests/world/test_dome_compliant.py,
test_frictionless_and_very_high_friction) on one dome: μ = 3, press 3 mm on the
rectangle's edge, slide 6 mm along it, reverse 12 mm, come back. Prints each move's
seconds and the contact force (N, tool frame) after it.

    python hard_case.py LEVEL [--fitted [--scaled]] [--friction=MU] [physics_key=value ...]

--fitted: the fitted dome (fitted.yaml) at the level's node spacing; --scaled: with its
stiffness scaled to the 4.3 N edge press (../finding-2026-12-05-force-scale/scaled.yaml);
key=value entries change its `physics` (or, without --fitted, the plain solid's:
twin.world.dome.compliant.PLAIN_SOLID, the compliant dome's defaults when this ran);
--friction: μ instead of 3.
"""

import sys
import time
from collections.abc import Iterator
from pathlib import Path

import yaml

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment
from twin.world.dome.compliant import PLAIN_SOLID

#: fitted.yaml's `physics`: the fitted dome's entries
FITTED: dict = yaml.safe_load((Path(__file__).parent / "fitted.yaml").read_text())["physics"]
#: the fitted dome's entries scaled to the 4.3 N edge press, written by force_scale.py there
SCALED_FILE = Path(__file__).parent.parent / "finding-2026-12-05-force-scale" / "scaled.yaml"


def scaled_entries() -> dict:
    """SCALED_FILE's `physics` entries (the moduli and the sway), to go over FITTED."""
    return yaml.safe_load(SCALED_FILE.read_text())["physics"]


def environment(level: str, physics: dict, friction: float = 3.0) -> SimEnvironment:
    """The compliant dome at `level` with `physics` on the rectangle of `friction`, started
    out of contact above the edge."""
    spec = {
        "name": "hard_case",
        "object": {"name": "rectangle", "friction": friction},
        "dome": "compliant",
        "fidelity": level,
        "effects": ["contact", "friction"],
        "physics": physics,
    }
    env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(60, 0, -2, 0, 0, 0))
    env.reset()
    return env


def moves(env: SimEnvironment) -> Iterator[float]:
    """Press, slide, reverse and come back, yielding each move's y (mm) after it is made."""
    for y in (0.0, 6.0, -6.0, 0.0):
        env.move_to(Pose(60, y, 3.0, 0, 0, 0), 20.0)
        yield y


if __name__ == "__main__":
    args = sys.argv[2:]
    physics = dict(FITTED) if "--fitted" in args else dict(PLAIN_SOLID)
    physics |= scaled_entries() if "--scaled" in args else {}
    friction = next((float(a.split("=", 1)[1]) for a in args if a.startswith("--friction=")), 3.0)
    physics |= {k: yaml.safe_load(v) for k, v in (a.split("=", 1) for a in args if not a.startswith("--"))}
    env = environment(sys.argv[1], physics, friction)
    t0 = time.perf_counter()
    for y in moves(env):
        force = env.observe_frame().contact_force_tool
        print(
            f"  y {y:+4.0f} mm: {time.perf_counter() - t0:7.1f} s, force ({force[0]:+.2f}, {force[1]:+.2f}, {force[2]:+.2f}) N",
            flush=True,
        )
        t0 = time.perf_counter()
