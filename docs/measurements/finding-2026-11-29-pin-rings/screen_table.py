"""The screen's table from `twin compare` outputs (REAL beside each replay) and the pin
misfit lines: one row per replay with the figures the finding weighs.
usage: screen_table.py MISFIT_FILE COMPARE_FILE...  (the replay's name: the compare's B column)"""

import re
import sys


def rows(lines: list[str], heading: str) -> dict[str, tuple[str, str]]:
    """{l: (real, replay)} of a per-l block of `twin compare`'s edge figures."""
    start = next(k for k, line in enumerate(lines) if heading in line)
    table = {}
    for line in lines[start + 1 : start + 12]:
        parts = line.split()
        table[parts[1]] = (parts[-2], parts[-1])
    return table


def reach(lines: list[str], at: str) -> tuple[str, str]:
    start = next(k for k, line in enumerate(lines) if line.startswith(f"  reach at l {at} mm"))
    return lines[start + 1].split()[-1], lines[start + 2].split()[-1]


def cells(table: dict[str, tuple[str, str]], laterals: tuple[str, ...], column: int) -> str:
    return " / ".join(table[l][column] for l in laterals)


misfit = {}
for line in open(sys.argv[1]).read().splitlines():
    m = re.match(r"(\S+)\s+edge normal.*misfit ([\d.]+) px, less each frame's mean ([\d.]+) px", line)
    if m:
        misfit[m.group(1).removesuffix("_k4")] = f"{m.group(2)} / {m.group(3)}"
print(
    "| replay | pin misfit / less mean, px | signal +5 / −3 / −4 | θ_PC23 °/mm +4 / 0 / −2 / −4 | reach's last bin −4.5 / +4.5 | drag's rigid share, % |"
)
print("|---|---|---|---|---|---|")
real_done = False
for path in sys.argv[2:]:
    lines = open(path).read().splitlines()
    name = lines[[k for k, l in enumerate(lines) if l.startswith("edge figures")][0]].split("B: ")[-1].strip()
    signal = rows(lines, "signal / its")
    theta = rows(lines, "θ_PC23 turned")
    rigid = rows(lines, "rigid shift, %:")
    far, near = reach(lines, "-4.5"), reach(lines, "+4.5")
    if not real_done:
        print(
            f"| real | — | {cells(signal, ('+5', '-3', '-4'), 0)} | {cells(theta, ('+4', '+0', '-2', '-4'), 0)} | {far[0]} / {near[0]} | {rigid['+0'][0]} |"
        )
        real_done = True
    print(
        f"| {name} | {misfit.get(name, '—')} | {cells(signal, ('+5', '-3', '-4'), 1)} | {cells(theta, ('+4', '+0', '-2', '-4'), 1)} | {far[1]} / {near[1]} | {rigid['+0'][1]} |"
    )
