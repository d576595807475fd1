"""`twin figure shear`'s figure: the paper's Fig. 2 from the taps and slides of
twin.analysis.shear, with its numbers."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from twin.analysis.shear import CENTRAL_PIN, DIRECTIONS_DEG, collect_shear_data, shear_numbers
from twin.core.scenario import DEFAULT_DOME


def plot_shear_figure(data: dict, out_png: Path, title: str = "") -> Path:
    """Fig. 2: (a) all 127 pin traces, taps black, slides coloured by direction; (b) the
    central pin zoomed. Image coordinates (px): u right, v down."""

    matplotlib.use("Agg")

    colours = plt.get_cmap("hsv")(np.linspace(0.0, 1.0, len(DIRECTIONS_DEG), endpoint=False))
    fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(11, 5.2), dpi=120, gridspec_kw={"width_ratios": [1.6, 1]})
    taps = data["tap_pins_px"]  # (8, 127, 2)
    for ax, pins in ((ax_a, range(taps.shape[1])), (ax_b, [CENTRAL_PIN])):
        for j in pins:
            for (direction, slide), colour in zip(sorted(data["slides"].items()), colours):
                p = slide["pins_px"][:, j]
                ax.plot(
                    p[:, 0],
                    p[:, 1],
                    "-",
                    color=colour,
                    lw=0.7 if ax is ax_a else 1.5,
                    marker="." if ax is ax_b else None,
                    ms=4,
                    label=f"slide {direction:.0f}°" if (ax is ax_b) else None,
                )
            ax.plot(
                taps[:, j, 0],
                taps[:, j, 1],
                "-",
                color="k",
                lw=0.9 if ax is ax_a else 2.0,
                marker="." if ax is ax_b else None,
                ms=5,
                label="taps" if ax is ax_b else None,
            )
        ax.set_aspect("equal")
        ax.invert_yaxis()
        ax.set_xlabel("u (px)")
        ax.set_ylabel("v (px)")
    # the zoom window of (a), drawn as a rectangle around the central pin
    centre = np.concatenate([taps[:, CENTRAL_PIN]] + [s["pins_px"][:, CENTRAL_PIN] for s in data["slides"].values()])
    lo, hi = centre.min(axis=0), centre.max(axis=0)
    pad = 0.15 * max(float(np.max(hi - lo)), 1.0)
    ax_a.add_patch(plt.Rectangle(lo - pad, *(hi - lo + 2 * pad), fill=False, lw=1.0, ec="0.3"))
    ax_b.set_xlim(lo[0] - pad, hi[0] + pad)
    ax_b.set_ylim(hi[1] + pad, lo[1] - pad)
    ax_a.set_title("(a) all pins: taps (black) vs slides (colour)")
    ax_b.set_title("(b) central pin")
    ax_b.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    out_png = Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png)
    plt.close(fig)
    return out_png


def write_shear_figure(
    out_png: Path, fidelity: str = "default", friction: bool = True, dome: str = DEFAULT_DOME
) -> dict:
    """Collect the taps and slides, write Fig. 2 to `out_png`, return the numbers.

    Returns shear_numbers(...) plus "png" (path), "fidelity", "friction", "dome".
    """
    data = collect_shear_data(fidelity, friction, dome)
    label = "with friction" if friction else "frictionless"
    plot_shear_figure(data, Path(out_png), f"Sliding vs tapping across an edge ({dome} dome, {fidelity}, {label})")
    numbers = shear_numbers(data)
    numbers.update({"png": str(out_png), "fidelity": fidelity, "friction": friction, "dome": dome})
    return numbers
