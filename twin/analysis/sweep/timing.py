"""The sweep's timing pass: after the parallel accuracy jobs, every setting alone on the
machine, in rounds, its CPU ms per frame (physics, render, tracking) and its ratio to the
default's within each round."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from twin.analysis.sweep.knobs import DEFAULT, Setting
from twin.analysis.sweep.probe import STAGES, Probe, Stages, open_loop
from twin.runs.protocols import protocol_moves
from twin.runs.sim_env import SimEnvironment

#: The timing pass (`time_settings`): best of this many rounds (full, quick sweep), after
#: an untimed one, over the slide probe's first TIMING_ORIENTATIONS orientations.
TIMING_REPEATS = (3, 2)
TIMING_ORIENTATIONS = 2


TIMED_STAGES: tuple[str, ...] = ("physics", "render", "track")


def timing_pass(setting: Setting, probe: Probe, seed: int = 0) -> dict:
    """{physics,render,track}_ms (CPU ms per frame) and n_timed_frames of one pass of
    `setting` over the timing probe (the slide probe's first TIMING_ORIENTATIONS
    orientations) on a fresh environment."""
    timing = replace(probe, slide_orientations_deg=probe.slide_orientations_deg[:TIMING_ORIENTATIONS])
    moves = protocol_moves(setting.scenario(timing.slides(), seed).protocol)
    env = SimEnvironment(setting.scenario(timing.contour(), seed), seed=seed)
    stages = Stages()
    try:
        open_loop(env, moves, stages)
    finally:
        env.close()
    per_frame = stages.ms_per_frame()
    return {**{f"{k}_ms": per_frame[f"{k}_ms"] for k in TIMED_STAGES}, "n_timed_frames": stages.calls["physics"]}


def time_settings(
    settings: list[Setting],
    rows: list[dict],
    probe: Probe,
    seed: int = 0,
    repeats: int = TIMING_REPEATS[0],
    verbose: bool = False,
) -> None:
    """The timing pass, into `rows` (one per setting; those not "ok" are skipped). After
    the parallel accuracy jobs, in this one process, so that no other job competes for
    the cores (timed inside the parallel jobs, physics-identical settings spread over
    12–18 ms per frame). In rounds: an untimed round (each dome model's first run in a
    process loads what it caches: influence matrices, compiled kernels, GL contexts), then
    `repeats` rounds, each running every setting once (`timing_pass`), so that a host that
    speeds up or slows down during the pass moves every setting alike. Sets each stage's
    best (min over rounds) as {stage}_ms, n_timed_frames, each round's physics + render +
    tracking as round_ms (what `dominates` compares round by round), and against the default in the
    same run (NaN without it): time_x_default (physics + render + tracking, best against
    best), physics_x_default, and each one's lowest and highest ratio within one round
    (`*_x_default_min`, `*_x_default_max`: how far one run's ratio can be trusted). A
    setting whose pass raises is recorded as failed in the "timing" stage."""
    live = [i for i, r in enumerate(rows) if r["status"] == "ok"]
    passes: dict[int, list[dict]] = {i: [] for i in live}
    for round_ in range(-1, repeats):  # round −1 untimed
        for i in live:
            if rows[i]["status"] != "ok":
                continue
            try:
                result = timing_pass(settings[i], probe, seed)
            except Exception as err:  # recorded like a failed probe (module doc)
                rows[i].update(status="failed", stage="timing", error=f"{type(err).__name__}: {err}"[:400])
                continue
            if round_ >= 0:
                passes[i].append(result)
        if verbose and round_ >= 0:
            print(f"[timing round {round_ + 1}/{repeats}] done", flush=True)
    names = [s.name for s in settings]
    default = names.index(DEFAULT) if DEFAULT in names and rows[names.index(DEFAULT)]["status"] == "ok" else None

    def per_round(i: int, stages: tuple[str, ...]) -> np.ndarray:
        return np.array([sum(p[f"{k}_ms"] for k in stages) for p in passes[i]])

    for i in live:
        row = rows[i]
        if row["status"] != "ok":
            continue
        for key in TIMED_STAGES:
            row[f"{key}_ms"] = min(p[f"{key}_ms"] for p in passes[i])
        row["n_timed_frames"] = passes[i][0]["n_timed_frames"]
        row["total_ms"] = float(sum(row[f"{k}_ms"] for k in STAGES))
        row["round_ms"] = [float(t) for t in per_round(i, TIMED_STAGES)]
        for name, stages in (("time", TIMED_STAGES), ("physics", ("physics",))):
            if default is None:
                row[f"{name}_x_default"] = row[f"{name}_x_default_min"] = row[f"{name}_x_default_max"] = math.nan
                continue
            mine, theirs = per_round(i, stages), per_round(default, stages)
            row[f"{name}_x_default"] = float(mine.min() / theirs.min())
            row[f"{name}_x_default_min"], row[f"{name}_x_default_max"] = (
                float((mine / theirs).min()),
                float((mine / theirs).max()),
            )
        if verbose:
            print(
                f"[timing] {row['setting']:18s} {row['total_ms']:7.1f} ms/frame  ×{row['time_x_default']:.2f} "
                f"of the default ({row['time_x_default_min']:.2f}–{row['time_x_default_max']:.2f} within a round)",
                flush=True,
            )
