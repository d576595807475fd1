"""`twin demo`: the README's main job."""
from __future__ import annotations

from pathlib import Path

from twin.scenario import load_scenario
from twin.sim_env import render_scenario_view

SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"


def run_demo(out: Path, seed: int = 0) -> int:
    """Render the inside-camera frame and an overview of the rectangle scene."""
    scenario = load_scenario(SCENARIO_DIR / "rectangle_render.yaml").with_changes(seed=seed)
    for view in ("sensor", "scene"):
        path = render_scenario_view(scenario, out / f"rectangle_{view}.png", view=view)
        print(f"wrote {path}")
    return 0
