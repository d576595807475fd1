"""A run written by RunRecorder reads back unchanged through load_run: pins, poses,
targets, labels, truth and frames; the status says how the run ended; a line cut by a
kill is dropped, a corrupt line elsewhere is named. Floats are stored to 1e-6 of their unit
(µpx, µm for poses in mm), so "exact" means equal after that rounding."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.core.environment import Observation
from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.scenario import load_scenario
from twin.runs.record import RunRecorder, load_run

SCENARIO = load_scenario("rectangle_render")


def _observations(n: int, rng: np.random.Generator) -> list[Observation]:
    return [
        Observation(
            time=0.1 * i,
            pose=Pose(*rng.normal(size=6)),
            frame=rng.integers(0, 256, (48, 64, 3), dtype=np.uint8),
            truth={"pins_px": rng.normal(320, 50, (127, 2)), "contact_force_n": float(i)},
        )
        for i in range(n)
    ]


def _record(out: Path, observations: list[Observation], rng: np.random.Generator) -> list[np.ndarray]:
    pins = []
    with RunRecorder(out, SCENARIO, seed=3, backend="sim") as rec:
        for i, obs in enumerate(observations):
            pins.append(rng.normal(320, 50, (127, 2)))
            rec.add(
                obs,
                Pose(i, 0, 1, 0, 0, 0),
                {"theta_deg": 10.0 * i, "on_object": i % 2 == 0},
                pins_px=pins[-1],
                found=np.arange(127) % 3 > 0,
            )
    return pins


def test_round_trip_is_exact(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    observations = _observations(4, rng)
    pins = _record(tmp_path / "run", observations, rng)
    run = load_run(tmp_path / "run")
    assert run.meta["status"] == "completed" and run.meta["samples"] == 4 and run.meta["seed"] == 3
    assert run.meta["scenario"]["name"] == SCENARIO.name
    np.testing.assert_array_equal(run.pins_px, np.round(pins, 6))
    np.testing.assert_array_equal(run.poses, [np.round(o.pose.as_array(), 6) for o in observations])
    np.testing.assert_array_equal(run.targets[:, 0], [0, 1, 2, 3])
    np.testing.assert_array_equal(run.label("theta_deg"), [0, 10, 20, 30])
    assert [s["labels"]["on_object"] for s in run.samples] == [True, False, True, False]
    np.testing.assert_array_equal(run.samples[2]["truth"]["pins_px"], np.round(observations[2].truth["pins_px"], 6))
    for i, obs in enumerate(observations):
        np.testing.assert_array_equal(run.frame(i), obs.frame)  # PNG is lossless


def test_interrupted_run_keeps_its_samples(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    with pytest.raises(KeyboardInterrupt):
        with RunRecorder(tmp_path / "run", SCENARIO, seed=0, backend="sim") as rec:
            for obs in _observations(3, rng):
                rec.add(obs, Pose(), {})
            raise KeyboardInterrupt
    run = load_run(tmp_path / "run")
    assert run.meta["status"] == "interrupted" and len(run.samples) == 3


def test_cut_last_line_is_dropped_and_corrupt_middle_line_is_named(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    _record(tmp_path / "run", _observations(3, rng), rng)
    samples = tmp_path / "run" / "samples.jsonl"
    lines = samples.read_text().splitlines()
    samples.write_text("\n".join(lines[:2] + [lines[2][: len(lines[2]) // 2]]))
    assert len(load_run(tmp_path / "run").samples) == 2
    samples.write_text("\n".join([lines[0], "{not json", lines[2]]))
    with pytest.raises(UserError, match="samples.jsonl: line 2 is not valid JSON"):
        load_run(tmp_path / "run")


def test_a_run_directory_is_never_overwritten(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    _record(tmp_path / "run", _observations(1, rng), rng)
    with pytest.raises(UserError, match="already holds a run"):
        RunRecorder(tmp_path / "run", SCENARIO, seed=0, backend="sim")
