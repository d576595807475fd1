"""Every model in assets/ and every scenario's scene compiles and steps 1 s of simulated
time with zero MuJoCo warnings (the MuJoCo Menagerie habit)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from twin.core.scenario import load_scenario
from twin.runs.spec import scene_spec
from twin.world.scene import build_scene

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted(p for p in (ROOT / "assets").rglob("*.xml"))
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))


def _step_one_second(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    steps = int(np.ceil(1.0 / model.opt.timestep))
    for _ in range(steps):
        mujoco.mj_step(model, data)
    warnings = {
        mujoco.mjtWarning(i).name: int(data.warning[i].number)
        for i in range(len(data.warning))
        if data.warning[i].number
    }
    assert not warnings, f"MuJoCo warnings: {warnings}"
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    assert data.time >= 1.0 - 1e-9


@pytest.mark.parametrize("path", MODELS, ids=lambda p: str(p.relative_to(ROOT / "assets")))
def test_asset_model_steps_without_warnings(path: Path) -> None:
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    _step_one_second(model, data)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_scenario_scene_steps_without_warnings(path: Path) -> None:
    scenario = load_scenario(path)
    if scenario.backend != "sim":
        pytest.skip("hardware scenario")
    scene = build_scene(scene_spec(scenario))
    _step_one_second(scene.model, scene.data)


def test_assets_found() -> None:
    names = {p.name for p in MODELS}
    assert {"irb120.xml", "scene.xml"} <= names


def test_generated_tactip_assets_equal_a_fresh_generation(tmp_path):
    """assets/tactip/*.xml are generated from the code: a stale copy fails here."""
    from twin.tools.assets import write_tactip_assets

    for fresh in write_tactip_assets(tmp_path):
        stored = ROOT / "assets" / "tactip" / fresh.name
        assert stored.read_text() == fresh.read_text(), f"{stored} is stale: run `python -m twin.tools.assets`"
