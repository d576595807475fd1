"""A parallel run's worker processes end with it, even when it is killed outright
(SIGKILL: checked by process id), and a SIGTERM keeps every sample the workers had
finished or were working on, and so does Ctrl-C: the chunks in progress are recorded, not
thrown away."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from twin.core.errors import WorkerLostError
from twin.runs.parallel import WorkerPool
from twin.runs.record import load_run

SCENARIO = {
    "name": "lifetime_taps",
    "object": {"name": "rectangle"},
    "fidelity": "fast",
    "seed": 3,
    "effects": ["contact", "friction"],
    "protocol": {"kind": "taps", "orientations_deg": [-60, -20, 20, 60], "lateral_mm": [6, 0, -4], "depths_mm": [3]},
}
CHUNK = 3  # samples per orientation: a chunk (twin.runs.runner.chunk_moves)

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads process trees from /proc")


def _children(pid: int) -> set[int]:
    """Every live descendant of `pid` (from /proc)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = _parent(int(entry.name))
            except OSError:
                continue
    found, todo = set(), [pid]
    while todo:
        parent = todo.pop()
        for child, ppid in parents.items():
            if ppid == parent and child not in found:
                found.add(child)
                todo.append(child)
    return found


def _parent(pid: int) -> int:
    """The parent's process id (from /proc; OSError once `pid` is gone)."""
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def _alive(pid: int) -> bool:
    try:
        return "Z" not in Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False


def _start(tmp_path: Path, scenario_dict: dict = SCENARIO) -> tuple[subprocess.Popen, Path]:
    scenario = tmp_path / "taps.yaml"
    scenario.write_text(yaml.safe_dump(scenario_dict))
    out = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "twin.tools.cli", "run", str(scenario), "--out", str(out), "--workers", "2", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=os.environ | {"PYTHONUNBUFFERED": "1"},
        start_new_session=True,
    )
    return proc, out


def _wait(condition, proc: subprocess.Popen, what: str, timeout_s: float = 180.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, f"no {what} within {timeout_s} s"
        time.sleep(0.01)


def test_workers_end_when_the_parent_is_killed(tmp_path: Path) -> None:
    proc, out = _start(tmp_path)
    workers: set[int] = set()

    def two_workers_busy() -> bool:
        workers.update(_children(proc.pid))
        return len([p for p in workers if _alive(p)]) >= 3 and (out / "run.json").exists()  # forkserver + 2

    _wait(two_workers_busy, proc, "worker processes")
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 20.0
    while any(_alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [p for p in workers if _alive(p)], f"processes left of {sorted(workers)}"


@pytest.mark.parametrize("stop, exit_code", [("SIGTERM to the parent", 143), ("Ctrl-C to the process group", 130)])
@pytest.mark.parametrize("after", [1, CHUNK], ids=["at the first sample", "once the first chunk is in"])
def test_an_interruption_keeps_every_chunk_the_workers_were_running(
    tmp_path: Path, stop: str, exit_code: int, after: int
) -> None:
    """The first chunk runs in the parent while the workers start (about a second: the
    forkserver imports the simulator). Stopped during that chunk, or once it is in and
    the parent waits for the workers, the second chunk is still finished and kept."""
    proc, out = _start(tmp_path)
    samples = out / "samples.jsonl"
    _wait(lambda: samples.exists() and samples.read_bytes().count(b"\n") >= after, proc, f"{after} samples")
    seen = samples.read_bytes().count(b"\n")
    if stop.startswith("SIGTERM"):
        proc.send_signal(signal.SIGTERM)
    else:  # a terminal's Ctrl-C reaches every process of the group: the workers leave it to the parent
        os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=180)
    assert proc.returncode == exit_code, err.decode()
    run = load_run(out)
    assert run.meta["status"] == "interrupted" and len(run.samples) % CHUNK == 0
    assert len(run.samples) >= max(seen, CHUNK * 2), (seen, len(run.samples))


def test_a_run_whose_worker_is_killed_fails_and_keeps_its_chunks(tmp_path: Path) -> None:
    """`twin run` with a worker killed outright (as by the out-of-memory killer): exit 1,
    one line naming the signal, the run marked failed with whole chunks kept, and no
    process left behind."""
    many = SCENARIO | {"protocol": SCENARIO["protocol"] | {"orientations_deg": list(range(-160, 180, 20))}}
    proc, out = _start(tmp_path, many)
    samples = out / "samples.jsonl"
    workers: list[int] = []

    def two_workers_busy() -> bool:
        children = _children(proc.pid)
        direct = {p for p in children if _parent(p) == proc.pid}  # the forkserver, the resource tracker
        workers[:] = sorted(p for p in children - direct if _alive(p))
        return len(workers) >= 2 and samples.exists() and samples.read_bytes().count(b"\n") >= 1

    _wait(two_workers_busy, proc, "two busy workers")
    everyone = _children(proc.pid)
    os.kill(workers[-1], signal.SIGKILL)
    _, err = proc.communicate(timeout=180)
    assert proc.returncode == 1, err.decode()
    assert err.decode().startswith("failed: ") and "a worker process ended" in err.decode(), err.decode()
    assert "killed by SIGKILL" in err.decode() and err.decode().count("\n") == 1, err.decode()
    run = load_run(out)
    assert run.meta["status"] == "failed" and len(run.samples) % CHUNK == 0
    assert len(run.samples) < 3 * len(many["protocol"]["orientations_deg"])
    deadline = time.monotonic() + 20.0
    while any(_alive(p) for p in everyone) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [p for p in everyone if _alive(p)], f"processes left of {sorted(everyone)}"


def _die_once_the_other_runs(folder: str) -> None:
    """Wait until the other job has started, then end this worker as the out-of-memory
    killer would (SIGKILL)."""
    started = Path(folder) / "started"
    for _ in range(6000):
        if started.exists():
            break
        time.sleep(0.01)
    os.kill(os.getpid(), signal.SIGKILL)


def _run_until_released(folder: str) -> None:
    """A long job: mark it started, then wait for `released` (at most 120 s), then mark it
    finished."""
    (Path(folder) / "pid").write_text(str(os.getpid()))
    (Path(folder) / "started").touch()
    for _ in range(12000):
        if (Path(folder) / "released").exists():
            break
        time.sleep(0.01)
    (Path(folder) / "finished").touch()


@pytest.mark.parametrize("streamed", [False, True], ids=["map_ordered", "map_streamed"])
def test_a_worker_killed_outright_fails_the_map_at_once(tmp_path: Path, streamed: bool) -> None:
    """One worker dies while the other is in a long job: the map raises WorkerLostError
    naming the signal, without waiting for the other job (its result is lost with the
    pool), and the other worker is stopped, though it blocks SIGTERM."""
    jobs = [(_die_once_the_other_runs, str(tmp_path)), (_run_until_released, str(tmp_path))]
    with WorkerPool(workers=2) as pool:
        map_ = pool.map_streamed if streamed else pool.map_ordered
        with pytest.raises(WorkerLostError, match=r"killed by SIGKILL \(signal 9"):
            list(map_(_call, jobs))
        survivor = int((tmp_path / "pid").read_text())
        assert not (tmp_path / "finished").exists(), "the map waited for the other worker's job"
        assert not _alive(survivor), "the other worker was left running"
        assert list(pool.map_ordered(abs, [(-1,), (-2,)])) == [1, 2]  # the pool starts new workers
    (tmp_path / "released").touch()


def _call(fn, folder: str, send=None) -> None:
    """fn(folder): a job function of its own for each job of one map."""
    fn(folder)
