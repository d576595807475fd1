"""A parallel run's worker processes end with it, even when it is killed outright
(SIGKILL: checked by process id), and a SIGTERM keeps every sample the workers had
finished or were working on, and so does Ctrl-C: the chunks in progress are recorded, not
thrown away. A worker killed outright fails a run or a calibration at once, and the line
says how to go on."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

from twin.core.errors import Terminated, WorkerLostError
from twin.core.scenario import scenario_from_dict
from twin.runs.parallel import WorkerPool
from twin.runs.record import load_run
from twin.runs.run import run_scenario

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


def _parents() -> dict[int, int]:
    """Each live process's parent process id (from /proc; a process that ends while it is
    read is left out)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except OSError:
                continue
    return parents


def _children(pid: int, parents: dict[int, int] | None = None) -> set[int]:
    """Every live descendant of `pid` (in `parents`, else a fresh `_parents()`)."""
    parents = _parents() if parents is None else parents
    found, todo = set(), [pid]
    while todo:
        parent = todo.pop()
        for child, ppid in parents.items():
            if ppid == parent and child not in found:
                found.add(child)
                todo.append(child)
    return found


def _busy_workers(pid: int) -> list[int]:
    """The live worker processes of the `twin` process `pid`: its descendants but its own
    children (the forkserver, the resource tracker), from one look at /proc."""
    parents = _parents()
    return sorted(p for p in _children(pid, parents) if parents[p] != pid and _alive(p))


def _alive(pid: int) -> bool:
    try:
        return "Z" not in Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False


def _assert_all_end(pids: set[int] | list[int], within_s: float = 20.0) -> None:
    """Every process of `pids` ends within `within_s`."""
    deadline = time.monotonic() + within_s
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [p for p in pids if _alive(p)], f"processes left of {sorted(pids)}"


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
    _assert_all_end(workers)


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
        workers[:] = _busy_workers(proc.pid)
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
    assert f"keeps its {len(run.samples)} samples: continue it with: twin run --resume {out}" in err.decode()
    assert len(run.samples) < 3 * len(many["protocol"]["orientations_deg"])
    _assert_all_end(everyone)


#: `twin calibrate` of the friction alone, over many short generations (a shrinking grid of four)
FRICTION_ALONE = {
    "parameters": {
        "camera.focal_px": {"fit": False},
        "camera.k1": {"fit": False},
        "material.young_kpa": {"fit": False},
        "tcp.z_mm": {"fit": False},
        "friction": {"fit": True},
    },
    "rest_pins": False,
    "optimiser": {"popsize": 4, "max_generations": 30, "tol_bracket": 1e-6},
}


def test_a_calibration_whose_worker_is_killed_fails_and_goes_on_from_its_checkpoint(tmp_path: Path) -> None:
    """`twin calibrate --workers 2` with a pool worker killed outright after its first
    generation: exit 1, one line naming the signal and the checkpoint, no process left; the
    same command again goes on from that checkpoint (the generations before it kept)."""
    run_scenario(scenario_from_dict(SCENARIO), tmp_path / "taps", workers=1, progress=False)
    (tmp_path / "twin.yaml").write_text(yaml.safe_dump(SCENARIO))
    (tmp_path / "settings.yaml").write_text(yaml.safe_dump(FRICTION_ALONE))
    out = tmp_path / "cal"
    command = [sys.executable, "-m", "twin.tools.cli", "calibrate", str(tmp_path / "taps"), "--out", str(out)]
    command += ["--scenario", str(tmp_path / "twin.yaml"), "--settings", str(tmp_path / "settings.yaml"), "--quiet"]
    proc = subprocess.Popen([*command, "--workers", "2"], stderr=subprocess.PIPE, start_new_session=True)
    history = out / "history.jsonl"

    def a_generation_done() -> bool:
        return history.exists() and history.read_bytes().count(b"\n") >= 2 and len(_busy_workers(proc.pid)) >= 2

    _wait(a_generation_done, proc, "a finished generation and two workers")
    everyone = _children(proc.pid)
    os.kill(_busy_workers(proc.pid)[-1], signal.SIGKILL)
    _, err = proc.communicate(timeout=180)
    assert proc.returncode == 1, err.decode()
    message = err.decode()
    assert message.startswith("failed: WorkerLostError: a worker process ended") and message.count("\n") == 1, message
    assert "killed by SIGKILL" in message and f"{out / 'checkpoint.json'} keeps every finished generation" in message
    _assert_all_end(everyone)
    kept = history.read_text().splitlines()
    again = subprocess.run([*command, "--workers", "1"], capture_output=True, timeout=600)
    assert again.returncode == 0, again.stderr.decode()
    assert history.read_text().splitlines()[: len(kept)] == kept  # went on, not started again


