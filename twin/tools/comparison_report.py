"""`twin compare`'s plots: the comparison (twin.analysis.comparison), then comparison.png
(the most deformed pair's pins and the per-sample pin differences) and, for contour runs,
paths.png."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from twin.analysis.comparison import FIGURE_RESAMPLES, compare_runs, displacements, paired_runs, pin_differences
from twin.analysis.edge_imprint import REACH_AT_MM
from twin.runs.record import Run, load_run


def compare_and_report(
    dir_a: Path,
    dir_b: Path,
    out: Path,
    max_ssim_frames: int = 200,
    model_path: Path | None = None,
    slides_a: Path | None = None,
    slides_b: Path | None = None,
    reach_at: tuple[float, ...] = REACH_AT_MM,
    resamples: int = FIGURE_RESAMPLES,
    seed: int = 0,
) -> dict:
    """`twin compare`: comparison.json (twin.analysis.comparison.compare_runs) and its plots in
    `out` (no plots for runs compared by their edge figures alone, which share no sample)."""
    result = compare_runs(
        dir_a,
        dir_b,
        out,
        max_ssim_frames=max_ssim_frames,
        model_path=model_path,
        slides_a=slides_a,
        slides_b=slides_b,
        reach_at=reach_at,
        resamples=resamples,
        seed=seed,
    )
    if not result["n_pairs"]:
        return result
    a, b = load_run(dir_a), load_run(dir_b)
    ia, ib, diff = pin_differences(a, b, paired_runs(a, b)[0])
    _plot(a, b, ia, ib, diff, out, result["protocol"])
    return result


def _plot(a: Run, b: Run, ia: np.ndarray, ib: np.ndarray, diff: np.ndarray, out: Path, kind: str) -> None:

    matplotlib.use("Agg")

    k = int(np.argmax(np.linalg.norm(displacements(a)[ia], axis=2).max(axis=1)))  # the most deformed pair
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4), dpi=110)
    for ax, run, idx, title in ((axes[0], a, ia[k], "A"), (axes[1], b, ib[k], "B")):
        frame = run.frame(int(idx))
        pins = run.pins_px[int(idx)]
        if frame is not None:
            ax.imshow(frame)
        ref = run.pins_px[0]
        ax.quiver(
            ref[:, 0],
            ref[:, 1],
            pins[:, 0] - ref[:, 0],
            pins[:, 1] - ref[:, 1],
            color="tab:red",
            angles="xy",
            scale_units="xy",
            scale=0.25,
            width=0.003,
        )
        ax.set_title(
            f"{title}: {run.meta['scenario']['name']} ({run.meta['backend']}, {run.meta['scenario']['fidelity']})\n"
            f"sample {int(idx)}, pin displacement ×4"
        )
        ax.set_xlim(0, 640)
        ax.set_ylim(480, 0)
    with_pins = np.isfinite(diff).any(axis=1)  # a recording's frame without pins has no difference
    axes[2].hist(np.sqrt(np.nanmean(diff[with_pins] ** 2, axis=1)), bins=40, color="tab:blue")
    axes[2].set_xlabel("per-sample pin RMS difference (px)")
    axes[2].set_ylabel("samples")
    fig.tight_layout()
    fig.savefig(out / "comparison.png")
    plt.close(fig)
    if kind == "contour":
        fig, ax = plt.subplots(figsize=(5, 5), dpi=110)
        for run, label in ((a, "A"), (b, "B")):
            p = np.array([s["pose"][:2] for s in run.samples])
            ax.plot(p[:, 0], -p[:, 1], label=f"{label}: {run.meta['backend']} {run.meta['scenario']['fidelity']}")
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm, seen from above)")
        ax.legend()
        fig.savefig(out / "paths.png")
        plt.close(fig)
