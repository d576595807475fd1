"""Scale-out: map a function over independent jobs on the local cores or a Ray cluster,
yielding results in job order. Same jobs and seeds → same results either way."""
from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

from threadpoolctl import threadpool_limits

from twin.core.errors import UserError


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def map_ordered(fn: Callable, jobs: list[tuple], workers: int | None = None, cluster: str | None = None) -> Iterator:
    """Yield fn(*job) for each job, in order, on a pool started for this call alone
    (WorkerPool: to map many times, keep one pool).

    workers: local processes (default: all cores; 1 runs in this process).
    cluster: a Ray address ("auto", "ray://host:10001", or "local" to start a local
      instance); needs the `ray` extra.
    """
    with WorkerPool(workers if cluster is not None else _local_workers(workers, len(jobs)), cluster) as pool:
        yield from pool.map_ordered(fn, jobs)


def _local_workers(workers: int | None, n_jobs: int) -> int:
    """No more local processes than jobs (a one-shot map)."""
    return min(default_workers() if workers is None else workers, max(n_jobs, 1))


class WorkerPool:
    """Worker processes (or a Ray connection) kept across calls to `map_ordered`, so a
    caller that maps again and again (a calibration: once per CMA-ES generation) starts
    them once: each start is a forkserver process importing the simulator, then one
    worker process per core. Use it as a context manager; closing it stops the workers
    (and a Ray instance it started).

    workers: local processes (default: all cores; 1 runs in this process). Processes are
      started as jobs arrive, up to `workers`.
    cluster: a Ray address, as map_ordered's.
    """

    def __init__(self, workers: int | None = None, cluster: str | None = None) -> None:
        self.workers = default_workers() if workers is None else workers
        self.cluster = cluster
        self._pool: ProcessPoolExecutor | None = None
        self._ray_remote = None
        self._ray_started = False

    def __enter__(self) -> "WorkerPool":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def map_ordered(self, fn: Callable, jobs: list[tuple]) -> Iterator:
        """Yield fn(*job) for each job, in order. A failed job, SIGINT or SIGTERM drops the
        queued jobs (not run) and stops the local workers; the next call starts new ones."""
        if self.cluster is not None:
            yield from self._map_ray(fn, jobs)
            return
        if self.workers <= 1 or len(jobs) <= 1:
            for job in jobs:
                yield fn(*job)
            return
        if self._pool is None:
            # forkserver, not fork: the parent may hold a GL context or BLAS/OpenMP threads (GP
            # training), which a forked child inherits half-initialised and can deadlock on.
            context = get_context("forkserver")
            context.set_forkserver_preload(["twin.runs.sim_env", "twin.runs.runner", "twin.control.contour"])
            self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=context, initializer=_start_worker,
                                             initargs=(os.getpid(),))
        futures = [self._pool.submit(fn, *job) for job in jobs]
        # Ctrl-C and SIGTERM land while this waits for a worker, never while the caller
        # handles a result (records a chunk): the results finished by then are all kept.
        on_main = threading.current_thread() is threading.main_thread()
        caller_mask = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS) if on_main else None
        try:
            for index, future in enumerate(futures):
                try:
                    with _signals_delivered(caller_mask):
                        result = future.result()
                except KeyboardInterrupt:  # Ctrl-C, SIGTERM: what the workers have finished is kept
                    yield from _finished_in_order(futures[index:])
                    raise
                yield result
        except BaseException:
            self._stop_local()
            raise
        finally:
            if on_main:
                signal.pthread_sigmask(signal.SIG_SETMASK, caller_mask)

    def close(self) -> None:
        """Stop the local workers and a Ray instance this pool started."""
        self._stop_local()
        if self._ray_started:
            import ray

            ray.shutdown()
            self._ray_started = False
        self._ray_remote = None

    def _stop_local(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def _map_ray(self, fn: Callable, jobs: list[tuple]) -> Iterator:
        try:
            import ray
        except ImportError:
            raise UserError("a Ray cluster needs the ray extra: uv sync --extra ray") from None
        if self._ray_remote is None:
            if not ray.is_initialized():
                if self.cluster == "local":
                    ray.init(num_cpus=default_workers(), include_dashboard=False, log_to_driver=False)
                else:
                    ray.init(address=self.cluster, log_to_driver=False)
                self._ray_started = True
            self._ray_remote = ray.remote(_call_with_one_blas_thread)
        refs = [self._ray_remote.remote(fn, *job) for job in jobs]
        for ref in refs:
            yield ray.get(ref)


_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


@contextlib.contextmanager
def _signals_delivered(mask: set | None) -> Iterator[None]:
    """Inside, the signal mask is `mask` (the caller's); None leaves it as it is."""
    if mask is None:
        yield
        return
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)


def _finished_in_order(futures: list) -> Iterator:
    """After an interruption: the queued jobs cancelled, the results of those finished or
    running, in order, up to the first that was cancelled or failed (a record is a prefix
    of the protocol)."""
    for future in futures:
        future.cancel()
    for future in futures:
        if future.cancelled():
            return
        try:
            result = future.result()
        except Exception:  # noqa: BLE001  (a failed job ends the kept prefix; the interruption is raised)
            return
        yield result


#: How often a worker checks that the process that started it is alive (s)
PARENT_CHECK_S = 0.5


def _start_worker(parent_pid: int) -> None:
    """A local worker's start: one BLAS thread; Ctrl-C left to the parent, which keeps
    what the workers finish; the worker ends when its parent does, even one killed
    outright (SIGKILL: Linux's parent-death signal, and a thread that polls the parent)."""
    one_blas_thread()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG: killed when the forkserver goes
    threading.Thread(target=_exit_with, args=(parent_pid,), daemon=True, name="twin-parent-watch").start()


def _exit_with(parent_pid: int) -> None:
    """End this process as soon as `parent_pid` is gone."""
    while True:
        time.sleep(PARENT_CHECK_S)
        try:
            os.kill(parent_pid, 0)
        except ProcessLookupError:
            os._exit(1)
        except PermissionError:
            pass


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
