"""Which samples of two runs are the same sample: paired by target pose (a replay of a
recording visits its targets), and, for taps, the same tap (its pose and motion labels)."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from twin.core.scenario import SHEARED_TAP_MOTION
from twin.runs.record import Run

POSE_TOLERANCE = 1e-3  # targets are paired when equal to within 1e-3 mm / deg in every coordinate
#: the labels that make a tap the tap it is (where both samples have them): not its index
#: in its run, nor its nominal depth (a replay at another nominal depth keeps its taps)
TAP_LABELS = ("theta_deg", "lateral_mm", "depth_offset_mm", *SHEARED_TAP_MOTION)
LABEL_TOLERANCE = 1e-6  # mm / deg: a replay carries its record's labels unchanged


def pair_samples(a: Run, b: Run) -> list[tuple[int, int]]:
    """Index pairs (i in a, j in b) with the same target pose (within POSE_TOLERANCE in every
    coordinate); each target used once, in order. A tolerance, not rounding: a record's
    targets are written to 7 significant digits, and rounding a replayed 41.37949958° and
    its record's 41.3795° to 1e-3 gave 41.379 against 41.380."""
    targets_b = np.array([s["target"] for s in b.samples], float).reshape(-1, 6)
    if not len(targets_b):
        return []
    tree = cKDTree(targets_b)
    used = np.zeros(len(targets_b), bool)
    pairs = []
    for i, s in enumerate(a.samples):
        for j in sorted(tree.query_ball_point(np.asarray(s["target"], float), POSE_TOLERANCE, p=np.inf)):
            if not used[j]:
                used[j] = True
                pairs.append((i, j))
                break
    return pairs


def _same_tap(a: dict, b: dict) -> bool:
    if bool(a.get("no_contact")) != bool(b.get("no_contact")):
        return False
    for key in TAP_LABELS:
        va, vb = a.get(key), b.get(key)
        if va is None or vb is None:
            continue
        if not (math.isfinite(va) and math.isfinite(vb)) or abs(va - vb) > LABEL_TOLERANCE:
            return False
    return True


def shared_taps(a: Run, b: Run, pairs: list[tuple[int, int]] | None = None) -> list[tuple[int, int]]:
    """The pairs of `pair_samples` that are the same tap in both runs (`TAP_LABELS` equal
    within LABEL_TOLERANCE), in a's order: the taps a replay shares with its recording.
    Runs whose targets coincide but whose taps differ share none. `pairs`: the runs'
    `pair_samples`, where the caller has them."""
    pairs = pair_samples(a, b) if pairs is None else pairs
    return [(i, j) for i, j in pairs if _same_tap(a.samples[i]["labels"], b.samples[j]["labels"])]
