"""Scale-out: map a function over independent jobs on the local cores or a Ray cluster,
yielding results in job order. Same jobs and seeds → same results either way."""

from __future__ import annotations

import contextlib
import ctypes
import os
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import connection, get_context

from threadpoolctl import threadpool_limits

from twin.core.errors import UserError, WorkerLostError
from twin.runs.interrupts import HeldSignals, signals_held, stop_signals_blocked


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


def map_streamed(
    fn: Callable,
    jobs: list[tuple],
    workers: int | None = None,
    cluster: str | None = None,
    first_here: Callable[..., Iterator] | None = None,
) -> Iterator:
    """Yield the items each job sends, in job order, as soon as they are sent (a job runs
    fn(*job, send)), on a pool started for this call alone (WorkerPool.map_streamed).
    workers, cluster, first_here: as WorkerPool.map_streamed's."""
    local_jobs = len(jobs) - (first_here is not None and cluster is None)
    with WorkerPool(workers if cluster is not None else _local_workers(workers, local_jobs), cluster) as pool:
        yield from pool.map_streamed(fn, jobs, first_here)


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
        self._outbox = None  # the local workers' queue of (job index, item) (map_streamed)
        self._ray_remote = None
        self._ray_started = False
        #: SIGTERM's handler before this pool started Ray, which installs its own (put back on close)
        self._sigterm_before_ray: object = None

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def map_ordered(self, fn: Callable, jobs: list[tuple], keep_running: bool = True) -> Iterator:
        """Yield fn(*job) for each job, in order. A failed job, SIGINT or SIGTERM drops the
        queued jobs (not run) and stops the local workers; the next call starts new ones.
        keep_running: on SIGINT or SIGTERM, the jobs the workers are running are finished
        and their results yielded; False: the workers are killed at once, for a caller
        that would throw those results away (a calibration keeps whole generations)."""
        if self.cluster is not None:
            yield from self._map_ray(fn, jobs)
            return
        if self.workers <= 1 or len(jobs) <= 1:
            for job in jobs:
                yield fn(*job)
            return
        pool = self._local_pool()
        with self._interruptible() as held:
            with stop_signals_blocked():  # the workers it starts leave Ctrl-C to this process
                futures = [pool.submit(fn, *job) for job in jobs]
            for index, future in enumerate(futures):
                try:
                    result = self._result(future, held)
                except KeyboardInterrupt:  # Ctrl-C, SIGTERM: what the workers have finished is kept
                    if not keep_running:
                        self._kill_local()
                        raise
                    yield from _finished_in_order(futures[index:])
                    raise
                yield result

    def map_streamed(
        self, fn: Callable, jobs: list[tuple], first_here: Callable[..., Iterator] | None = None
    ) -> Iterator:
        """Yield what each job sends, job after job in order, as soon as it is sent: a
        job runs fn(*job, send) and calls send(item) for each item (a chunk's samples),
        so the caller gets a job's first item while the job runs, not when it ends.
        SIGINT or SIGTERM: the rest of the jobs the workers were on is yielded, then it
        raises; a failed job: what it sent, then its exception; either stops the local
        workers (the next call starts new ones).

        first_here: the same job as an iterator of the items it would send; given, this
        process runs the first job with it while the workers start (a thread starts them
        and hands them the other jobs), so the first item comes without waiting for a
        worker. An interruption lands once that job is done, as for the workers' jobs."""
        if self.cluster is not None or self.workers <= 1 or len(jobs) <= 1:
            for items in self.map_ordered(_collect, [(fn, job) for job in jobs]):
                yield from items
            return
        first = 1 if first_here is not None else 0
        futures: list = [None] * first  # job index → its future (the first job's is this process's)
        waiting: dict[int, list] = {}  # items of later jobs, sent before the earlier jobs ended
        pool = self._local_pool()
        with self._interruptible() as held:
            submitter = _Submitter(pool, fn, jobs, first)
            try:
                if first_here is not None:
                    yield from first_here(*jobs[0])
            finally:
                futures += submitter.futures()  # waits for the workers to start, as an interruption would
            for index in range(first, len(jobs)):
                future = futures[index]
                pending = waiting.pop(index, [])
                while True:
                    try:
                        item = pending.pop(0) if pending else self._next_item(index, future, waiting, held)
                    except KeyboardInterrupt:  # Ctrl-C, SIGTERM: the jobs the workers were on are kept whole
                        for later in futures[index + 1 :]:
                            later.cancel()
                        yield from self._sent_in_order(futures, index, waiting)
                        raise
                    if isinstance(item, _JobEnd):
                        break
                    yield item

    @contextlib.contextmanager
    def _interruptible(self) -> Iterator[HeldSignals]:
        """Around a local map: Ctrl-C and SIGTERM are held (twin.runs.interrupts) and land
        only while it waits for a worker (`_result`, `_next_item`), never while this
        process runs the first job, waits for the workers to start or the caller handles
        what it yields (records a chunk), so what was yielded is kept whole; a failure or
        an interruption kills the local workers. Not a shutdown that waits for them: a
        job failed, so another's result has no use, and a worker whose job has sent more
        than the pipe holds cannot end until someone reads it, which no one would."""
        with signals_held() as held:
            try:
                yield held
            except BrokenProcessPool as broken:
                lost = self._stop_broken()
                raise WorkerLostError(lost) from broken
            except BaseException:
                self._kill_local()
                raise

    def _result(self, future, held: HeldSignals):
        """The future's result, waited for in steps of WAIT_S; what `held` holds lands here."""
        while True:
            held.deliver()
            try:
                return future.result(timeout=WAIT_S)
            except TimeoutError:
                self._check_workers()

    def _check_workers(self) -> None:
        """Raise BrokenProcessPool if a local worker has died. The executor finds a dead
        worker by itself only if its manager thread waits on that worker: one started by
        the same `submit` that woke the thread may be missed until the next result
        arrives (a job of minutes), so the waits look as well (CPython 3.11's submit wakes
        the thread before it starts the process)."""
        if _ended(self._processes()):
            raise BrokenProcessPool("a worker process died (found while waiting for a job)")

    def _next_item(self, index: int, future, waiting: dict[int, list], held: HeldSignals | None):
        """The next item job `index` sends (waits for it; what `held` holds lands here);
        items of other jobs go to `waiting`. Raises the job's exception once the items it
        sent before failing have been taken."""
        while True:
            if held is not None:
                held.deliver()
            try:
                sender, item = self._outbox.get(timeout=WAIT_S)
            except queue.Empty:
                if future.done() and future.exception() is not None:
                    raise future.exception() from None
                self._check_workers()
                continue
            if sender == index:
                return item
            waiting.setdefault(sender, []).append(item)

    def _sent_in_order(self, futures: list, index: int, waiting: dict[int, list]) -> Iterator:
        """After an interruption: the rest of the items of job `index` and of the jobs
        after it that were not cancelled, in order, up to the first job that failed."""
        for i in range(index, len(futures)):
            if futures[i].cancelled():
                return
            pending = waiting.pop(i, [])
            while True:
                try:
                    item = pending.pop(0) if pending else self._next_item(i, futures[i], waiting, None)
                except Exception:  # noqa: BLE001  (a failed job ends the kept prefix; the interruption is raised)
                    return
                if isinstance(item, _JobEnd):
                    break
                yield item

    def close(self) -> None:
        """Stop the local workers and a Ray instance this pool started."""
        self._stop_local()
        if self._ray_started:
            import ray

            ray.shutdown()
            self._ray_started = False
            if self._sigterm_before_ray is not None and threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGTERM, self._sigterm_before_ray)
                self._sigterm_before_ray = None
        self._ray_remote = None

    def _local_pool(self) -> ProcessPoolExecutor:
        """The local workers, started on first use, with the queue they send items on.
        Made before the workers are started under stop_signals_blocked: making the queue
        starts multiprocessing's resource tracker, which unblocks SIGINT and SIGTERM on the
        thread that starts it."""
        if self._pool is None:
            # forkserver, not fork: the parent may hold a GL context or BLAS/OpenMP threads (GP
            # training), which a forked child inherits half-initialised and can deadlock on.
            context = get_context("forkserver")
            context.set_forkserver_preload(["twin.runs.sim_env", "twin.runs.runner", "twin.control.contour"])
            self._outbox = context.Queue()
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=context,
                initializer=_start_worker,
                initargs=(os.getpid(), self._outbox),
            )
        return self._pool

    def _processes(self) -> list:
        """The local pool's worker processes (multiprocessing.Process): the executor's
        private `_processes` (Python 3.14 has `ProcessPoolExecutor.kill_workers`)."""
        return list((getattr(self._pool, "_processes", None) or {}).values())

    def _stop_broken(self) -> str:
        """After a worker died: what ended it, then every other worker killed outright and
        the pool stopped. The others block SIGTERM (stop_signals_blocked), so the pool's
        own SIGTERM leaves them to finish their jobs, whose results are lost with the pool
        (a chunk at a fine lattice takes minutes), or to wait for ever on a queue lock the
        dead worker held.

        The exit statuses are read only once the pool is stopped: a forkserver worker's
        status is read off a pipe, once, and the executor's thread reads it as it joins
        the workers, so a second reader at that moment gets nothing and Python reports
        exit code 255. The executor can find the loss (the dead worker's end of the result
        pipe closed) before the forkserver has reaped the worker and written its status,
        so the first ending is waited for, up to REAP_WAIT_S."""
        processes = self._processes()
        if processes:
            connection.wait([p.sentinel for p in processes], timeout=REAP_WAIT_S)
        dead = _ended(processes)
        self._kill_local()
        how = "; ".join(f"process {p.pid} {_ending(p.exitcode)}" for p in dead if p.exitcode)
        return f"a worker process ended without finishing its job: {how or 'no exit status'}"

    def _kill_local(self) -> None:
        """Kill every local worker outright and stop the pool, without waiting for their
        jobs (the workers block SIGTERM, so the pool's own shutdown would)."""
        processes = self._processes()
        dead = _ended(processes)
        for process in processes:
            if process not in dead:
                process.kill()
        self._stop_local()

    def _stop_local(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            self._outbox.close()
            self._outbox = None

    def _map_ray(self, fn: Callable, jobs: list[tuple]) -> Iterator:
        try:
            import ray
        except ImportError:
            raise UserError("a Ray cluster needs the ray extra: uv sync --extra ray") from None
        if self._ray_remote is None:
            if not ray.is_initialized():
                if threading.current_thread() is threading.main_thread():
                    self._sigterm_before_ray = signal.getsignal(signal.SIGTERM)
                if self.cluster == "local":
                    ray.init(num_cpus=default_workers(), include_dashboard=False, log_to_driver=False)
                else:
                    ray.init(address=self.cluster, log_to_driver=False)
                self._ray_started = True
            self._ray_remote = ray.remote(_call_with_one_blas_thread)
        refs = [self._ray_remote.remote(fn, *job) for job in jobs]
        for ref in refs:
            yield ray.get(ref)


def _ended(processes: list) -> list:
    """Those of `processes` that have ended, found from their sentinels without reading
    their exit status (see WorkerPool._stop_broken)."""
    ready = set(connection.wait([p.sentinel for p in processes], timeout=0)) if processes else set()
    return [p for p in processes if p.sentinel in ready]


def _ending(exitcode: int) -> str:
    """How a process with this exit code ended, in words."""
    if exitcode >= 0:
        return f"exited with code {exitcode}"
    number = -exitcode
    name = signal.Signals(number).name if number in signal.valid_signals() else "a signal"
    oom = ", as the kernel's out-of-memory killer does; see dmesg" if number == signal.SIGKILL else ""
    return f"was killed by {name} (signal {number}{oom})"


#: How long a lost worker's exit status is waited for, from the forkserver that reaps it (s)
REAP_WAIT_S = 10.0

#: How long a wait for a worker lasts before the held signals are looked at again (s)
WAIT_S = 0.2


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


#: A local worker's queue to its parent (map_streamed)
_outbox = None


class _JobEnd:
    """What a streamed job sends after its last item."""


class _Submitter:
    """Starts a pool's local workers and submits jobs[first:] to them (map_streamed's
    _send_job) on a thread of its own, started at once: starting a worker waits for the
    forkserver to import the simulator, which this process need not wait for."""

    def __init__(self, pool: ProcessPoolExecutor, fn: Callable, jobs: list[tuple], first: int) -> None:
        self._submitted: list = []
        self._error: BaseException | None = None

        def submit() -> None:
            try:
                with stop_signals_blocked():  # the workers it starts leave Ctrl-C to the parent
                    for index in range(first, len(jobs)):
                        self._submitted.append(pool.submit(_send_job, fn, index, jobs[index]))
            except BaseException as error:  # noqa: BLE001  (raised on the caller's thread by futures())
                self._error = error

        self._thread = threading.Thread(target=submit, daemon=True, name="twin-pool-start")
        self._thread.start()

    def futures(self) -> list:
        """The submitted jobs' futures, once all are submitted (raises what submitting raised)."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._submitted


def _send_job(fn: Callable, index: int, job: tuple) -> None:
    """A streamed job's body in a local worker: fn(*job, send), each item sent as
    (index, item), then (index, _JobEnd())."""
    fn(*job, lambda item: _outbox.put((index, item)))
    _outbox.put((index, _JobEnd()))


def _collect(fn: Callable, job: tuple) -> list:
    """A streamed job's body where nothing streams (one process, Ray): its items as a list."""
    items: list = []
    fn(*job, items.append)
    return items


def _start_worker(parent_pid: int, outbox=None) -> None:
    """A local worker's start: one BLAS thread; Ctrl-C left to the parent, which keeps
    what the workers finish; the worker ends when its parent does, even one killed
    outright (SIGKILL: Linux's parent-death signal, and a thread that polls the parent).
    outbox: the queue map_streamed's jobs send their items on."""
    global _outbox
    _outbox = outbox
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


def one_render_thread() -> None:
    """Have Mesa's software renderer (llvmpipe) draw in the thread that renders, in this
    process and in those it starts later (they inherit the variable, which Mesa reads when
    a process first opens a GL display). Frames are the same bit for bit; a GPU driver
    ignores it.

    By default llvmpipe starts one rasterizer thread per CPU it may run on in every process
    that renders and hands each frame's raster work to them, so with one env process per
    core (gymnasium's async vector envs) every process's threads compete for every core.
    In one env on 2 cores they did 3.3 of a step's 15.5 ms CPU; drawn in the env's own
    thread, the step took 15.1 ms CPU (measured)."""
    os.environ["LP_NUM_THREADS"] = "0"


def _call_with_one_blas_thread(fn: Callable, *args):
    """Ray task body: `one_blas_thread`, then fn(*args)."""
    one_blas_thread()
    return fn(*args)
