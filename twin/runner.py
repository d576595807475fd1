"""`twin run`: execute a scenario on its backend and record it (twin.record).

Open-loop protocols (render, taps, slides) are split into independent chunks — one per
sensor orientation, each starting from a reset (no contact) — and the chunks run in
parallel over the local cores (or a Ray cluster, twin.parallel). Every chunk starts from
the same reset state, so the samples do not depend on how chunks were distributed.
Samples are recorded in protocol order as chunks complete.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from twin.env import Environment, Observation
from twin.errors import LostPinsError
from twin.protocols import Move, protocol_moves
from twin.record import RunRecorder
from twin.scenario import Scenario


@dataclass
class Sample:
    """One recorded sample as produced by a worker (picklable)."""

    move: Move
    observation: Observation
    pins_px: np.ndarray
    found: np.ndarray | None
    track_ms: float


def make_environment(scenario: Scenario, seed: int | None = None, hardware_config: str | None = None) -> Environment:
    """The scenario's backend behind the Environment interface."""
    if scenario.backend == "hardware":
        from hardware.env import HardwareEnvironment

        return HardwareEnvironment.from_scenario(scenario, hardware_config)
    from twin.sim_env import SimEnvironment

    return SimEnvironment(scenario, seed=seed)


class PinReader:
    """Turns observations into pins: tracked from frames, or taken as projected.

    A frame with more than `max_lost_fraction` of its pins untracked stops the run with
    LostPinsError (a torn skin, a covered lens or a camera that moved)."""

    max_lost_fraction = 0.2

    def __init__(self, reference: Observation) -> None:
        self.tracker = None
        if reference.frame is not None:
            from twin.tracker import PinTracker

            self.tracker = PinTracker(reference.frame)

    def read(self, obs: Observation) -> tuple[np.ndarray, np.ndarray | None, float]:
        if obs.frame is None or self.tracker is None:
            return obs.pins_px, None, 0.0
        result = self.tracker.track(obs.frame)
        lost = int((~result.found).sum())
        if lost > self.max_lost_fraction * len(result.found):
            reasons = sorted({r for r in result.reasons if r})
            raise LostPinsError(f"lost {lost}/{len(result.found)} pins at pose {obs.pose} ({', '.join(reasons)}); "
                                "check the camera and the skin")
        return result.pins_px, result.found, result.ms


def chunk_moves(moves: list[Move]) -> list[list[Move]]:
    """Split a protocol into chunks that start out of contact: a new chunk begins at each
    change of sensor orientation (γ)."""
    chunks: list[list[Move]] = []
    for move in moves:
        if not chunks or move.pose.gamma != chunks[-1][-1].pose.gamma:
            chunks.append([])
        chunks[-1].append(move)
    return chunks


def run_chunk(scenario: Scenario, seed: int, moves: list[Move], sink=None) -> list[Sample]:
    """Run one chunk in a fresh environment state (reset). Each sample goes to `sink` as
    soon as it is observed (serial runs record as they go); the samples not sunk are
    returned (parallel workers send their chunk back when it is done)."""
    env = _worker_env(scenario, seed)
    reader = PinReader(env.reset())
    samples = []
    for move in moves:
        env.move_to(move.pose, move.speed_mm_s)
        if move.record:
            obs = env.observe()
            pins, found, ms = reader.read(obs)
            sample = Sample(move, obs, pins, found, ms)
            if sink is None:
                samples.append(sample)
            else:
                sink(sample)
    return samples


_ENV_CACHE: dict = {}


def _worker_env(scenario: Scenario, seed: int) -> Environment:
    """One environment per process and scenario, reused across chunks (reset in between)."""
    key = (scenario.model_dump_json(), seed)
    if key not in _ENV_CACHE:
        close_worker_envs()
        _ENV_CACHE[key] = make_environment(scenario, seed)
    return _ENV_CACHE[key]


def close_worker_envs() -> None:
    """Close and forget this process's cached environments (see _worker_env)."""
    for env in _ENV_CACHE.values():
        env.close()
    _ENV_CACHE.clear()


def run_scenario(scenario: Scenario, out: Path, seed: int | None = None, workers: int | None = None,
                 cluster: str | None = None, progress: bool = True) -> Path:
    """Run and record a scenario; returns the run directory."""
    from twin.parallel import default_workers, map_ordered

    seed = scenario.seed if seed is None else seed
    if scenario.protocol.kind == "contour":
        from twin.contour import run_contour

        return run_contour(scenario, out, seed=seed, progress=progress)
    moves = protocol_moves(scenario.protocol)
    chunks = chunk_moves(moves)
    n_samples = sum(m.record for m in moves)
    from twin.scene import camera_model

    wall = time.perf_counter()
    with RunRecorder(out, scenario, seed, scenario.backend, camera_model(scenario)) as recorder:
        bar = tqdm(total=n_samples, desc=scenario.name, unit="frame", disable=not progress)

        def record(s: Sample) -> None:
            recorder.add(s.observation, s.move.pose, s.move.labels, s.pins_px, s.found)
            bar.update(1)

        serial = scenario.backend != "sim" or (cluster is None and (workers or default_workers()) <= 1)
        try:
            if serial:  # record each sample as it is observed
                for chunk in chunks:
                    run_chunk(scenario, seed, chunk, sink=record)
            else:  # record each chunk as its worker finishes it, in protocol order
                for chunk_samples in map_ordered(run_chunk, [(scenario, seed, c) for c in chunks],
                                                 workers=workers, cluster=cluster):
                    for s in chunk_samples:
                        record(s)
        finally:
            bar.close()
            if serial:
                close_worker_envs()
        recorder.meta["wall_time_s"] = time.perf_counter() - wall
    return Path(out)
