"""Four of `twin compare`'s edge figures as rows, l = +5 ... -5 mm (or the l a subset has):
the signal ratio, θ_PC23's turn per mm of slide, drag / signal and the drag's rigid share;
for each, the recorded run's row, then each replay's. usage: figure_rows.py COMPARE_OUTPUT
(rows "real" and "twin"); figure_rows.py COMPARE_OUTPUT COMPARE_OUTPUT... (the recording
of the first, then a row per output, named by its file, under the l they cover)"""

import re
import sys
from pathlib import Path

HEADINGS = ("signal / its", "θ_PC23 turned", "drag / orientation", "rigid shift, %")


def block(lines: list[str], heading: str) -> list[list[str]]:
    """The rows under the first line holding `heading`: [l, recorded, replay] each."""
    start = next(k for k, line in enumerate(lines) if heading in line)
    rows = []
    for line in lines[start + 1 :]:
        m = re.match(r"\s+l ([+-]\d+) mm\s+(\S+)\s+(\S+)$", line)
        if not m:
            return rows
        rows.append([m[1], m[2], m[3]])
    return rows


outputs = [(Path(p).stem.removeprefix("compare-"), open(p).read().split("\n")) for p in sys.argv[1:]]
for heading in HEADINGS:
    blocks = [(name, block(lines, heading)) for name, lines in outputs]
    if len(blocks) == 1:
        rows = blocks[0][1]
        print(f"{heading[:14]:14s} real " + " ".join(f"{r[1]:>5s}" for r in rows))
        print(f"{'':14s} twin " + " ".join(f"{r[2]:>5s}" for r in rows))
        continue
    print(f"{heading[:14]:14s} {'l =':>28s} " + " ".join(f"{r[0]:>5s}" for r in blocks[0][1]))
    print(f"{'':14s} {'real':>28s} " + " ".join(f"{r[1]:>5s}" for r in blocks[0][1]))
    for name, rows in blocks:
        print(f"{'':14s} {name:>28s} " + " ".join(f"{r[2]:>5s}" for r in rows))
