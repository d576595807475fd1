"""The drag split by the slide's direction: per lateral bin of a sheared-taps run, the pins'
response (px per mm, RMS over pins) to a slide along the edge and across it, each side of
zero apart (a linear fit in the angle, the depth offset, the lateral position within the
bin, the twist and the four half-slides max(s, 0), min(s, 0)). `twin evaluate`'s drag fits
one slope per slide; this says where a slide's sign matters (across the edge onto the
object, lateral−, or off it, lateral+).
usage: python split.py RUN... (bins at |l| ≥ 3.5 mm)"""

import sys

import numpy as np

from twin.analysis.edge_imprint import usable
from twin.runs.record import load_run
from twin.sensing.perception import pins_to_vectors

HALVES = ("along+", "along−", "lateral+", "lateral−")

for path in sys.argv[1:]:
    run = load_run(path)
    ok = usable(run)
    z = pins_to_vectors(run.pins_px[ok])
    lateral = run.label("lateral_mm")[ok]
    label = {
        t: run.label(t)[ok] for t in ("theta_deg", "depth_offset_mm", "slide_along_mm", "slide_lateral_mm", "twist_deg")
    }
    centre = np.round(lateral)
    print(path)
    for c in sorted(set(centre.tolist())):
        if abs(c) < 3.5:
            continue
        m = centre == c
        along, across = label["slide_along_mm"][m], label["slide_lateral_mm"][m]
        design = np.column_stack(
            [
                np.ones(m.sum()),
                label["theta_deg"][m],
                label["depth_offset_mm"][m],
                lateral[m] - c,
                label["twist_deg"][m],
            ]
            + [np.maximum(along, 0), np.minimum(along, 0), np.maximum(across, 0), np.minimum(across, 0)]
        )
        coef, *_ = np.linalg.lstsq(design, z[m], rcond=None)
        per_mm = [float(np.sqrt(np.mean(np.sum(coef[5 + k].reshape(-1, 2) ** 2, axis=1)))) for k in range(4)]
        print(
            f"  l {c:+.0f} mm ({m.sum()} taps): " + ", ".join(f"{h} {v:.2f}" for h, v in zip(HALVES, per_mm)) + " px/mm"
        )
