"""The edge figures of `twin compare` outputs side by side, one column per replay: the
recording's value and each replay's, per l. usage: spacing_table.py COMPARE.txt [...]"""

import re
import sys

FIGURES = {
    "signal / l = 0's": "orientation signal / its value at l = 0",
    "signal, px": "orientation signal, px:",
    "drag / signal": "drag / orientation signal",
    "θ_PC23, °/mm": "θ_PC23 turned",
    "rigid share, %": "drag energy in a rigid shift, %:",
}


def blocks(path):
    """{header: {l: (recorded, replay)}} of one compare output."""
    lines = open(path).read().splitlines()
    out = {}
    for name, head in FIGURES.items():
        for i, line in enumerate(lines):
            if head in line:
                rows = {}
                for row in lines[i + 1 :]:
                    m = re.match(r"\s+l ([+-]\d+) mm\s+(\S+)\s+(\S+)$", row)
                    if not m:
                        break
                    rows[int(m[1])] = (m[2], m[3])
                out[name] = rows
                break
    return out


runs = [(p.split("compare-")[-1].removesuffix(".txt"), blocks(p)) for p in sys.argv[1:]]
for name in FIGURES:
    if name not in runs[0][1]:
        continue
    ls = sorted(runs[0][1][name], reverse=True)
    print(f"{name:26s} l = " + " ".join(f"{l:+6d}" for l in ls))
    print(f"{'  real':30s} " + " ".join(f"{runs[0][1][name][l][0]:>6s}" for l in ls))
    for label, b in runs:
        print(f"  {label:28s} " + " ".join(f"{b[name].get(l, ('', '—'))[1]:>6s}" for l in ls))
