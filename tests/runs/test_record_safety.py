"""A run folder is written by one recorder at a time, never torn and never read outside
itself: a second recorder of a folder is refused by name; a full disk leaves the status
"failed" and a run that resumes to completion; a frame file exists before the line that
names it; a sample naming a frame outside its run, or a field of the wrong type or shape,
is refused by file, line and field."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from twin.core.environment import Observation
from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.scenario import load_scenario
from twin.runs.record import LOCK_FILE, RunRecorder, load_run

SCENARIO = load_scenario("rectangle_render")


def _observation(i: int, rng: np.random.Generator, size: int = 48) -> Observation:
    return Observation(
        time=0.1 * i, pose=Pose(i, 0, 1, 0, 0, 0), frame=rng.integers(0, 256, (size, size, 3), dtype=np.uint8)
    )


def _record(out: Path, n: int, rng: np.random.Generator) -> None:
    with RunRecorder(out, SCENARIO, seed=3, backend="sim") as rec:
        for i in range(n):
            rec.add(_observation(i, rng), Pose(i, 0, 1, 0, 0, 0), {"theta_deg": float(i)}, pins_px=np.zeros((127, 2)))


def test_a_second_recorder_of_a_folder_is_refused_by_name(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with RunRecorder(out, SCENARIO, seed=0, backend="sim"):
        with pytest.raises(UserError, match=f"{out}: another twin process is recording"):
            RunRecorder(out, SCENARIO, seed=0, backend="sim")
        with pytest.raises(UserError, match=f"{out}: another twin process is recording"):
            RunRecorder.resume(out)
    assert not (out / LOCK_FILE).exists()  # released with the run


def test_each_line_follows_its_frame(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    out = tmp_path / "run"
    with RunRecorder(out, SCENARIO, seed=0, backend="sim") as rec:
        for i in range(5):
            rec.add(_observation(i, rng), Pose(), {})
            for line in (out / "samples.jsonl").read_text().splitlines():
                assert (out / json.loads(line)["frame"]).is_file()
    assert len(load_run(out).samples) == 5
    assert sorted(p.name for p in out.iterdir()) == ["frames", "run.json", "samples.jsonl"]  # no temporary files


def test_resume_removes_what_a_killed_writer_left(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    out = tmp_path / "run"
    _record(out, 2, rng)
    meta = json.loads((out / "run.json").read_text())
    (out / "run.json").write_text(json.dumps({**meta, "status": "interrupted"}))
    leftovers = [out / "frames" / ".000002.png.4242.tmp", out / ".run.json.4242.tmp"]
    for leftover in leftovers:
        leftover.write_bytes(b"half")
    with RunRecorder.resume(out) as rec:
        assert rec.count == 2
    assert not any(p.exists() for p in leftovers) and load_run(out).meta["status"] == "completed"


@pytest.fixture
def tiny_disk(tmp_path: Path):
    """A 512 KiB tmpfs (root only): a disk that fills up."""
    mount = tmp_path / "disk"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(mount)], capture_output=True).returncode:
        pytest.skip("mounting a small tmpfs needs root")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=True)


def test_a_full_disk_fails_the_run_readably_and_resume_completes_it(tiny_disk: Path) -> None:
    rng = np.random.default_rng(1)
    out = tiny_disk / "run"
    observations = [_observation(i, rng, size=160) for i in range(8)]  # ~77 kB of noise per PNG
    with pytest.raises(OSError) as err:
        with RunRecorder(out, SCENARIO, seed=0, backend="sim") as rec:
            for i, obs in enumerate(observations):
                rec.add(obs, Pose(i, 0, 0, 0, 0, 0), {"theta_deg": float(i)})
    assert err.value.errno == 28  # ENOSPC
    run = load_run(out)
    assert run.meta["status"] == "failed" and "No space left" in run.meta["error"]
    assert 0 < len(run.samples) < 8 and run.meta["samples"] == len(run.samples)
    assert all((out / s["frame"]).is_file() for s in run.samples)
    assert not [p for p in out.rglob("*") if "tmp" in p.name] and not (out / LOCK_FILE).exists()
    subprocess.run(["mount", "-o", "remount,size=8m", str(tiny_disk)], check=True)  # room made
    with RunRecorder.resume(out) as rec:
        for i in range(rec.count, 8):
            rec.add(observations[i], Pose(i, 0, 0, 0, 0, 0), {"theta_deg": float(i)})
    run = load_run(out)
    assert run.meta["status"] == "completed" and run.meta["resumes"][0]["previous_status"] == "failed"
    assert [s["labels"]["theta_deg"] for s in run.samples] == list(range(8))
    for i in range(8):
        np.testing.assert_array_equal(run.frame(i), observations[i].frame)


@pytest.mark.parametrize("frame", ["/etc/passwd", "../secret.png", "frames/../../x.png", "link.png"])
def test_a_frame_outside_its_run_is_refused_by_name(tmp_path: Path, frame: str) -> None:
    rng = np.random.default_rng(2)
    out = tmp_path / "run"
    _record(out, 2, rng)
    (tmp_path / "secret.png").write_bytes((out / "frames" / "000000.png").read_bytes())
    (out / "link.png").symlink_to(tmp_path / "secret.png")
    lines = (out / "samples.jsonl").read_text().splitlines()
    row = json.loads(lines[1])
    row["frame"] = frame
    (out / "samples.jsonl").write_text("\n".join([lines[0], json.dumps(row)]) + "\n")
    with pytest.raises(UserError, match=r"samples.jsonl: line 2: field 'frame' names a file outside the run directory"):
        load_run(out)


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda row: "{}", "sample without the fields"),
        (lambda row: json.dumps({**row, "pins_px": [[1.0, 2.0]] * 100}), "field 'pins_px'"),
        (lambda row: json.dumps({**row, "target": "abc"}), "field 'target'"),
        (lambda row: json.dumps({**row, "pose": [1, 2, 3, 4, 5, float("inf")]}), "field 'pose' holds NaN"),
        (lambda row: json.dumps({**row, "labels": {"theta_deg": "abc"}}), "label 'theta_deg'"),
        (lambda row: json.dumps({**row, "found": [1] * 127}), "field 'found'"),
        (lambda row: "[" * 100_000 + "]" * 100_000, "not valid JSON"),
    ],
)
def test_a_sample_of_the_wrong_type_is_refused_by_line_and_field(tmp_path: Path, edit, field: str) -> None:
    out = tmp_path / "run"
    _record(out, 2, np.random.default_rng(3))
    lines = (out / "samples.jsonl").read_text().splitlines()
    (out / "samples.jsonl").write_text("\n".join([lines[0], edit(json.loads(lines[1]))]) + "\n")
    with pytest.raises(UserError, match=f"line 2.*{field}"):
        load_run(out)


@pytest.mark.parametrize(
    "meta, field",
    [
        ("[1, 2, 3]", "a JSON object"),
        ("{}", "format_version"),
        ("[" * 200_000 + "]" * 200_000, "nested too deep"),
        (
            '{"format_version": 1, "scenario": {"name": "x", "fidelity": "fast", "protocol": {"kind": "taps"}}, '
            '"seed": -5, "backend": "sim"}',
            "field 'seed'",
        ),
    ],
)
def test_run_metadata_of_the_wrong_type_is_refused_by_field(tmp_path: Path, meta: str, field: str) -> None:
    out = tmp_path / "run"
    _record(out, 1, np.random.default_rng(4))
    (out / "run.json").write_text(meta)
    with pytest.raises(UserError, match=f"run.json: .*{field}"):
        load_run(out)
