"""Nothing is read or written outside what the user named: a run name is one folder
name; a symbolic link out of a scenario's folder is refused; a YAML alias bomb is refused
before it expands; error messages name a bad file's line without quoting it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.core.errors import UserError
from twin.core.scenario import load_scenario, scenario_from_dict
from twin.core.validation import MAX_YAML_NODES, read_yaml
from twin.runs.spec import load_scenario_stimulus
from twin.sensing.perception import PerceptionModel

BASE = {"object": {"name": "rectangle"}}


@pytest.mark.parametrize("name", ["../../x", "/tmp/x", "a/b", "..", ".hidden", "a\0b", "a\nb", "x" * 101, "", "a b"])
def test_a_run_name_that_is_not_one_folder_name_is_refused(name: str) -> None:
    with pytest.raises(UserError, match="name = .*a run name"):
        scenario_from_dict({**BASE, "name": name})


@pytest.mark.parametrize("name", ["taps_rectangle", "x" * 100, "run-2.b+c", "_x"])
def test_a_folder_name_is_a_run_name(name: str) -> None:
    assert scenario_from_dict({**BASE, "name": name}).name == name


def test_an_alias_bomb_is_refused_before_it_expands(tmp_path: Path) -> None:
    lines = ['a: &a ["x","x","x","x","x","x","x","x","x"]']
    lines += [f"{c}: &{c} [{', '.join(['*' + p] * 9)}]" for p, c in zip("abcdefgh", "bcdefghi")]
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("\n".join(lines))
    assert bomb.stat().st_size < 400 and 9**9 > MAX_YAML_NODES
    with pytest.raises(UserError, match=f"bomb.yaml: not valid YAML: more than {MAX_YAML_NODES} values"):
        read_yaml(bomb, "scenario")
    (tmp_path / "fine.yaml").write_text("a: &a [1, 2]\nb: *a\n")  # aliases within the bound are fine
    assert read_yaml(tmp_path / "fine.yaml", "scenario") == {"a": [1, 2], "b": [1, 2]}


def test_an_outline_linked_out_of_its_folder_is_refused_unread(tmp_path: Path) -> None:
    secret = tmp_path / "elsewhere" / "secret.csv"
    secret.parent.mkdir()
    secret.write_text("top secret line\n")
    folder = tmp_path / "scenario"
    folder.mkdir()
    (folder / "pw.csv").symlink_to(secret)
    (folder / "s.yaml").write_text("name: linked\nobject: {outline: pw.csv, thickness_mm: 5}\n")
    with pytest.raises(UserError, match="pw.csv is a symbolic link out of its folder") as err:
        load_scenario_stimulus(load_scenario(folder / "s.yaml"))
    assert "secret" not in str(err.value).replace(str(tmp_path), "")


def test_an_outline_error_names_the_line_without_quoting_it(tmp_path: Path) -> None:
    (tmp_path / "o.csv").write_text("x,y\n0,0\nroot:x:0:0:secret\n10,10\n")
    (tmp_path / "s.yaml").write_text("name: quoted\nobject: {outline: o.csv, thickness_mm: 5}\n")
    with pytest.raises(UserError, match="o.csv line 3: expected 'x,y'") as err:
        load_scenario_stimulus(load_scenario(tmp_path / "s.yaml"))
    message = str(err.value).replace(str(tmp_path), "")
    assert "secret" not in message and "root" not in message


def test_a_truncated_model_file_is_named_not_a_zip_error(tmp_path: Path) -> None:
    path = tmp_path / "taps.npz"
    np.savez(path, header=np.zeros(100_000, np.uint8))
    path.write_bytes(path.read_bytes()[:5000])
    with pytest.raises(UserError, match="taps.npz: not a perception model file"):
        PerceptionModel.load(path)


def test_an_unknown_material_names_the_file_and_the_field(tmp_path: Path) -> None:
    path = tmp_path / "mat.yaml"
    path.write_text("name: mat\nobject: {name: rectangle, material: unobtainium}\nprotocol: {kind: taps}\n")
    with pytest.raises(UserError, match=rf"^{path}: field 'object.material' = 'unobtainium': not a known material"):
        load_scenario_stimulus(load_scenario(path))


def test_an_edge_radius_the_object_cannot_take_names_the_file_and_the_field(tmp_path: Path) -> None:
    path = tmp_path / "round.yaml"
    path.write_text("name: round\nobject: {name: spiral, edge_radius_mm: 4}\nprotocol: {kind: taps}\n")
    with pytest.raises(UserError, match=rf"^{path}: field 'object.edge_radius_mm': object spiral: edge radius 4 mm"):
        load_scenario_stimulus(load_scenario(path))


def test_an_outline_of_too_many_vertices_is_refused_while_it_is_read(tmp_path: Path) -> None:
    # 200,000 vertices used to run minutes of convex decomposition before a compile error
    t = np.linspace(0.0, 2 * np.pi, 200_000, endpoint=False)
    np.savetxt(tmp_path / "big.csv", np.c_[50 * np.cos(t), 50 * np.sin(t)], delimiter=",")
    (tmp_path / "s.yaml").write_text("name: big\nobject: {outline: big.csv, thickness_mm: 5}\n")
    with pytest.raises(UserError, match=r"big.csv: more than 10,000 vertices \(line 10001\)"):
        load_scenario_stimulus(load_scenario(tmp_path / "s.yaml"))
