"""How the drag grows with the slide: per lateral bin, the pins' RMS distance from a model
without slide terms (θ, depth offset, l in the bin; fitted to the bin's taps that slid
less than 1.5 mm), in bins of slide length |s| (mm), over the bin's mean imprint (RMS pin
distance from rest, its rigid shift taken out). Unit-free, so a real run and a twin's
compare across cameras.

usage: drag_curve.py RUN [RUN ...]   (the repository on PYTHONPATH)"""

import sys

import numpy as np

from twin.analysis.edge_imprint import usable
from twin.runs.record import load_run
from twin.sensing.perception import pins_to_vectors

EDGES_MM = (0, 1, 2, 3, 4, 5.01)

for path in sys.argv[1:]:
    run = load_run(path)
    ok = usable(run)
    z = pins_to_vectors(run.pins_px[ok])
    rest = run.rest_pins_px.reshape(-1)
    lateral = run.label("lateral_mm")[ok]
    centre = np.round(lateral)
    theta, depth = run.label("theta_deg")[ok], run.label("depth_offset_mm")[ok]
    length = np.hypot(run.label("slide_along_mm")[ok], run.label("slide_lateral_mm")[ok])
    print(path)
    print("   l  taps  imprint px   drag / imprint at |s| 0-1  1-2  2-3  3-4  4-5 mm")
    for c in sorted(set(centre.tolist())):
        m = centre == c
        if m.sum() < 60:
            continue
        x = np.column_stack([np.ones(m.sum()), theta[m], depth[m], lateral[m] - c])
        still = length[m] < 1.5
        coef, *_ = np.linalg.lstsq(x[still], z[m][still], rcond=None)
        drag = np.sqrt(np.mean(np.sum((z[m] - x @ coef).reshape(-1, 127, 2) ** 2, axis=2), axis=1))
        imprint = (z[m].mean(axis=0) - rest).reshape(127, 2)
        imprint_px = np.sqrt(np.mean(np.sum((imprint - imprint.mean(axis=0)) ** 2, axis=1)))
        cells = []
        for lo, hi in zip(EDGES_MM[:-1], EDGES_MM[1:]):
            k = (length[m] >= lo) & (length[m] < hi)
            cells.append(f"{np.sqrt(np.mean(drag[k] ** 2)) / imprint_px:5.2f}" if k.sum() > 5 else "    -")
        print(f"{c:+4.0f} {m.sum():5d}   {imprint_px:6.2f}                     " + " ".join(cells))
