"""Does an across-edge slide leave the imprint behind? Per lateral bin of a sheared-taps run,
the fitted pin motion of a 1 mm slide across the edge (slide_lateral_mm) regressed on the
imprint's own change with l (lateral_in_bin_mm, per mm): lag = -<g_across, g_l>/<g_l, g_l>
(mm of l per mm of slide; > 0: the imprint reads as if the sensor were still short of where
it slid to), with a bootstrap standard error; and the same for the along-edge slide (which
moves the imprint nowhere: a control).
    python lag.py RUN ..."""

import sys

import numpy as np
from along_across import bin_fit, sheared_design

from twin.analysis.edge_imprint import SHEARED_TERMS

T = {t: k for k, t in enumerate(SHEARED_TERMS)}


def lags(z, x, rigid_out):
    _, coef = bin_fit(z, x)
    g = {t: coef[1 + k].reshape(-1, 2) for t, k in T.items()}
    if rigid_out:
        g = {t: v - v.mean(axis=0) for t, v in g.items()}
    gl = g["lateral_in_bin_mm"].ravel()
    return np.array([-(g[t].ravel() @ gl) / (gl @ gl) for t in ("slide_lateral_mm", "slide_along_mm")])


rng = np.random.default_rng(0)
for path in sys.argv[1:]:
    z, x, centre = sheared_design(path)
    print(path, "   lag, mm per mm: across (along, control); rigid shifts kept | taken out")
    for c in sorted(set(centre.tolist())):
        m = centre == c
        if m.sum() < 20:
            continue
        idx = np.flatnonzero(m)
        cells = []
        for rigid_out in (False, True):
            v = lags(z[m], x[m], rigid_out)
            b = np.array([lags(z[s], x[s], rigid_out) for s in (rng.choice(idx, len(idx)) for _ in range(200))])
            e = b.std(axis=0)
            cells.append(f"{v[0]:+5.2f} ± {e[0]:4.2f} ({v[1]:+5.2f} ± {e[1]:4.2f})")
        print(f"  {c:+3.0f}  " + "   |   ".join(cells))
