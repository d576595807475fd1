"""The along-edge turn of θ_PC23 per mm of slide, by lateral bin, from `twin evaluate`'s
edge figures (sheared.sh's sheared-*.txt) and from `twin compare`'s (A and B of
compare-fsafit.txt: the DigiTac recording and the fit's replay of it), as a Markdown table.

    python sheared_table.py "LABEL=FILE[:COLUMN]" ...   # COLUMN: 1 = A, 2 = B of a compare
"""

import sys


def turns(path: str, column: int) -> list[str]:
    """The first 'θ_PC23 turned, deg per mm' block's values (l = +5 … −5 mm), column `column`."""
    lines = open(path).read().splitlines()
    start = next(i for i, line in enumerate(lines) if "θ_PC23 turned, deg per mm:" in line)
    return [line.split()[2 + column] for line in lines[start + 1 : start + 12]]


if __name__ == "__main__":
    header = ["+5", "+4", "+3", "+2", "+1", "0", "−1", "−2", "−3", "−4", "−5"]
    print("| θ_PC23 turned along the edge, °/mm, at l (mm) = | " + " | ".join(header) + " |")
    print("|---" * (len(header) + 1) + "|")
    for item in sys.argv[1:]:
        label, source = item.split("=", 1)
        path, _, column = source.partition(":")
        print(f"| {label} | " + " | ".join(turns(path, int(column or 1))) + " |")
