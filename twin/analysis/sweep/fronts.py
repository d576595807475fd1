"""The sweep's Pareto fronts: which settings no peer beats in time and accuracy together,
with noise margins; time compared round by round of the timing pass."""

from __future__ import annotations

import math

from twin.analysis.sweep.knobs import BASE_DOME, DEFAULT
from twin.runs.contour_metrics import COMPLETED_STOPS

#: Accuracy columns measured against the dome's own reference (compared within a dome only).
PIN_METRICS: tuple[str, ...] = ("pin_rms_px", "pin_physics_rms_px", "pin_settling_rms_px")
#: Noise margins of the Pareto dominance test: relative time, relative and absolute error.
TIME_MARGIN = 0.05
ERROR_MARGIN_REL = 0.02
#: pin_settling_rms_px: the smallest settling difference that changes anything downstream.
#: The measure itself resolves ≈ 0.01 px (halving converged_pins' band moved it by
#: 0.003–0.010 px), but below 0.05 px a settle tolerance is invisible: the tracker reads
#: rendered pins to 0.08 px RMS, the pin error against the reference is ≈ 2 px either way
#: (2.14 px at the default 0.1 px band and at 0.05 px), and a frictionless slide ends
#: 9 / 13 / 18 µm (≈ 0.1–0.2 px) from the static press at settle 0.025 / 0.05 / 0.1 px
#: (tests/world/test_dome.py asks < 20 µm). Settle ×2 (0.28 vs 0.12 px) stays distinguishable.
ERROR_MARGIN_ABS = {"pin_rms_px": 0.02, "pin_settling_rms_px": 0.05, "theta_rms_deg": 0.5, "contour_completed_mm": 0.1}


#: The Pareto fronts: (row flag, accuracy columns weighed together against time). The first
#: is the primary front; its columns (`PRIMARY`) are every physics-accuracy figure.
FRONTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("on_front", ("pin_rms_px", "pin_settling_rms_px")),
    ("on_front_theta", ("theta_rms_deg",)),
    ("on_front_contour", ("contour_completed_mm",)),
)
PRIMARY: tuple[str, ...] = FRONTS[0][1]


def metric_tuple(metrics: str | tuple[str, ...]) -> tuple[str, ...]:
    return (metrics,) if isinstance(metrics, str) else tuple(metrics)


