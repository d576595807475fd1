"""Scenario validation: every shipped scenario is valid; bad files fail with exit 2,
naming the file, the field and the value, without a traceback."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.core.errors import UserError
from twin.runs.spec import load_scenario  # the scenario file with its dome model's `physics` checked
from twin.tools.cli import main

SCENARIOS = sorted(Path(__file__).resolve().parents[2].joinpath("scenarios").glob("*.yaml"))


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_shipped_scenarios_validate(path: Path) -> None:
    assert load_scenario(path).name


BAD = {
    "unknown_object": ("name: x\nobject: {name: square}\n", "object", "square"),
    "bad_effect": ("name: x\nobject: {name: rectangle}\neffects: [render, fog]\n", "effects", "fog"),
    "bad_depth": (
        "name: x\nobject: {name: rectangle}\nprotocol: {kind: taps, depths_mm: [2, deep]}\n",
        "depths_mm",
        "deep",
    ),
    "negative_gain": ("name: x\nobject: {name: rectangle}\nprotocol: {kind: contour, gain: -1}\n", "gain", "-1"),
    "short_pose": (
        "name: x\nobject: {name: rectangle}\nprotocol: {kind: render, poses: [[0, 0, 1]]}\n",
        "poses",
        "[0, 0, 1]",
    ),
    "typo_field": ("name: x\nobject: {name: rectangle}\nfidelty: fast\n", "fidelty", "fast"),
    "friction_without_contact": ("name: x\nobject: {name: rectangle}\neffects: [friction]\n", "effects", "friction"),
    "not_yaml": ("name: [x\n", "line", "YAML"),
    "flex_override_on_compliant": (
        "name: x\nobject: {name: rectangle}\ndome: compliant\nphysics: {cellcount: [4, 4, 2]}\n",
        "physics.cellcount",
        "compliant",
    ),
    "sealed_gel_on_flex": (
        "name: x\nobject: {name: rectangle}\ndome: flex\nphysics: {gel_enclosed: false}\n",
        "physics.gel_enclosed",
        "flex",
    ),
    "gel_modulus_on_flex": (
        "name: x\nobject: {name: rectangle}\ndome: flex\nphysics: {gel_young_kpa: 26.9}\n",
        "physics.gel_young_kpa",
        "flex",
    ),
    "bending_without_membrane": (
        "name: x\nobject: {name: rectangle}\ndome: compliant\nphysics: {membrane_young_mpa: 0}\n",
        "skin_bending",
        "membrane_young_mpa",
    ),
    "skin_held_inside_the_cap": (
        "name: x\nobject: {name: rectangle}\ndome: compliant\nphysics: {skin_held_deg: 50}\n",
        "physics.skin_held_deg",
        "50",
    ),
    "silhouette_with_lighting": (
        "name: x\nobject: {name: rectangle}\nsensor: {camera: {renderer: silhouette}}\n"
        "effects: [contact, render, lighting]\n",
        "sensor.camera.renderer",
        "lighting",
    ),
    "silhouette_with_msaa": (
        "name: x\nobject: {name: rectangle}\nsensor: {camera: {renderer: silhouette, msaa: 4}}\n",
        "sensor.camera.renderer",
        "msaa",
    ),
    "unknown_renderer": (
        "name: x\nobject: {name: rectangle}\nsensor: {camera: {renderer: vulkan}}\n",
        "sensor.camera.renderer",
        "vulkan",
    ),
    "unknown_dome": ("name: x\nobject: {name: rectangle}\ndome: rubber\n", "dome", "rubber"),
    "sway_on_flex": (
        "name: x\nobject: {name: rectangle}\ndome: flex\nphysics: {tip_sway_mm_per_n: 0.3}\n",
        "physics.tip_sway_mm_per_n",
        "flex",
    ),
    "negative_sway": (
        "name: x\nobject: {name: rectangle}\ndome: compliant\nphysics: {tip_sway_mm_per_n: -0.5}\n",
        "physics.tip_sway_mm_per_n",
        "-0.5",
    ),
    "skin_held_on_flex": (
        "name: x\nobject: {name: rectangle}\ndome: flex\nphysics: {skin_held_deg: 80}\n",
        "physics.skin_held_deg",
        "flex",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_scenario_names_file_field_value(case: str, tmp_path: Path, capsys) -> None:
    text, field, value = BAD[case]
    path = tmp_path / f"{case}.yaml"
    path.write_text(text)
    with pytest.raises(UserError) as err:
        load_scenario(path)
    message = str(err.value)
    assert str(path) in message and field in message and value in message, message
    assert main(["check", "--no-compile", str(path)]) == 2
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and str(path) in captured.err


def test_missing_file_is_user_error(tmp_path: Path, capsys) -> None:
    missing = tmp_path / "nope.yaml"
    assert main(["check", str(missing)]) == 2
    err = capsys.readouterr().err
    assert f"{missing}: no such scenario file" in err and "Traceback" not in err, err


def test_user_outline_object_named_in_a_scenario(tmp_path: Path) -> None:
    """A user's own object: a 2D outline CSV extruded to a thickness, path relative to the scenario."""
    from twin.core.poses import Pose
    from twin.runs.sim_env import SimEnvironment

    (tmp_path / "triangle.csv").write_text("x,y\n-30,-20\n30,-20\n0,30\n")
    path = tmp_path / "triangle.yaml"
    path.write_text(
        "name: triangle\nobject: {outline: triangle.csv, thickness_mm: 8}\nfidelity: fast\n"
        "effects: [contact, friction]\n"
    )
    assert main(["check", str(path)]) == 0
    with SimEnvironment(load_scenario(path)) as env:
        rest = env.reset().pins_px
        pressed = env.step(Pose(0, 20, 3, 0, 0, 0)).pins_px  # the edge at y = −20 (object) = +20 (work)
    assert np.abs(pressed - rest).max() > 1.0


def test_broken_user_stl_is_a_user_error(tmp_path: Path, capsys) -> None:
    (tmp_path / "broken.stl").write_text("solid broken\nendsolid broken\n")
    path = tmp_path / "broken.yaml"
    path.write_text("name: broken\nobject: {stl: broken.stl}\n")
    assert main(["check", str(path)]) == 2
    assert "broken.stl" in capsys.readouterr().err


def test_unreachable_pose_is_a_user_error(tmp_path: Path, capsys) -> None:
    path = tmp_path / "far.yaml"
    path.write_text("name: far\nobject: {name: rectangle}\nprotocol: {kind: render, poses: [[900, 0, -5, 0, 0, 0]]}\n")
    assert main(["render", str(path), "--out", str(tmp_path / "f.png")]) == 2
    assert "out of reach" in capsys.readouterr().err
