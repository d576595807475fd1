"""One bounded Gauss-Newton step on the figure misses, from sens.py's one-at-a-time
differences (usage: gn.py TABLES.json ...)."""

import json
import math
import sys

import numpy as np
from scipy.optimize import lsq_linear

T = {}
for f in sys.argv[1:]:
    T.update(json.load(open(f)))
base = np.array([r["miss"] for r in T["base"]])
# name -> (variant, coordinate, step in coordinate, bounds in coordinate)
coords = {
    "log_gel": ("gel26", math.log(2), (math.log(5 / 13.3), math.log(60 / 13.3))),
    "log_bend": ("bend0.3", math.log(6), (math.log(0.01 / 0.05), math.log(2 / 0.05))),
    "sway": ("sway0.3", 0.3, (0.0, 2.0)),
    "depth": ("deeper0.5", 0.5, (-1.5, 1.5)),
    "log_mem": ("membrane0.93", math.log(3), (math.log(0.1 / 0.31), math.log(3 / 0.31))),
    "mu": ("mu0.40", -0.11, (0.2 - 0.51, 0.8 - 0.51)),
    "held": ("held80", -10.0, (65 - 90.0, 0.0)),
}
use = [c for c in coords if coords[c][0] in T]
J = np.column_stack([(np.array([r["miss"] for r in T[coords[c][0]]]) - base) / coords[c][1] for c in use])
lo = np.array([coords[c][2][0] for c in use])
hi = np.array([coords[c][2][1] for c in use])
for damp in (0.0, 0.5, 2.0):
    A = np.vstack([J, math.sqrt(damp) * np.eye(len(use))]) if damp else J
    b = np.concatenate([-base, np.zeros(len(use))]) if damp else -base
    res = lsq_linear(A, b, bounds=(lo, hi))
    pred = base + J @ res.x
    print(
        f"damp {damp}: predicted chi2 {np.sum(pred**2):.1f} (base {np.sum(base**2):.1f})",
        {c: round(float(v), 3) for c, v in zip(use, res.x)},
    )
    p = dict(zip(use, res.x))
    print(
        "  point:",
        {
            "gel_kpa": 13.3 * math.exp(p.get("log_gel", 0)),
            "bend_mpa": 0.05 * math.exp(p.get("log_bend", 0)),
            "sway": p.get("sway", 0),
            "depth": p.get("depth", 0),
            "mem_mpa": 0.31 * math.exp(p.get("log_mem", 0)),
            "mu": 0.51 + p.get("mu", 0),
            "held": 90 + p.get("held", 0),
        },
    )
if "combo" in T:
    c = np.array([r["miss"] for r in T["combo"]])
    lin = (
        base
        + J[:, use.index("log_gel")] * math.log(2)
        + J[:, use.index("log_bend")] * math.log(6)
        + J[:, use.index("sway")] * 0.3
    )
    print("combo chi2", np.sum(c**2), "linear prediction", np.sum(lin**2), "max |diff|", np.abs(c - lin).max())
