"""The controller loader: the paper's controller by name, a user class from a file, an
object as it is, and a clear UserError naming the spec for everything else."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from twin.control.controllers import PaperController, load_controller
from twin.core.errors import UserError
from twin.core.scenario import ContourProtocol

PROTOCOL = ContourProtocol()


class _Straight:
    def reset(self, start):
        self.start = start

    def next_pose(self, percept):
        return None


def test_paper_by_name_takes_the_protocols_gains() -> None:
    c = load_controller("paper", PROTOCOL)
    assert isinstance(c, PaperController)
    assert (c.step_mm, c.gain, c.lateral_target_mm) == (PROTOCOL.step_mm, PROTOCOL.gain, PROTOCOL.lateral_target_mm)


def test_object_is_used_as_it_is() -> None:
    obj = _Straight()
    assert load_controller(obj, PROTOCOL) is obj


def test_user_class_from_file_relative_to_the_scenario(tmp_path: Path) -> None:
    (tmp_path / "mine.py").write_text(
        "class Mine:\n    def __init__(self, step_mm, gain, lateral_target_mm):\n"
        "        self.step_mm = step_mm\n    def reset(self, start): pass\n"
        "    def next_pose(self, percept): return None\n"
    )
    c = load_controller("mine.py:Mine", PROTOCOL, base_dir=tmp_path)
    assert type(c).__name__ == "Mine" and c.step_mm == PROTOCOL.step_mm


@pytest.mark.parametrize(
    "source, spec, message",
    [
        (None, "pid", "use 'paper' or 'path/to/file.py:ClassName'"),
        (None, "missing.py:C", "missing.py not found"),
        ("raise RuntimeError('boom')\n", "c.py:C", "failed to import: RuntimeError: boom"),
        ("X = 1\n", "c.py:C", "has no 'C'"),
        ("class C:\n    def reset(self, start): pass\n", "c.py:C", "C has no method next_pose()"),
    ],
)
def test_bad_specs_are_user_errors_naming_the_spec(tmp_path: Path, source, spec, message) -> None:
    if source is not None:
        (tmp_path / "c.py").write_text(source)
    with pytest.raises(UserError, match=".*".join(map(re.escape, [spec, message]))):
        load_controller(spec, PROTOCOL, base_dir=tmp_path)


def test_object_without_methods_is_refused() -> None:
    with pytest.raises(UserError, match="needs reset\\(start\\) and next_pose\\(percept\\)"):
        load_controller(object(), PROTOCOL)


@pytest.mark.parametrize(
    "answer, message",
    [
        ("raise RuntimeError('boom')", r"next_pose\(\) raised RuntimeError: boom"),
        ("import sys; sys.exit(0)", r"next_pose\(\) raised SystemExit"),
        ("return 'abc'", r"next_pose\(\) must return a finite Pose, got str"),
        ("return None", r"next_pose\(\) must return a finite Pose, got NoneType"),
        ("return Pose(float('nan'), 0, 0, 0, 0, 0)", r"next_pose\(\) must return a finite Pose, got a Pose with NaN"),
        ("return Pose(None, 0, 0, 0, 0, 0)", r"next_pose\(\) must return a finite Pose, got a Pose with NaN"),
    ],
)
def test_a_plug_in_that_fails_at_run_time_is_named(tmp_path: Path, answer: str, message: str) -> None:
    """The contour loop asks its controller through ContourFollower._ask_controller: a
    plug-in's exception, sys.exit or a non-finite answer is a UserError naming it (by its
    name in the scenario: the scenario's loop, twin.runs.contour_run.ScenarioFollower)."""
    from twin.core.scenario import scenario_from_dict
    from twin.runs.contour_run import ScenarioFollower

    (tmp_path / "bad.py").write_text(
        "from twin.core.poses import Pose\nclass C:\n    def reset(self, start): pass\n"
        f"    def next_pose(self, percept):\n        {answer}\n"
    )
    scenario = scenario_from_dict(
        {"name": "plug_in", "object": {"name": "rectangle"}, "protocol": {"kind": "contour", "controller": "bad.py:C"}},
        str(tmp_path / "s.yaml"),
    )
    follower = ScenarioFollower(None, scenario, model=None)
    with pytest.raises(UserError, match=r"controller 'bad.py:C': " + message):
        follower._ask_controller("next_pose", None)
