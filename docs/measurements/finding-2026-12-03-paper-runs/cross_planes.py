"""The along-edge slides' drag in the taps' PC2–PC3 plane across frictions: each friction's
slides (rows) in each friction's taps' plane (columns), RMS px; then the angle between the
taps' planes (deg, the larger principal angle). Run beside run.sh's runs/.

    python cross_planes.py
"""

from pathlib import Path

import numpy as np
from slide_figures import drags

from twin.analysis.edge_imprint import TapPCs, plane_angle_deg, tap_pcs
from twin.runs.record import load_run


def drag_in(pcs: TapPCs, slides) -> float:
    parts = pcs.field_in_plane(drags(slides, (90, 270)).T)
    return float(np.sqrt(np.mean(np.sum(parts**2, axis=0))))


tags = ["fit", "f05", "f03", "f01"]  # friction 0.95, 0.5, 0.3, 0.1
planes = {t: tap_pcs(load_run(Path(f"runs/taps_rectangle_{t}"))) for t in tags}
for s in tags:
    sl = load_run(Path(f"runs/slides_rectangle_{s}"))
    print(
        f"slides {s}: in-plane drag px in the taps' plane of "
        + "  ".join(f"{p}: {drag_in(planes[p], sl):6.2f}" for p in tags)
    )
print("angle between the taps' planes, deg:")
for p in tags:
    print(p, " ".join(f"{plane_angle_deg(planes[p], planes[q]):5.1f}" for q in tags))
