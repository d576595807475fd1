"""The table rows of docs/real-sensor.md, "Where the base holds the skin", from `twin compare`'s
output: pin RMS, the reach at l = +4.5 mm (or `--reach-at L`), and at the two lateral
positions the taps hold drag / signal (B / A), the drag's rigid share and its share in the
taps' PC2–PC3 (the twin's; the recording's first).
usage: python rows.py [--reach-at L] cmp-NAME-TAPS.txt..."""

import re
import sys


def after(lines: list[str], heading: str, count: int) -> list[str]:
    """The `count` lines after the first line containing `heading`."""
    at = next(k for k, line in enumerate(lines) if heading in line)
    return lines[at + 1 : at + 1 + count]


def last_numbers(rows: list[str], column: int = -1) -> str:
    """Each row's number in `column` (the twin's last, the recording's before it), " / "-joined."""
    return " / ".join(row.split()[column] for row in rows)


paths = sys.argv[1:]
reach_at = "+4.5"
if paths[0] == "--reach-at":
    reach_at, paths = paths[1], paths[2:]
for path in paths:
    lines = open(path).read().splitlines()
    name = re.match(r"cmp-(.*)-[^-]+\.txt", path.split("/")[-1]).group(1)
    pins = lines[1].split()[3]
    reach = after(lines, f"reach at l {reach_at}", 2)
    if path == paths[0]:
        print("the recording | — | " + reach[0].split(":")[-1].strip())
    by_tap = after(lines, "B against A", 3)[1:]
    rigid = after(lines, "in a rigid shift, %", 2)
    in_plane = after(lines, "energy in the taps' PC2", 2)
    print(
        f"{name} | {pins} | {reach[1].split(':')[-1].strip()} | {last_numbers(by_tap, -4)} | "
        f"{last_numbers(rigid)} (rec. {last_numbers(rigid, -2)}) | "
        f"{last_numbers(in_plane)} (rec. {last_numbers(in_plane, -2)})"
    )
