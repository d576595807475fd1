"""Replaying a recorded run in the simulator: the pin tips the twin gives at the run's own
target poses, reached along the run's own path (friction makes the pins path-dependent).

Open-loop runs (render, taps, slides) replay their protocol's moves, split into the
runner's chunks (each from a reset, so chunks run in parallel and in any order); a
contour run replays its recorded targets in order from a hover over the first (the
closed loop chose them; replaying them is what the robot did). Used by `twin calibrate`.
"""

from __future__ import annotations

import numpy as np

from twin.core.poses import Pose
from twin.core.scenario import Scenario, hover_over
from twin.runs.protocols import Move, protocol_moves
from twin.runs.record import Run
from twin.runs.runner import chunk_moves, worker_environment


def replay_chunks(run: Run, scenario: Scenario) -> list[list[Move]]:
    """The run's moves as independent chunks (recorded moves marked `record`). `scenario`
    is the run's own scenario (run.json), validated."""
    protocol = scenario.protocol
    if protocol.kind != "contour":
        return chunk_moves(protocol_moves(protocol))
    targets = [Pose.from_array(s["target"]) for s in run.samples]
    if not targets:
        return []
    first = targets[0]
    moves = [Move(hover_over(first.x, first.y, first.gamma), protocol.speed_mm_s)]
    moves += [Move(t, protocol.speed_mm_s, True) for t in targets]
    return [moves]


def replay_chunk(scenario: Scenario, seed: int, moves: list[Move]) -> tuple[np.ndarray, np.ndarray]:
    """Run one chunk in the simulator from a reset: (targets (n, 6) mm/deg, pin tips
    (n, 127, 3) m, tool frame) of its recorded moves. The scenario's backend must be
    `sim`; one environment per process and scenario is reused (runner)."""
    env = worker_environment(scenario, seed)
    env.reset()
    targets, pins = [], []
    for move in moves:
        env.move_to(move.pose, move.speed_mm_s)
        if move.record:
            targets.append(move.pose.as_array())
            pins.append(env.pins_tool.copy())
    return np.array(targets).reshape(-1, 6), np.array(pins).reshape(-1, 127, 3)


def replay_batch(scenario: Scenario, seed: int, chunks: list[list[Move]]) -> list[tuple[np.ndarray, np.ndarray]]:
    """replay_chunk for several chunks in one job (one environment built for all of them)."""
    return [replay_chunk(scenario, seed, moves) for moves in chunks]
