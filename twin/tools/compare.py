"""`twin compare`: sample-by-sample comparison of two recorded runs of one scenario —
sim vs sim (two fidelity levels) or sim vs real (sim-to-real)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from twin.core.errors import UserError
from twin.runs.record import Run, load_run
import cv2
from skimage.metrics import structural_similarity
from twin.sensing.perception import angle_error_deg
from twin.sensing.perception import PerceptionModel
from twin.tools.evaluate import along_edge_drag_px, orientation_signal_px
from twin.analysis.comparison import paired_runs
import matplotlib
import matplotlib.pyplot as plt

def _displacements(run: Run) -> np.ndarray:
    pins = run.pins_px
    return pins - pins[0]


def _ssim(a: np.ndarray, b: np.ndarray) -> float:

    ga, gb = (cv2.cvtColor(x, cv2.COLOR_RGB2GRAY) for x in (a, b))
    if ga.shape != gb.shape:
        gb = cv2.resize(gb, (ga.shape[1], ga.shape[0]), interpolation=cv2.INTER_AREA)
    return float(structural_similarity(ga, gb, data_range=255))


def _path_distance(a: Run, b: Run) -> dict:
    pa = np.array([s["pose"][:2] for s in a.samples])
    pb = np.array([s["pose"][:2] for s in b.samples])
    d = np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2)
    ab, ba = d.min(axis=1), d.min(axis=0)
    return {"mean_mm": float(np.mean(np.concatenate([ab, ba]))), "hausdorff_mm": float(max(ab.max(), ba.max()))}


def perception_error(run: Run, model) -> dict | None:
    """RMS θ (deg) and l (mm) error of `model` on a run whose samples carry theta_deg and
    lateral_mm labels (taps, slides); None for runs without them."""

    theta, lateral = run.label("theta_deg"), run.label("lateral_mm")
    if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(lateral))) or not len(theta):
        return None
    pred = model.predict(run.pins_px, resolution=run.resolution)
    return {"orientation_rms_deg": float(np.sqrt(np.mean(angle_error_deg(pred.theta_deg, theta) ** 2))),
            "lateral_rms_mm": float(np.sqrt(np.mean((pred.lateral_mm - lateral) ** 2))),
            "ok_fraction": float(np.mean(pred.ok))}


def compare_runs(dir_a: Path, dir_b: Path, out: Path, max_ssim_frames: int = 200, model_path: Path | None = None) -> dict:
    """Pair the runs' samples by target pose and write comparison.json and plots to `out`.

    Each run's perception error: contour runs report their metrics.json; labelled runs
    (taps, slides) are scored with the model file `model_path` when given. Tap runs also
    get each run's orientation signal per lateral position and slide runs each run's
    along-edge drag (twin.tools.evaluate), the two figures Table I's along-edge cells
    weigh, side by side for a sim and a real sensor."""
    a, b = load_run(dir_a), load_run(dir_b)
    name_a, name_b = a.meta["scenario"]["name"], b.meta["scenario"]["name"]
    kind = a.meta["scenario"]["protocol"]["kind"]
    if kind != b.meta["scenario"]["protocol"]["kind"]:
        raise UserError(f"{dir_a} ({kind}) and {dir_b} ({b.meta['scenario']['protocol']['kind']}) are different protocols")
    result: dict = {"run_a": str(dir_a), "run_b": str(dir_b), "backend_a": a.meta["backend"], "backend_b": b.meta["backend"],
                    "fidelity_a": a.meta["scenario"]["fidelity"], "fidelity_b": b.meta["scenario"]["fidelity"],
                    "scenario_a": name_a, "scenario_b": name_b, "protocol": kind,
                    "state_a": a.state, "state_b": b.state,
                    "unfinished": [n for n in (a.unfinished_note(), b.unfinished_note()) if n]}
    if kind == "contour":
        result["path_distance"] = _path_distance(a, b)
        for tag, run in (("a", a), ("b", b)):
            metrics = run.path / "metrics.json"
            if metrics.exists():
                result[f"metrics_{tag}"] = json.loads(metrics.read_text())
    elif model_path is not None:
        model = PerceptionModel.load(model_path)
        result["perception_a"], result["perception_b"] = perception_error(a, model), perception_error(b, model)
    if kind == "taps":  # what each sensor's taps carry of the edge's orientation, by lateral position
        result["orientation_signal_px"] = {"a": orientation_signal_px(a), "b": orientation_signal_px(b)}
    elif kind == "slides":  # how far each sensor's skin is dragged along the edge
        result["along_edge_drag_px"] = {"a": along_edge_drag_px(a), "b": along_edge_drag_px(b)}
    pairs, result["pairing"] = paired_runs(a, b)
    ia, ib = (np.array(x) for x in zip(*pairs))
    pins_a, pins_b = a.pins_px[ia], b.pins_px[ib]
    diff = np.linalg.norm(pins_a - pins_b, axis=2)
    disp_a, disp_b = _displacements(a)[ia], _displacements(b)[ib]
    corr = []
    for k in range(pins_a.shape[1]):
        va, vb = disp_a[:, k].ravel(), disp_b[:, k].ravel()
        if np.std(va) > 1e-9 and np.std(vb) > 1e-9:
            corr.append(float(np.corrcoef(va, vb)[0, 1]))
    result.update(n_pairs=len(pairs), n_a=len(a.samples), n_b=len(b.samples),
                  pin_rms_difference_px=float(np.sqrt(np.nanmean(diff**2))),
                  pin_displacement_correlation={"mean": float(np.mean(corr)) if corr else None,
                                                "min": float(np.min(corr)) if corr else None, "pins": len(corr)})
    ssims = []
    step = max(1, len(pairs) // max_ssim_frames)
    for i, j in pairs[::step]:
        fa, fb = a.frame(i), b.frame(j)
        if fa is not None and fb is not None:
            ssims.append(_ssim(fa, fb))
    result["ssim"] = {"mean": float(np.mean(ssims)), "min": float(np.min(ssims)), "frames": len(ssims)} if ssims else None
    out.mkdir(parents=True, exist_ok=True)
    (out / "comparison.json").write_text(json.dumps(result, indent=1, default=float))
    _plot(a, b, ia, ib, diff, out, kind)
    return result


def _plot(a: Run, b: Run, ia: np.ndarray, ib: np.ndarray, diff: np.ndarray, out: Path, kind: str) -> None:

    matplotlib.use("Agg")

    k = int(np.argmax(np.linalg.norm(_displacements(a)[ia], axis=2).max(axis=1)))  # the most deformed pair
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4), dpi=110)
    for ax, run, idx, title in ((axes[0], a, ia[k], "A"), (axes[1], b, ib[k], "B")):
        frame = run.frame(int(idx))
        pins = run.pins_px[int(idx)]
        if frame is not None:
            ax.imshow(frame)
        ref = run.pins_px[0]
        ax.quiver(ref[:, 0], ref[:, 1], pins[:, 0] - ref[:, 0], pins[:, 1] - ref[:, 1], color="tab:red",
                  angles="xy", scale_units="xy", scale=0.25, width=0.003)
        ax.set_title(f"{title}: {run.meta['scenario']['name']} ({run.meta['backend']}, {run.meta['scenario']['fidelity']})\n"
                     f"sample {int(idx)}, pin displacement ×4")
        ax.set_xlim(0, 640)
        ax.set_ylim(480, 0)
    axes[2].hist(np.sqrt(np.nanmean(diff**2, axis=1)), bins=40, color="tab:blue")
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
