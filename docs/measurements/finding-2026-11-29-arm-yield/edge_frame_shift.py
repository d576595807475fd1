"""The frames' mean pin shift (px) split into a part fixed in the image (d0), a part fixed in
the edge's frame (along its outward normal n and along the edge t; per lateral bin, then per
depth third) and the slides' terms in the edge's frame (linear and |·| in the slide along and
across the edge), fitted jointly by least squares over every usable frame.
A shift fixed in the edge's frame turns with the edge in the image: it is the part of the
orientation signal that moves every pin alike.
usage: edge_frame_shift.py [--first N] RUN [RUN...]  (--first: each run's first N samples)"""

import sys

import numpy as np

from twin.analysis.edge_imprint import edge_normal_in_image, usable
from twin.runs.record import Run, load_run


def frames(run):
    """The usable frames' mean shift (n, 2) px, the edge normal's image direction (cos, sin)
    and their labels."""
    ok = usable(run)
    phi0, sigma = edge_normal_in_image(run)
    shift = (run.pins_px[ok] - run.rest_pins_px).mean(axis=1)
    a = np.radians(phi0 + sigma * run.label("theta_deg")[ok])
    keys = ("slide_along_mm", "slide_lateral_mm", "lateral_mm", "depth_mm", "tap")
    return ok, shift, np.cos(a), np.sin(a), {k: run.label(k)[ok] for k in keys}


def fit(shift, c, s, labels, groups, names, show=None):
    """Least squares of the shift on d0 + Σ group × (n, t) + the slides' terms; the terms
    named in `show` (all by default) with their standard errors, and the rss (px²)."""
    one = np.ones(len(c))
    along, across = labels["slide_along_mm"], labels["slide_lateral_mm"]
    rows_x, rows_y = [one, 0 * one], [0 * one, one]
    for g in list(groups) + [along, across, np.abs(along), np.abs(across)]:
        rows_x += [g * c, -g * s]
        rows_y += [g * s, g * c]
    x = np.vstack([np.column_stack(rows_x), np.column_stack(rows_y)])
    y = np.concatenate([shift[:, 0], shift[:, 1]])
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    r = y - x @ coef
    se = np.sqrt(np.diag(np.linalg.pinv(x.T @ x)) * r.var())
    cells = " ".join(
        f"[{k}] n {coef[2 + 2 * i]:+.3f}±{se[2 + 2 * i]:.3f} t {coef[3 + 2 * i]:+.3f}"
        for i, k in enumerate(names)
        if show is None or k in show
    )
    return f"rss {np.sum(r**2):8.1f} px², {x.shape[1]:2d} terms | d0 ({coef[0]:+.2f}, {coef[1]:+.2f}) {cells}"


def lateral_bins(labels):
    return [(np.abs(labels["lateral_mm"] - b) <= 0.5) * 1.0 for b in range(-5, 6)], [f"{b:+d}" for b in range(-5, 6)]


if __name__ == "__main__":
    args, first = sys.argv[1:], None
    if args[0] == "--first":
        first, args = int(args[1]), args[2:]
    for path in args:
        run = load_run(path)
        run = Run(run.path, run.meta, run.samples[:first])
        _, shift, c, s, labels = frames(run)
        print("==", path.rstrip("/").split("/")[-1], "" if first is None else f"(first {first} samples)")
        print("  by l:    ", fit(shift, c, s, labels, *lateral_bins(labels)))
        depth = labels["depth_mm"]
        q = np.quantile(depth, [1 / 3, 2 / 3])
        thirds = [(depth < q[0]) * 1.0, ((depth >= q[0]) & (depth < q[1])) * 1.0, (depth >= q[1]) * 1.0]
        print("  by depth:", fit(shift, c, s, labels, thirds, [f"<{q[0]:.2f}", "mid", f">{q[1]:.2f}"]))