def _die_once_the_other_runs(folder: str) -> None:
    """Wait until the other job has started, then end this worker as the out-of-memory
    killer would (SIGKILL)."""
    started = Path(folder) / "started"
    for _ in range(6000):
        if started.exists():
            break
        time.sleep(0.01)
    os.kill(os.getpid(), signal.SIGKILL)


def _fail_once_the_other_runs(folder: str) -> None:
    """Wait until the other job has started, then raise."""
    started = Path(folder) / "started"
    for _ in range(6000):
        if started.exists():
            break
        time.sleep(0.01)
    raise RuntimeError("the job failed")


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


@pytest.mark.parametrize("dies_first", [True, False], ids=["dying_job_first", "dying_job_second"])
@pytest.mark.parametrize("streamed", [False, True], ids=["map_ordered", "map_streamed"])
def test_a_worker_killed_outright_fails_the_map_at_once(tmp_path: Path, streamed: bool, dies_first: bool) -> None:
    """One worker dies while the other is in a long job: the map raises WorkerLostError
    naming the signal, without waiting for the other job (its result is lost with the
    pool), and the other worker is stopped, though it blocks SIGTERM. With the dying job
    second, the worker that dies is the one the second job started, which the executor's
    own watch can miss until the long job ends."""
    jobs = [(_die_once_the_other_runs, str(tmp_path)), (_run_until_released, str(tmp_path))]
    jobs = jobs if dies_first else jobs[::-1]
    with WorkerPool(workers=2) as pool:
        map_ = pool.map_streamed if streamed else pool.map_ordered
        with pytest.raises(WorkerLostError, match=r"killed by SIGKILL \(signal 9"):
            list(map_(_call, jobs))
        survivor = int((tmp_path / "pid").read_text())
        assert not (tmp_path / "finished").exists(), "the map waited for the other worker's job"
        assert not _alive(survivor), "the other worker was left running"
        assert list(pool.map_ordered(abs, [(-1,), (-2,)])) == [1, 2]  # the pool starts new workers
    (tmp_path / "released").touch()


@pytest.mark.parametrize("streamed", [False, True], ids=["map_ordered", "map_streamed"])
def test_a_failed_job_fails_the_map_at_once(tmp_path: Path, streamed: bool) -> None:
    """A job raises while the other worker is in a long job: the map raises the job's
    error without waiting for the other job, and the other worker is stopped, as where a
    worker dies. (A shutdown that waited for it would wait for its job and, where that job
    had sent more items than the pipe holds, for ever: a run that failed on the dome's
    physics hung so.)"""
    jobs = [(_fail_once_the_other_runs, str(tmp_path)), (_run_until_released, str(tmp_path))]
    try:
        with WorkerPool(workers=2) as pool:
            map_ = pool.map_streamed if streamed else pool.map_ordered
            with pytest.raises(RuntimeError, match="the job failed"):
                list(map_(_call, jobs))
            survivor = int((tmp_path / "pid").read_text())
            assert not (tmp_path / "finished").exists(), "the map waited for the other worker's job"
            _assert_all_end([survivor])
            assert list(pool.map_ordered(abs, [(-1,), (-2,)])) == [1, 2]  # the pool starts new workers
    finally:
        (tmp_path / "released").touch()


def test_a_map_that_keeps_nothing_running_stops_at_once_on_sigterm(tmp_path: Path) -> None:
    """map_ordered(keep_running=False), as a calibration maps its candidates: a SIGTERM
    while a worker is in a long job stops the map at once and kills that worker; the job
    is not finished (with keep_running it would be, after up to 120 s)."""

    def terminate_once_started() -> None:
        started = tmp_path / "started"
        for _ in range(6000):
            if started.exists():
                break
            time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGTERM)

    def terminated(signum, frame) -> None:
        raise Terminated

    previous = signal.signal(signal.SIGTERM, terminated)
    try:
        with WorkerPool(workers=2) as pool:
            sender = threading.Thread(target=terminate_once_started)
            sender.start()
            jobs = [(_run_until_released, str(tmp_path)), (_run_until_released, str(tmp_path / "other"))]
            (tmp_path / "other").mkdir()
            with pytest.raises(Terminated):
                list(pool.map_ordered(_call, jobs, keep_running=False))
            sender.join()
            worker = int((tmp_path / "pid").read_text())
            _assert_all_end([worker])
            assert not (tmp_path / "finished").exists(), "the map waited for the running job"
            assert list(pool.map_ordered(abs, [(-1,), (-2,)])) == [1, 2]  # the pool starts new workers
    finally:
        signal.signal(signal.SIGTERM, previous)
        (tmp_path / "released").touch()
        (tmp_path / "other" / "released").touch()


def _call(fn, folder: str, send=None) -> None:
    """fn(folder): a job function of its own for each job of one map."""
    fn(folder)
