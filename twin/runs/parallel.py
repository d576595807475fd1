"""Scale-out: map a function over independent jobs on the local cores or a Ray cluster,
yielding results in job order. Same jobs and seeds → same results either way."""
from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

from twin.core.errors import UserError
from threadpoolctl import threadpool_limits


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def map_ordered(fn: Callable, jobs: list[tuple], workers: int | None = None, cluster: str | None = None) -> Iterator:
    """Yield fn(*job) for each job, in order.

    workers: local processes (default: all cores; 1 runs in this process).
    cluster: a Ray address ("auto", "ray://host:10001", or "local" to start a local
      instance); needs the `ray` extra.
    """
    if cluster is not None:
        yield from _map_ray(fn, jobs, cluster)
        return
    workers = default_workers() if workers is None else workers
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            yield fn(*job)
        return
    # forkserver, not fork: the parent may hold a GL context or BLAS/OpenMP threads (GP
    # training), which a forked child inherits half-initialised and can deadlock on.
    context = get_context("forkserver")
    context.set_forkserver_preload(["twin.runs.sim_env", "twin.runs.runner", "twin.control.contour"])
    with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=context,
                             initializer=one_blas_thread) as pool:
        futures = [pool.submit(fn, *job) for job in jobs]
        try:
            for future in futures:
                yield future.result()
        except BaseException:  # SIGINT/SIGTERM or a failed job: drop the queued jobs, not run them
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def one_blas_thread() -> None:
    """Limit this process to one BLAS/OpenMP thread, for the libraries loaded already
    (threadpoolctl) and for those loaded later (the environment variables they read when
    they load: numpy, scipy and OpenCV each bring their own OpenBLAS).

    Every matrix here is small (the skin layer's ≤ 100² solves, GP kernels of a few
    hundred taps), so BLAS threads only hand work off and then spin-wait: a second
    OpenBLAS thread burnt a whole core beside the physics (CPU time 1.7× the wall time
    in one process, measured) and, with one process per core, stole it from the other
    worker. Called by `twin`'s CLI, every local worker and every Ray task."""
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[name] = "1"

    threadpool_limits(1)


def _call_with_one_blas_thread(fn: Callable, *args):
    """Ray task body: `one_blas_thread`, then fn(*args)."""
    one_blas_thread()
    return fn(*args)


def _map_ray(fn: Callable, jobs: list[tuple], cluster: str) -> Iterator:
    try:
        import ray
    except ImportError:
        raise UserError("a Ray cluster needs the ray extra: uv sync --extra ray") from None
    started = False
    if not ray.is_initialized():
        if cluster == "local":
            ray.init(num_cpus=default_workers(), include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=cluster, log_to_driver=False)
        started = True
    try:
        remote = ray.remote(_call_with_one_blas_thread)
        refs = [remote.remote(fn, *job) for job in jobs]
        for ref in refs:
            yield ray.get(ref)
    finally:
        if started:
            ray.shutdown()