def is_finite_number(v) -> bool:
    """A real int or float (not a bool) that is finite."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def dominates(a: dict, b: dict, metrics: str | tuple[str, ...] = PRIMARY) -> bool:
    """True when setting `a` is clearly better than `b` in total_ms and the error column(s)
    `metrics`: no slower and no less accurate in *every* one within the noise margins, and
    better beyond them in at least one.

    Margins: TIME_MARGIN (relative) on time; on an error the larger of ERROR_MARGIN_REL
    (relative) and ERROR_MARGIN_ABS[column] (absolute, the column's unit). Time: where
    both rows have the timing pass's rounds (`round_ms`), `a` is no slower only if it is
    within the margin in every round, and faster only if it is faster beyond it in every
    round, each round against the other setting's same round (`_time_ratios`); otherwise
    best against best. A column neither row has (a sweep.json from before it existed) is
    left out; one that only one row has makes them incomparable (False)."""
    ta, tb = a.get("total_ms"), b.get("total_ms")
    if not (is_finite_number(ta) and is_finite_number(tb)):
        return False
    slowest = max(_time_ratios(a, b))
    no_worse, better, compared = slowest <= 1 + TIME_MARGIN, slowest < 1 - TIME_MARGIN, False
    for metric in metric_tuple(metrics):
        ea, eb = a.get(metric), b.get(metric)
        if ea is None and eb is None:
            continue
        if not (is_finite_number(ea) and is_finite_number(eb)):
            return False
        e_tol = max(ERROR_MARGIN_REL * abs(eb), ERROR_MARGIN_ABS.get(metric, 0.0))
        no_worse = no_worse and ea <= eb + e_tol
        better = better or ea < eb - e_tol
        compared = True
    return compared and no_worse and better


def _time_ratios(a: dict, b: dict) -> list[float]:
    """`a`'s time over `b`'s: per round of the timing pass where both rows have the same
    rounds (`round_ms`: the host's drift between rounds moves both alike, so only a
    difference that holds in every round is the settings'), else total_ms against
    total_ms. On the sweep's host one setting's ratio to the default spread over
    0.87–1.24 across three rounds, far more than TIME_MARGIN: best against best alone
    then let a setting doing strictly more work per frame dominate the default."""
    ra, rb = a.get("round_ms"), b.get("round_ms")
    if isinstance(ra, list) and isinstance(rb, list) and ra and len(ra) == len(rb):
        return [x / y for x, y in zip(ra, rb)]
    return [a["total_ms"] / b["total_ms"]]


def pareto_flags(
    rows: list[dict], metrics: str | tuple[str, ...] = PRIMARY, by_output: bool = True
) -> list[bool | None]:
    """Per row: on the front of total_ms against the error column(s) `metrics` (`dominates`)
    (None: a failed row, or no time or first-column figure; failed settings are no
    alternative, so they neither sit on a front nor push others off).

    by_output: compare only peer rows (`peers`: same output kind and camera); pin metrics
    always compare rows of one dome only."""
    first = metric_tuple(metrics)[0]
    flags: list[bool | None] = []
    ok = [r for r in rows if r.get("status") == "ok"]
    for b in rows:
        if b.get("status") != "ok" or not (is_finite_number(b.get("total_ms")) and is_finite_number(b.get(first))):
            flags.append(None)
            continue
        rivals = [
            a for a in ok if a is not b and (peers(a, b, metrics) if by_output else _same_dome_if_pins(a, b, metrics))
        ]
        flags.append(not any(dominates(a, b, metrics) for a in rivals))
    return flags


def peers(a: dict, b: dict, metrics: str | tuple[str, ...] = PRIMARY) -> bool:
    """Whether two rows compete on the front of `metrics`: same output kind ('frames' or
    'pins') and, for frames, the same camera resolution (module docstring); for a pin
    metric (PIN_METRICS, measured against each dome's own reference) also the same dome."""
    return a["output"] == b["output"] and a.get("camera") == b.get("camera") and _same_dome_if_pins(a, b, metrics)


def _same_dome_if_pins(a: dict, b: dict, metrics: str | tuple[str, ...]) -> bool:
    """Pin metrics compare rows of one dome only (PIN_METRICS); other metrics any two rows."""
    pin = any(m in PIN_METRICS for m in metric_tuple(metrics))
    return not pin or a.get("dome", BASE_DOME) == b.get("dome", BASE_DOME)


def dominators(rows: list[dict], row: dict, metrics: str | tuple[str, ...] = PRIMARY) -> list[str]:
    """Names of the ok peer settings (`peers`) that dominate `row` in total_ms and `metrics`."""
    return [
        a["setting"]
        for a in rows
        if a is not row and a.get("status") == "ok" and peers(a, row, metrics) and dominates(a, row, metrics)
    ]


def annotate_fronts(rows: list[dict]) -> list[dict]:
    """Set on_front / on_front_theta / on_front_contour (FRONTS, per output kind),
    on_front_all (PRIMARY, all kinds together) and dominated_by (primary front) on every row,
    and the contour front's figure, contour_completed_mm: the contour error of a run that
    completed the contour (COMPLETED_STOPS), infinite for one that did not, which is no
    alternative however fast."""
    for row in rows:
        if is_finite_number(row.get("contour_path_mean_mm")):
            completed = row.get("contour_stop") in COMPLETED_STOPS
            row["contour_completed_mm"] = row["contour_path_mean_mm"] if completed else math.inf
    for key, metrics in FRONTS:
        for row, flag in zip(rows, pareto_flags(rows, metrics)):
            row[key] = flag
    for row, flag in zip(rows, pareto_flags(rows, PRIMARY, by_output=False)):
        row["on_front_all"] = flag
    for row in rows:
        row["dominated_by"] = " ".join(dominators(rows, row)) if row.get("on_front") is False else ""
    return rows


def default_on_front(rows: list[dict]) -> bool | None:
    """Whether the default setting is on the primary front (None: no default row or no figures)."""
    row = next((r for r in rows if r["setting"] == DEFAULT), None)
    return None if row is None else row.get("on_front")
