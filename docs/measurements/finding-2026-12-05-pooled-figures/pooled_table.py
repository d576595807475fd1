"""The pooled edge figures of `twin compare` runs (comparison.json's "pooled" and
"pooled_in_a_plane"), one row per run and side of the edge: the signal ratio's B − A ± its
error, the other figures' B / A ×÷ the factor of one error.
usage: python pooled_table.py NAME=CMP_DIR [NAME=CMP_DIR ...]"""

import json
import math
import sys
from pathlib import Path

COLUMNS = (  # (heading, "pooled" or "pooled_in_a_plane", figure)
    ("signal, B − A", "pooled", "signal"),
    ("θ_PC23 along, in the recording's plane", "pooled_in_a_plane", "theta_pc23"),
    ("θ_PC23 across, in the recording's plane", "pooled_in_a_plane", "theta_pc23_across"),
    ("drag / signal", "pooled", "drag/signal"),
    ("θ_PC23 along, in its own plane", "pooled", "theta_pc23"),
)


def cell(figure: str, pooled: dict | None) -> str:
    if pooled is None:
        return "–"
    if figure == "signal":
        return f"{pooled['difference']:+.2f} ± {pooled['error']:.2f}"
    return f"{math.exp(pooled['difference']):.2f} ×÷ {math.exp(pooled['error']):.2f}"


print("| run | side | " + " | ".join(h for h, *_ in COLUMNS) + " |")
print("|---|---|" + "---|" * len(COLUMNS))
for arg in sys.argv[1:]:
    name, folder = arg.split("=", 1)
    differences = json.loads((Path(folder) / "comparison.json").read_text())["edge_figure_differences"]
    for side in ("onto", "off"):
        cells = [cell(f, differences[key].get(f, {}).get(side)) for _, key, f in COLUMNS]
        print(f"| {name} | {side} | " + " | ".join(cells) + " |")
