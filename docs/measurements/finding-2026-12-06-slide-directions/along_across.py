"""Per lateral bin of a sheared-taps run: the fitted pin motion of a 1 mm slide along the edge
and across it, its rigid part (the mean pin shift, px) and the rest (RMS over pins, px), both
less the least-squares noise of the fitted gradient; and across / along of each, with a
bootstrap standard error (resampling the bin's taps), and pooled over the bins of each side.
    python along_across.py RUN ..."""

import sys

import numpy as np

from twin.analysis.edge_imprint import SHEARED_TERMS, usable
from twin.runs.record import load_run
from twin.sensing.perception import pins_to_vectors

ALONG, ACROSS = SHEARED_TERMS.index("slide_along_mm"), SHEARED_TERMS.index("slide_lateral_mm")


def bin_fit(z, x):
    """The least-squares fit of one bin's frames z (n, 254) px on its centred terms x (n, 6),
    as edge_imprint.sheared_fits makes it: (design (n, 7), coefficients (7, 254))."""
    design = np.column_stack([np.ones(len(x)), x - x.mean(axis=0)])
    coef, *_ = np.linalg.lstsq(design, z, rcond=None)
    return design, coef


def parts(z, x):
    """(rigid px, rest px) of the along and across gradients, noise taken out of their squares."""
    design, coef = bin_fit(z, x)
    res = z - design @ coef
    dof = len(z) - design.shape[1]
    var = np.sum(res**2, axis=0) / dof  # (254,) per coordinate
    inv = np.linalg.pinv(design.T @ design)
    shift_var = np.array([np.sum(var[0::2]), np.sum(var[1::2])]) / 127**2  # variance of the mean shift's noise
    out = []
    for t in (ALONG, ACROSS):
        g, c = coef[1 + t].reshape(-1, 2), inv[1 + t, 1 + t]
        shift = g.mean(axis=0)
        rigid2 = shift @ shift - c * shift_var.sum()
        rest2 = np.mean(np.sum((g - shift) ** 2, axis=1)) - c * np.sum(var) / 127 * (1 - 1 / 127)
        out.append((np.sqrt(max(rigid2, 0)), np.sqrt(max(rest2, 0))))
    return np.array(out)  # [[along rigid, rest], [across rigid, rest]]


def sheared_design(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A sheared-taps run's usable frames (n, 254) px, their SHEARED_TERMS values (n, 6) and
    their lateral bins (n,) mm (whole mm), as edge_imprint.sheared_fits takes them."""
    run = load_run(path)
    ok = usable(run)
    lateral = run.label("lateral_mm")[ok]
    centre = np.round(lateral)
    x = np.column_stack([run.label(t)[ok] for t in SHEARED_TERMS[:-1]] + [lateral - centre])
    return pins_to_vectors(run.pins_px[ok]), x, centre


rng = np.random.default_rng(0)
for path in sys.argv[1:] if __name__ == "__main__" else []:
    z, x, centre = sheared_design(path)
    print(path)
    print("   l    n   along rigid / rest px   across rigid / rest px   across/along: rigid, rest")
    sides = {"onto (l<0)": [], "off (l>0)": []}
    for c in sorted(set(centre.tolist())):
        m = centre == c
        if m.sum() < 20:
            continue
        p = parts(z[m], x[m])
        idx = np.flatnonzero(m)
        boots = []
        for _ in range(200):
            b = rng.choice(idx, len(idx))
            q = parts(z[b], x[b])
            boots.append(q[1] / np.maximum(q[0], 1e-9))
        boots = np.log(np.maximum(np.array(boots), 1e-3))
        # a part within its noise (floored at 0) has no ratio
        ratio = np.where((p[0] > 0) & (p[1] > 0), p[1] / np.maximum(p[0], 1e-12), np.nan)
        err = boots.std(axis=0)
        cells = [f"{r:4.2f} ×÷{np.exp(e):4.2f}" if np.isfinite(r) else "   —       " for r, e in zip(ratio, err)]
        print(
            f"  {c:+3.0f}  {m.sum():3d}   {p[0, 0]:5.2f} / {p[0, 1]:5.2f}            {p[1, 0]:5.2f} / {p[1, 1]:5.2f}"
            f"            {cells[0]}, {cells[1]}"
        )
        if c != 0:
            sides["onto (l<0)" if c < 0 else "off (l>0)"].append((np.log(ratio), err))
    for side, rows in sides.items():
        r = np.array([v for v, _ in rows])
        e = np.array([s for _, s in rows])
        cells = []
        for k, part in enumerate(("rigid", "rest")):
            ok = np.isfinite(r[:, k])
            w = 1 / e[ok, k] ** 2
            mean, se = (w * r[ok, k]).sum() / w.sum(), 1 / np.sqrt(w.sum())
            cells.append(f"{part} {np.exp(mean):.2f} ×÷ {np.exp(se):.2f} ({ok.sum()} bins)")
        print(f"  pooled {side}: " + ", ".join(cells))
