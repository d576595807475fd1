"""A `twin calibrate` report's edge-figure table summed up as screen_summary.py sums up a
replay (../finding-2026-12-05-across-fit/): geometric-mean twin / recording of the along-
and across-edge turns onto (l < 0) and off (l > 0) the object, their ratio onto the object,
drag / signal, the signal ratios' mean difference and the figures within tolerance, for
the report's "before" and "after" columns.

    python report_summary.py REPORT.md
"""

import math
import sys

import numpy as np


def rows(path: str) -> list[dict]:
    """The edge-figure table's rows: figure, l, recorded, and per column its value and miss."""
    found = []
    for line in open(path, encoding="utf-8"):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 10 or cells[1] in ("figure", "---"):
            continue
        number = lambda text: math.nan if text in ("–", "-") else float(text)  # noqa: E731
        found.append(
            {
                "figure": cells[1],
                "l": float(cells[2]),
                "recorded": float(cells[3]),
                "before": (number(cells[5]), float(cells[6])),
                "after": (number(cells[7]), float(cells[8])),
            }
        )
    return found


def gm(values: list[float]) -> float:
    values = [v for v in values if math.isfinite(v)]
    return math.exp(np.mean(np.log(values))) if values else math.nan


table = rows(sys.argv[1])
print(
    f"{'column':8s} {'along -':>8s} {'along +':>8s} {'across -':>9s} {'across +':>9s} {'ratio -':>8s} "
    f"{'drag/sig':>9s} {'signal Δ':>9s} {'within':>7s} {'missing':>8s}"
)


def ratio(column: str, figure: str, sign: int) -> float:
    """Geometric-mean twin / recording of `figure` in `column` on one side (sign −1: onto the object)."""
    return gm(
        [
            r[column][0] / r["recorded"]
            for r in table
            if r["figure"] == figure and np.sign(r["l"]) == sign and r["recorded"] > 0
        ]
    )


for column in ("before", "after"):
    along_onto, across_onto = ratio(column, "theta_pc23", -1), ratio(column, "theta_pc23_across", -1)
    drag = gm([r[column][0] / r["recorded"] for r in table if r["figure"] == "drag/signal"])
    signal = np.nanmean([r[column][0] - r["recorded"] for r in table if r["figure"] == "signal"])
    within = sum(abs(r[column][1]) <= 1.0 for r in table)
    missing = sum(not math.isfinite(r[column][0]) for r in table)
    print(
        f"{column:8s} {along_onto:8.2f} {ratio(column, 'theta_pc23', 1):8.2f} {across_onto:9.2f} "
        f"{ratio(column, 'theta_pc23_across', 1):9.2f} {across_onto / along_onto:8.2f} {drag:9.2f} {signal:+9.2f} "
        f"{within:4d}/{len(table)} {missing:8d}"
    )
print("(ratio −: the across / along turn onto the object over the recording's; 1 = the recording's anisotropy)")
