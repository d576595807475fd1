"""Table I's PCA + GP row with and without every frame's uniform shift (its mean pin
displacement from the rest pins) taken out before the perception is trained and run: the
paper's pipeline in a PC2–PC3 plane that, like the DigiTac figures', no rigid shift enters.
usage: python shift_free_table.py "LABEL=FOLDER" ...  (each FOLDER holding the paper's
       runs/taps_rectangle and runs/slides_rectangle, as run.sh writes them)"""

import sys
from pathlib import Path

from twin.analysis.evaluation import shift_free_table_i, table_i
from twin.runs.record import load_run
from twin.runs.training import train_from_run


def pca_gp_row(taps, slides, shift_free: bool) -> dict:
    """Table I's PCA + GP cells (direction → {"on", "off"}, deg RMS), as `twin evaluate`
    prints them, or (shift_free) as `twin evaluate --shift-free` adds them."""
    if shift_free:
        return shift_free_table_i(taps, slides)["PCA + GP"]
    theta = train_from_run(taps, "pca", 0).predict(slides.pins_px, resolution=slides.resolution).theta_deg
    return table_i(slides, {"PCA + GP": theta})["PCA + GP"]


def cell(row: dict) -> str:
    return f"{row['on']:.1f}" + (f" / {row['off']:.1f}" if row["off"] is not None else "")


if __name__ == "__main__":
    print("| dome | frames | " + " | ".join(f"{d}°" for d in range(0, 360, 45)) + " |")
    print("|---|---|" + "---|" * 8)
    for arg in sys.argv[1:]:
        label, folder = arg.split("=", 1)
        taps = load_run(Path(folder) / "runs" / "taps_rectangle")
        slides = load_run(Path(folder) / "runs" / "slides_rectangle")
        for shift_free in (False, True):
            row = pca_gp_row(taps, slides, shift_free)
            frames = "uniform shift taken out" if shift_free else "as recorded"
            print(f"| {label} | {frames} | " + " | ".join(cell(row[d]) for d in sorted(row)) + " |")
