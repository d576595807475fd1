"""Where the slides' drag lies among the taps' first eight PCs: each PC's explained variance
and its share of energy in a rigid shift of the pins, then, per sliding direction, the share
of the drag's energy (third sliding sample, 9.9 mm along, less the pressed frame) on each
PC and outside all eight.

    python drag_by_pc.py TAPS SLIDES
"""

import sys
from pathlib import Path

import numpy as np
from slide_figures import drags

from twin.analysis.edge_imprint import translation_share
from twin.runs.record import load_run
from twin.sensing.perception import pca_fit, pins_to_vectors

taps, slides = load_run(Path(sys.argv[1])), load_run(Path(sys.argv[2]))
mean, comps, explained = pca_fit(pins_to_vectors(taps.pins_px), 8)
print(f"{sys.argv[1]} / {sys.argv[2]}")
print("  explained, %:        " + " ".join(f"{100 * v:6.2f}" for v in explained))
print("  in a rigid shift, %: " + " ".join(f"{100 * translation_share(c):6.2f}" for c in comps))
for direction in (0, 90, 180, 270):
    drag = drags(slides, (direction,), [3])
    energy = np.mean(np.sum(drag**2, axis=1))
    share = np.mean((drag @ comps.T) ** 2, axis=0) / energy
    print(
        f"  {direction:3d}° drag by PC, %:   "
        + " ".join(f"{100 * v:6.2f}" for v in share)
        + f"   outside: {100 * (1 - share.sum()):.1f}"
    )
