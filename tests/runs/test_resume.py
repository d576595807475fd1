"""Every way a run can stop keeps it resumable: SIGTERM is handled like Ctrl-C (status
"interrupted", exit 143), a SIGKILLed run reads as "killed", and `twin run --resume`
continues either from its last complete sample to a run bit-identical to an
uninterrupted one (rendered frames with seeded camera noise, so the generator's state
matters too). Resuming with another scenario or seed is refused (exit 2)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from twin.runs.record import load_run
from twin.tools.cli import main

SCENARIO = {
    "name": "resume_taps",
    "object": {"name": "rectangle"},
    "fidelity": "fast",
    "seed": 7,
    "effects": ["contact", "friction", "render", "camera_noise"],
    "sensor": {"camera": {"width": 160, "height": 120, "noise_std": 4}},
    "protocol": {"kind": "taps", "orientations_deg": [-40, 0, 40, 80], "lateral_mm": [6, 0, -4], "depths_mm": [2, 4]},
}
N_SAMPLES = 24


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("resume") / "taps.yaml"
    path.write_text(yaml.safe_dump(SCENARIO))
    return path


@pytest.fixture(scope="module")
def reference(scenario_file: Path, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("reference") / "run"
    assert main(["run", str(scenario_file), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    return out


def _start(scenario_file: Path, out: Path) -> subprocess.Popen:
    env = os.environ | {"PYTHONUNBUFFERED": "1"}
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "twin.tools.cli",
            "run",
            str(scenario_file),
            "--out",
            str(out),
            "--workers",
            "1",
            "--quiet",
        ],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )


def _wait_for_samples(out: Path, n: int, proc: subprocess.Popen, timeout_s: float = 120.0) -> int:
    samples = out / "samples.jsonl"
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if samples.exists() and samples.read_bytes().count(b"\n") >= n:
            return samples.read_bytes().count(b"\n")
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.002)
    raise AssertionError(f"no {n} samples within {timeout_s} s")


def _assert_identical(run_dir: Path, reference: Path) -> None:
    run, ref = load_run(run_dir), load_run(reference)
    assert run.meta["status"] == "completed" and run.state == "completed"
    assert len(run.samples) == len(ref.samples) == N_SAMPLES
    assert np.array_equal(run.pins_px, ref.pins_px)  # bit for bit (as recorded)
    assert run.samples == ref.samples  # poses, labels, truth, time, frame names
    for s in ref.samples:  # the noisy frames, byte for byte
        assert (run_dir / s["frame"]).read_bytes() == (reference / s["frame"]).read_bytes(), s["frame"]


def test_sigkill_at_a_random_sample_then_resume_is_bit_identical(scenario_file, reference, tmp_path) -> None:
    kill_at = int(np.random.default_rng(20261125).integers(1, N_SAMPLES - 2))
    out = tmp_path / "killed"
    proc = _start(scenario_file, out)
    seen = _wait_for_samples(out, kill_at, proc)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    killed = load_run(out)
    assert killed.meta["status"] == "running" and killed.state == "killed" and not killed.finished
    assert seen <= len(killed.samples) < N_SAMPLES
    assert "did not finish" in killed.unfinished_note()

    assert main(["run", "--resume", str(out), "--workers", "1", "--quiet"]) == 0
    _assert_identical(out, reference)
    resumes = load_run(out).meta["resumes"]
    assert len(resumes) == 1 and resumes[0]["previous_status"] == "killed" and resumes[0]["at_sample"] >= seen - 1


def test_sigterm_is_an_interruption_and_resumes(scenario_file, reference, tmp_path, capsys) -> None:
    out = tmp_path / "terminated"
    proc = _start(scenario_file, out)
    _wait_for_samples(out, 5, proc)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err.decode()
    assert b"Traceback" not in err and b"SIGTERM" in err
    run = load_run(out)
    assert (
        run.meta["status"] == "interrupted"
        and run.meta["error"] == "SIGTERM"
        and run.meta["samples"] == len(run.samples)
    )
    assert 5 <= len(run.samples) < N_SAMPLES

    # another seed, another scenario: refused, the run untouched
    assert main(["run", "--resume", str(out), "--seed", "8", "--quiet"]) == 2
    other = tmp_path / "other.yaml"
    other.write_text(yaml.safe_dump(SCENARIO | {"fidelity": "default"}))
    assert main(["run", str(other), "--resume", str(out), "--quiet"]) == 2
    assert "fidelity" in capsys.readouterr().err
    assert load_run(out).meta["status"] == "interrupted"

    assert main(["run", str(scenario_file), "--resume", str(out), "--seed", "7", "--workers", "1", "--quiet"]) == 0
    _assert_identical(out, reference)
    assert main(["run", "--resume", str(out), "--quiet"]) == 2  # complete: nothing to resume


def test_readers_say_a_killed_run_did_not_finish(reference, tmp_path, capsys) -> None:
    killed = tmp_path / "killed"
    killed.mkdir()
    lines = (reference / "samples.jsonl").read_text().splitlines(keepends=True)
    (killed / "samples.jsonl").write_text("".join(lines[:10]) + lines[10][:40])  # a torn last line
    gone = subprocess.Popen(["true"])
    gone.wait()
    meta = json.loads((reference / "run.json").read_text())
    meta.update(status="running", process=meta["process"] | {"pid": gone.pid})  # no end marker, process gone
    (killed / "run.json").write_text(json.dumps(meta))
    shutil.copytree(reference / "frames", killed / "frames")  # a link out of the run would be refused
    run = load_run(killed)
    assert run.state == "killed" and len(run.samples) == 10
    assert main(["compare", str(reference), str(killed), "--out", str(tmp_path / "cmp")]) == 0
    err = capsys.readouterr().err
    assert f"{killed}: run did not finish (killed before it finished" in err
    assert f"twin run --resume {killed}" in err
