"""The paper's figures (the issue's point 5) from `run.sh`'s tables, one row per dome.

    python summary.py "LABEL=FOLDER" ...   # each FOLDER holding table-i.txt, heldout.txt
                                           # and, where its contours ran, contours.txt

Prints a Markdown table: Table I's PCA + GP error along the edge at 90° and 270° (raw pins,
the GP baseline, beside it), how many of the six other columns have Off below On, the
held-out taps' worst θ and lateral RMS from l = +5 to −5 mm, and the contours closed and
their mean θ RMS (the six shipped ones; the two user STL objects apart).
"""

import sys
from pathlib import Path


def table_i(folder: Path) -> dict[str, list[str]]:
    """Table I's rows by model name, each its eight 'on/off' cells."""
    rows = {}
    for line in (folder / "table-i.txt").read_text().splitlines()[1:5]:
        cells = line.split()
        rows[" ".join(cells[:-8])] = cells[-8:]
    return rows


def heldout_worst(folder: Path) -> tuple[float, float]:
    """The PCA + GP held-out θ RMS (deg) and lateral RMS (mm), worst over l = +5 … −5 mm."""
    worst_theta = worst_lateral = 0.0
    for line in (folder / "heldout.txt").read_text().splitlines():
        cells = line.split()
        if line.startswith("PCA + GP ") and len(cells) == 7 and abs(float(cells[3])) <= 5.0:
            worst_theta, worst_lateral = max(worst_theta, float(cells[4])), max(worst_lateral, float(cells[5]))
    return worst_theta, worst_lateral


def contours(folder: Path) -> str:
    """'closed of 6, mean θ RMS' of the shipped contours; the user STL objects' θ RMS."""
    path = folder / "contours.txt"
    if not path.exists():
        return "not run"
    rows = [line.split() for line in path.read_text().splitlines()[1:] if line.startswith("contour_")]
    shipped = [r for r in rows if not r[0].endswith("_stl")]
    closed = sum(r[1] == "True" for r in shipped)
    mean = sum(float(r[3]) for r in shipped) / len(shipped)
    stl = ", ".join(f"{r[0].removeprefix('contour_')} {float(r[3]):.1f}°" for r in rows if r[0].endswith("_stl"))
    return f"{closed} of {len(shipped)} closed, {mean:.1f}° ({stl})"


if __name__ == "__main__":
    print("| dome | 90° / 270° PCA + GP (raw pins) | Off < On | held-out worst θ, lateral | contours |")
    print("|---|---|---|---|---|")
    for item in sys.argv[1:]:
        label, folder = item.split("=", 1)
        rows = table_i(Path(folder))
        pca, raw = rows["twin PCA + GP"], rows["twin GP baseline"]
        along = f"{pca[2].split('/')[0]}° / {pca[6].split('/')[0]}° ({raw[2].split('/')[0]}° / {raw[6].split('/')[0]}°)"
        columns = [c.split("/") for i, c in enumerate(pca) if i not in (2, 6)]
        off_below = sum(float(off) < float(on) for on, off in columns)
        theta, lateral = heldout_worst(Path(folder))
        print(f"| {label} | {along} | {off_below} of 6 | {theta:.2f}°, {lateral:.2f} mm | {contours(Path(folder))} |")
