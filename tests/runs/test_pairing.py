"""Which samples of two runs are the same: twin.runs.pairing on runs built by hand."""

from __future__ import annotations

from pathlib import Path

from twin.runs.pairing import pair_samples, shared_taps
from twin.runs.record import Run


def _run(taps: list[dict], depth_mm: float = 4.0, first_tap: int = 0) -> Run:
    """A no-contact frame, then one sample per tap at target x = its position in `taps` (mm)."""
    samples = [{"target": [-10.0, 0, -5, 0, 0, 0], "labels": {"lateral_mm": 9.9, "theta_deg": 0.0, "no_contact": True}}]
    for k, tap in enumerate(taps):
        labels = {**tap, "depth_mm": depth_mm + tap["depth_offset_mm"], "tap": first_tap + k}
        samples.append({"target": [float(k), 0, 3, 0, 0, 0], "labels": labels})
    return Run(Path("hand"), {"scenario": {"name": "hand", "protocol": {"kind": "sheared_taps"}}}, samples)


TAPS = [
    {
        "lateral_mm": 1.5,
        "theta_deg": 10.0,
        "depth_offset_mm": 0.2,
        "slide_along_mm": 1.0,
        "slide_lateral_mm": 0.0,
        "twist_deg": 2.0,
    },
    {
        "lateral_mm": -2.0,
        "theta_deg": -30.0,
        "depth_offset_mm": -0.4,
        "slide_along_mm": 0.5,
        "slide_lateral_mm": 0.1,
        "twist_deg": 0.0,
    },
    {
        "lateral_mm": 4.0,
        "theta_deg": 45.0,
        "depth_offset_mm": 0.0,
        "slide_along_mm": -2.0,
        "slide_lateral_mm": 0.0,
        "twist_deg": -4.0,
    },
]


def test_a_replay_shares_its_taps_whatever_their_index_or_nominal_depth() -> None:
    """A replay numbers its taps from 0 and may press at another nominal depth: the taps
    are still the recording's (their pose and motion labels), the no-contact frame too."""
    recording = _run(TAPS, first_tap=3747)
    replay = _run(TAPS, depth_mm=3.0)
    assert shared_taps(recording, replay) == pair_samples(recording, replay) == [(0, 0), (1, 1), (2, 2), (3, 3)]


def test_taps_at_the_same_targets_with_other_labels_are_not_shared() -> None:
    """Another run that happens to use the same targets (its own taps): only the taps whose
    labels agree are shared; a slide or an angle that differs makes another tap."""
    other = [dict(TAPS[0]), {**TAPS[1], "slide_along_mm": 0.6}, {**TAPS[2], "theta_deg": 44.0}]
    a, b = _run(TAPS), _run(other)
    assert len(pair_samples(a, b)) == 4
    assert shared_taps(a, b) == [(0, 0), (1, 1)]
