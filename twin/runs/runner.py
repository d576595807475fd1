"""Recording open-loop protocols (render, taps, slides) on a scenario's backend (twin.runs.record).

Open-loop protocols (render, taps, slides) are split into independent chunks — one per
sensor orientation, each starting from a reset (no contact) — and the chunks run in
parallel over the local cores (or a Ray cluster, twin.runs.parallel). Every chunk starts from
the same reset state, so the samples do not depend on how chunks were distributed.
Samples are recorded in protocol order as soon as they are observed (a worker sends each
one to the parent while it runs the rest of its chunk).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from twin.control.contour import no_clock
from twin.core.environment import Environment, Observation
from twin.core.errors import WorkerLostError
from twin.core.scenario import Scenario
from twin.runs.backends import make_environment
from twin.runs.parallel import default_workers, map_streamed
from twin.runs.protocols import Move, protocol_moves
from twin.runs.record import RunRecorder, resume_hint
from twin.sensing.pins import PinReader


@dataclass
class Sample:
    """One recorded sample as produced by a worker (picklable)."""

    move: Move
    observation: Observation
    pins_px: np.ndarray
    found: np.ndarray | None
    track_ms: float
    rest_px: np.ndarray | None = None  # (127, 2) px: the chunk's pins at rest (tracker reference)


def chunk_moves(moves: list[Move]) -> list[list[Move]]:
    """Split a protocol into chunks that start out of contact: a new chunk begins at each
    change of sensor orientation (γ) but a turn in contact (`Move.in_contact_turn`)."""
    chunks: list[list[Move]] = []
    for move in moves:
        if not chunks or (move.pose.gamma != chunks[-1][-1].pose.gamma and not move.in_contact_turn):
            chunks.append([])
        chunks[-1].append(move)
    return chunks


def run_chunk(scenario: Scenario, seed: int, moves: list[Move], sink=None, skip: int = 0) -> list[Sample]:
    """Run one chunk in a fresh environment state (reset). Each sample goes to `sink` as
    soon as it is observed (serial runs record as they go); the samples not sunk are
    returned (parallel workers send their chunk back when it is done). The first `skip`
    samples are observed (the replay of a resumed run) but not returned."""
    samples = []
    for sample in stream_chunk(scenario, seed, moves, skip):
        if sink is None:
            samples.append(sample)
        else:
            sink(sample)
    return samples


def stream_chunk(scenario: Scenario, seed: int, moves: list[Move], skip: int = 0) -> Iterator[Sample]:
    """run_chunk's samples, each as soon as it is observed (the first `skip` observed, not yielded)."""
    for i, sample in enumerate(chunk_samples(worker_environment(scenario, seed), moves)):
        if i >= skip:
            yield sample


def send_chunk(scenario: Scenario, seed: int, moves: list[Move], skip: int, send) -> None:
    """run_chunk for a worker of twin.runs.parallel.map_streamed: each sample is sent as
    soon as it is observed, so the parent records a chunk's first frame while the rest
    of the chunk runs."""
    run_chunk(scenario, seed, moves, sink=send, skip=skip)


def chunk_samples(env: Environment, moves: list[Move], clock=no_clock) -> Iterator[Sample]:
    """The one open-loop chunk loop: reset (the tracker's reference), then each move; a
    recorded move yields its Sample right after it is observed. `clock(stage)` is charged
    with "physics" (the move into a recorded frame), "render" (observe) and "track"."""
    reader = PinReader(env.reset())
    for move in moves:
        if not move.record:
            env.move_to(move.pose, move.speed_mm_s)
            continue
        with clock("physics"):
            env.move_to(move.pose, move.speed_mm_s)
        with clock("render"):
            obs = env.observe()
        with clock("track"):
            pins, found, ms = reader.read(obs)
        yield Sample(move, obs, pins, found, ms, reader.rest_px)


_ENV_CACHE: dict = {}


def worker_environment(scenario: Scenario, seed: int) -> Environment:
    """One environment per process and scenario, reused across chunks (reset in between)."""
    key = (scenario.model_dump_json(), seed)
    if key not in _ENV_CACHE:
        close_worker_envs()
        _ENV_CACHE[key] = make_environment(scenario, seed)
    return _ENV_CACHE[key]


def close_worker_envs() -> None:
    """Close and forget this process's cached environments (see worker_environment)."""
    for env in _ENV_CACHE.values():
        env.close()
    _ENV_CACHE.clear()


def remaining_chunks(chunks: list[list[Move]], done: int) -> list[tuple[list[Move], int]]:
    """(chunk, samples of it already recorded) of every chunk not fully recorded when
    `done` samples of the protocol are."""
    left = []
    for chunk in chunks:
        n = sum(m.record for m in chunk)
        if done >= n:
            done -= n
            continue
        left.append((chunk, done))
        done = 0
    return left


def record_protocol(
    scenario: Scenario,
    out: Path,
    seed: int | None = None,
    workers: int | None = None,
    cluster: str | None = None,
    progress: bool = True,
    resume: bool = False,
) -> Path:
    """Run and record an open-loop scenario (render, taps, slides); returns the run
    directory. `resume`: continue the unfinished run in `out` (twin.runs.run.resume_run)."""

    seed = scenario.seed if seed is None else seed
    if scenario.protocol.kind == "contour":
        raise ValueError("contour runs are closed-loop: twin.runs.run.run_scenario dispatches them")
    moves = protocol_moves(scenario.protocol)
    chunks = chunk_moves(moves)
    n_samples = sum(m.record for m in moves)
    wall = time.perf_counter()
    recorder = (
        RunRecorder.resume(out)
        if resume
        else RunRecorder(out, scenario, seed, scenario.backend, scenario.camera_model())
    )
    try:
        with recorder:
            jobs = remaining_chunks(chunks, recorder.count)
            bar = tqdm(total=n_samples, initial=recorder.count, desc=scenario.name, unit="frame", disable=not progress)

            def record(s: Sample) -> None:
                recorder.set_rest_pins(s.rest_px)
                recorder.add(s.observation, s.move.pose, s.move.labels, s.pins_px, s.found)
                bar.update(1)

            serial = scenario.backend != "sim" or (cluster is None and (workers or default_workers()) <= 1)
            try:
                if serial:  # record each sample as it is observed
                    for chunk, skip in jobs:
                        run_chunk(scenario, seed, chunk, sink=record, skip=skip)
                else:  # record each sample as soon as its worker observes it, in protocol order
                    for s in map_streamed(  # this process runs the first chunk while the workers start
                        send_chunk,
                        [(scenario, seed, c, skip) for c, skip in jobs],
                        workers=workers,
                        cluster=cluster,
                        first_here=stream_chunk,
                    ):
                        record(s)
            finally:
                bar.close()
                close_worker_envs()
            recorder.meta["wall_time_s"] = time.perf_counter() - wall
    except WorkerLostError as lost:  # a transient loss (the out-of-memory killer): the run can go on
        raise lost.going_on(f"the run keeps its {recorder.count} samples: {resume_hint(Path(out))}") from lost
    return Path(out)
