"""Four of `twin compare`'s edge figures as two rows each (the recorded run's, the
replay's), l = +5 ... -5 mm: the signal ratio, θ_PC23's turn per mm of slide, drag /
signal and the drag's rigid share. usage: figure_rows.py COMPARE_OUTPUT"""

import sys

lines = open(sys.argv[1]).read().split("\n")
for heading in ("signal / its", "θ_PC23 turned", "drag / orientation", "rigid shift, %"):
    start = next(k for k, line in enumerate(lines) if heading in line)
    rows = [line.split() for line in lines[start + 1 : start + 12]]
    print(f"{heading[:14]:14s} real " + " ".join(f"{r[-2]:>5s}" for r in rows))
    print(f"{'':14s} twin " + " ".join(f"{r[-1]:>5s}" for r in rows))
