"""Two recorded runs of one scenario side by side: which of their samples are compared."""
from __future__ import annotations

import numpy as np

from twin.core.errors import UserError
from twin.runs.record import Run

POSE_DECIMALS = 3  # targets are paired when equal to 1e-3 mm / deg


def pair_samples(a: Run, b: Run) -> list[tuple[int, int]]:
    """Index pairs (i in a, j in b) with the same target pose; each target used once, in order."""
    index: dict[tuple, list[int]] = {}
    for j, s in enumerate(b.samples):
        index.setdefault(tuple(np.round(s["target"], POSE_DECIMALS)), []).append(j)
    pairs = []
    for i, s in enumerate(a.samples):
        bucket = index.get(tuple(np.round(s["target"], POSE_DECIMALS)))
        if bucket:
            pairs.append((i, bucket.pop(0)))
    return pairs


def paired_runs(a: Run, b: Run) -> tuple[list[tuple[int, int]], str]:
    """The sample pairs (i in a, j in b) two runs are compared on, and how they were
    paired: closed-loop (contour) runs by step, since their targets differ; the others by
    target pose (pair_samples). Raises UserError when they share none."""
    if a.meta["scenario"]["protocol"]["kind"] == "contour":
        pairs, pairing = [(i, i) for i in range(min(len(a.samples), len(b.samples)))], "by step (closed loop: targets differ)"
    else:
        pairs, pairing = pair_samples(a, b), "by target pose"
    if not pairs:
        raise UserError(f"{a.path} and {b.path} share no target poses: are they runs of the same scenario?")
    return pairs, pairing
