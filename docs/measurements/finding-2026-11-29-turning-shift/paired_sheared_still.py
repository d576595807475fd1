"""Paired sheared − still replays of the same taps: the frames' mean rigid shift in the
edge frame (along the outward normal n, along the edge t; px) by slide size, off the object
(l > 0.5) and onto it (l < -0.5). usage: paired_sheared_still.py SHEARED STILL"""

import sys

import numpy as np

from twin.analysis.edge_imprint import edge_normal_in_image, usable
from twin.runs.record import load_run

a_run, b_run = load_run(sys.argv[1]), load_run(sys.argv[2])
assert len(a_run.samples) == len(b_run.samples)
ok = usable(a_run) & usable(b_run)
phi0, sigma = edge_normal_in_image(b_run)
d = (a_run.pins_px[ok] - b_run.pins_px[ok]).mean(axis=1)
a = np.radians(phi0 + sigma * a_run.label("theta_deg")[ok])
dn = d[:, 0] * np.cos(a) + d[:, 1] * np.sin(a)
dt = -d[:, 0] * np.sin(a) + d[:, 1] * np.cos(a)
sa, sl, l = (a_run.label(k)[ok] for k in ("slide_along_mm", "slide_lateral_mm", "lateral_mm"))
size = np.maximum(np.abs(sa), np.abs(sl))
for side, m0 in (("off", l > 0.5), ("onto", l < -0.5)):
    row = []
    for lo, hi in ((0, 0.5), (0.5, 1), (1, 2), (2, 3), (3, 5.01)):
        m = m0 & (size >= lo) & (size < hi)
        row.append(f"{lo}-{hi:.0f}mm n={m.sum()}: Δn {dn[m].mean():+.2f} Δt {dt[m].mean():+.2f}")
    print(side, " | ".join(row))
# along-only and across-only signs (off the object)
m0 = l > 0.5
for name, s in (("sa", sa), ("sl", sl)):
    other = sl if name == "sa" else sa
    for sign in (-1, 1):
        m = m0 & (np.sign(s) == sign) & (np.abs(s) > 2) & (np.abs(other) < 1)
        print(
            f"off, {name} {'+' if sign > 0 else '-'}(>2 mm, other <1): n={m.sum()} Δn {dn[m].mean():+.2f} Δt {dt[m].mean():+.2f}"
        )
