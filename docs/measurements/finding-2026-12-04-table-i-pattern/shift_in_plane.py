"""Where a uniform shift of every pin lands in the taps' PC2–PC3 plane, for a shift along
the edge's outward normal and one along the edge, against each tap's own place there:
the part along the tap's direction from the plane's origin (radial: moves ρ, φ) and the
part round it (turns θ_PC23). RMS over the taps at each lateral position, per px of shift.

    python shift_in_plane.py EVAL_DIR TAPS_RUN [EVAL_DIR TAPS_RUN ...]
"""

import sys
from pathlib import Path

import numpy as np

from twin.analysis.edge_imprint import edge_normal_in_image, usable
from twin.runs.record import load_run
from twin.sensing.perception import PerceptionModel


def main(pairs: list[tuple[str, str]]) -> None:
    for eval_dir, taps_dir in pairs:
        model = PerceptionModel.load(Path(eval_dir) / "model_pca.npz")
        taps = load_run(taps_dir)
        ok = usable(taps)
        ok[ok] = np.linalg.norm(model.pc23_px(taps.pins_px[ok], taps.resolution), axis=1) > 1e-9  # not at the origin
        pins, theta, lateral = taps.pins_px[ok], taps.label("theta_deg")[ok], taps.label("lateral_mm")[ok]
        phi0, sigma = edge_normal_in_image(taps)
        a = np.radians(phi0 + sigma * theta)
        normal = np.stack([np.cos(a), np.sin(a)], axis=1)[:, None, :]  # (n, 1, 2) px per px, off the object
        along = np.stack([-np.sin(a), np.cos(a)], axis=1)[:, None, :]
        p = model.pc23_px(pins, taps.resolution)
        radial = p / np.linalg.norm(p, axis=1, keepdims=True)
        round_ = radial @ np.array([[0.0, 1.0], [-1.0, 0.0]])
        print(
            f"{Path(eval_dir).name}: {len(pins)} taps off the plane's origin; px in the plane per px of uniform shift"
        )
        print("   l, mm | normal: radial, round | along the edge: radial, round | tap radius, px")
        for l in sorted(set(lateral.tolist()), reverse=True):
            m = lateral == l
            row = []
            for shift in (normal, along):
                d = model.pc23_px(pins[m] + shift[m], taps.resolution) - p[m]
                row += [
                    np.sqrt(np.mean(np.sum(d * radial[m], axis=1) ** 2)),
                    np.sqrt(np.mean(np.sum(d * round_[m], axis=1) ** 2)),
                ]
            radius = np.sqrt(np.mean(np.sum(p[m] ** 2, axis=1)))
            print(
                f"  {l:+6.1f} | {row[0]:6.2f} {row[1]:6.2f}        | {row[2]:6.2f} {row[3]:6.2f}              | {radius:6.2f}"
            )


if __name__ == "__main__":
    args = sys.argv[1:]
    main(list(zip(args[::2], args[1::2], strict=True)))
