"""The frames' mean rigid shift in the edge's frame (along the outward normal n, along the
edge t; px) fitted, over taps at l in [lo, hi], on the slides: constant, linear and squared
terms of slide along / across the edge, twist, angle. usage: slide_terms.py LO HI RUN [RUN...]"""

import sys

import numpy as np

from twin.analysis.edge_imprint import edge_normal_in_image, usable
from twin.runs.record import load_run

lo, hi = float(sys.argv[1]), float(sys.argv[2])
for p in sys.argv[3:]:
    run = load_run(p)
    ok = usable(run) & (run.label("lateral_mm") >= lo) & (run.label("lateral_mm") <= hi)
    phi0, sigma = edge_normal_in_image(run)
    shift = (run.pins_px[ok] - run.rest_pins_px).mean(axis=1)
    a = np.radians(phi0 + sigma * run.label("theta_deg")[ok])
    sn = shift[:, 0] * np.cos(a) + shift[:, 1] * np.sin(a)
    st = -shift[:, 0] * np.sin(a) + shift[:, 1] * np.cos(a)
    sa, sl, tw, th, l = (
        run.label(k)[ok] for k in ("slide_along_mm", "slide_lateral_mm", "twist_deg", "theta_deg", "lateral_mm")
    )
    X = np.column_stack([np.ones(ok.sum()), sa, sl, tw, np.abs(sa), np.abs(sl), l - l.mean(), th])
    names = ["1", "sa", "sl", "tw", "|sa|", "|sl|", "l", "th"]
    out = []
    for name, y in (("n", sn), ("t", st)):
        c, *_ = np.linalg.lstsq(X, y, rcond=None)
        r = y - X @ c
        se = np.sqrt(np.diag(np.linalg.pinv(X.T @ X)) * r.var())
        out.append(
            name
            + ": "
            + " ".join(
                f"{k} {v:+.3f}±{e:.3f}" for k, v, e in zip(names, c, se) if k in ("1", "sa", "sl", "|sa|", "|sl|")
            )
        )
    print(p.split("/")[-1][:26].ljust(26), f"n={ok.sum()}", " | ".join(out), flush=True)
