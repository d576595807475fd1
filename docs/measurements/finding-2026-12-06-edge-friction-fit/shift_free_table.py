"""Table I's PCA + GP row with and without every frame's uniform shift (its mean pin
displacement from the rest pins) taken out before the perception is trained and run: the
paper's pipeline in a PC2–PC3 plane that, like the DigiTac figures', no rigid shift enters.
usage: python shift_free_table.py "LABEL=FOLDER" ...  (each FOLDER holding the paper's
       runs/taps_rectangle and runs/slides_rectangle, as run.sh writes them)"""

import sys
from pathlib import Path

import numpy as np

from twin.analysis.edge_imprint import without_uniform_shift
from twin.analysis.evaluation import table_i
from twin.runs.record import load_run
from twin.sensing.perception import PerceptionModel


def pca_gp_row(taps, slides, shift_free: bool) -> dict:
    """Table I's PCA + GP cells (direction → {"on", "off"}, deg RMS)."""
    tap_pins, slide_pins = taps.pins_px, slides.pins_px
    if shift_free:
        tap_pins = without_uniform_shift(tap_pins, taps.rest_pins_px)
        slide_pins = without_uniform_shift(slide_pins, taps.rest_pins_px)
    model = PerceptionModel(method="pca").fit(
        tap_pins,
        taps.label("theta_deg"),
        taps.label("lateral_mm"),
        taps.label("depth_mm"),
        np.random.default_rng(0),
        resolution=taps.resolution,
    )
    theta = model.predict(slide_pins, resolution=slides.resolution).theta_deg
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
