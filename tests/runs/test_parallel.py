"""Scale-out gives identical results: one process, two local processes and a local Ray
instance record the same pins for the same scenario and seed."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from twin.core.scenario import scenario_from_dict
from twin.runs.parallel import WorkerPool, map_ordered
from twin.runs.record import load_run
from twin.runs.run import run_scenario

TAPS = {
    "name": "parallel_taps",
    "object": {"name": "rectangle"},
    "fidelity": "fast",
    "effects": ["contact", "friction"],
    "protocol": {"kind": "taps", "orientations_deg": [-40, 0, 40], "lateral_mm": [6, 0, -4], "depths_mm": [3]},
}


def _pins(tmp_path, name: str, **kwargs) -> np.ndarray:
    run = load_run(run_scenario(scenario_from_dict(TAPS), tmp_path / name, progress=False, **kwargs))
    assert run.meta["status"] == "completed" and len(run.samples) == 9
    return run.pins_px


def test_local_processes_match_one_process(tmp_path) -> None:
    serial = _pins(tmp_path, "serial", workers=1)
    assert np.array_equal(serial, _pins(tmp_path, "two", workers=2))
    assert np.abs(serial - serial[0]).max() > 1.0  # the taps did press on the edge


def test_ray_local_cluster_matches(tmp_path) -> None:
    pytest.importorskip("ray", reason="the ray extra is installed by the README's commands")
    assert np.array_equal(_pins(tmp_path, "serial", workers=1), _pins(tmp_path, "ray", cluster="local"))


def test_one_blas_thread_covers_libraries_loaded_later() -> None:
    """numpy, scipy and OpenCV each bring their own OpenBLAS; an idle second BLAS thread
    spin-waits beside the physics (twin.runs.parallel.one_blas_thread). Fresh process: the
    limit must hold for the libraries loaded after the call too."""
    import ast
    import subprocess
    import sys

    code = (
        "from twin.runs.parallel import one_blas_thread; one_blas_thread()\n"
        "import numpy, scipy.linalg, cv2, sklearn.gaussian_process\n"
        "from threadpoolctl import threadpool_info\n"
        "print(sorted({(i['filepath'], i['num_threads']) for i in threadpool_info()}))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    pools = ast.literal_eval(out)
    assert len(pools) >= 2 and all(n == 1 for _, n in pools), pools


def test_worker_pool_keeps_its_processes() -> None:
    # a calibration maps once per generation: one pool's workers serve every call, while map_ordered starts its own
    with WorkerPool(workers=2) as pool:
        pids = [set(pool.map_ordered(os.getpid, [()] * 4)) for _ in range(3)]
        assert len(set.union(*pids)) <= 2 and os.getpid() not in set.union(*pids)
        assert list(pool.map_ordered(math.sqrt, [(9.0,), (4.0,)])) == [3.0, 2.0]  # in job order
        with pytest.raises(ValueError):
            list(pool.map_ordered(math.sqrt, [(4.0,), (-1.0,), (1.0,)]))  # a failed job stops the workers ...
        assert set(pool.map_ordered(os.getpid, [()] * 4)).isdisjoint(
            set.union(*pids)
        )  # ... the next call starts new ones
    assert set(map_ordered(os.getpid, [()] * 4, workers=2)).isdisjoint(set.union(*pids))


def test_worker_pool_keeps_one_ray_instance() -> None:
    ray = pytest.importorskip("ray", reason="the ray extra is installed by the README's commands")
    with WorkerPool(cluster="local") as pool:
        assert list(pool.map_ordered(math.sqrt, [(9.0,), (4.0,)])) == [3.0, 2.0]
        assert ray.is_initialized()  # kept between calls
        address = ray.get_runtime_context().gcs_address
        assert list(pool.map_ordered(math.sqrt, [(1.0,)])) == [1.0]
        assert ray.get_runtime_context().gcs_address == address  # the same instance: not started per call
    assert not ray.is_initialized()  # the instance the pool started is stopped with it


def _send_then_wait_for_flag(flag: str, patience_s: float, send) -> None:
    """Send 'first', then whether `flag` appeared (the parent creates it on receiving
    'first') within `patience_s` s: 'streamed', or 'not streamed' when it did not."""
    import time
    from pathlib import Path

    send("first")
    deadline = time.monotonic() + patience_s
    while not Path(flag).exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    send("streamed" if Path(flag).exists() else "not streamed")


def _send_range(n: int, send) -> None:
    for i in range(n):
        send(i)


def _send_then_fail(send) -> None:
    send("before")
    raise ValueError("job failed")


def test_streamed_items_arrive_while_the_job_runs(tmp_path) -> None:
    flag = tmp_path / "first_received"
    with WorkerPool(workers=2) as pool:
        items = []
        for item in pool.map_streamed(_send_then_wait_for_flag, [(str(flag), 60.0), (str(tmp_path / "never"), 0.5)]):
            items.append(item)
            if item == "first":
                flag.touch()
        assert items[:2] == ["first", "streamed"]  # the first item came before its job ended
        assert items[2:] == ["first", "not streamed"]  # the second job's, after the first job's
        assert list(pool.map_streamed(_send_range, [(3,), (0,), (2,)])) == [0, 1, 2, 0, 1]  # in job order
        got = []
        with pytest.raises(ValueError, match="job failed"):
            for item in pool.map_streamed(_send_then_fail, [(), ()]):
                got.append(item)
        assert got == ["before"]  # what a failed job sent before failing is kept
    assert list(map_ordered(math.sqrt, [(4.0,)], workers=2)) == [2.0]
    with WorkerPool(workers=1) as serial:  # one process: the same items, in the same order
        assert list(serial.map_streamed(_send_range, [(3,), (0,), (2,)])) == [0, 1, 2, 0, 1]
