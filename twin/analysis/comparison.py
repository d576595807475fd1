"""`twin compare`'s figures: sample-by-sample comparison of two recorded runs of one
scenario — sim vs sim (two fidelity levels) or sim vs real (sim-to-real): which samples
pair up, pin differences and correlation, image SSIM, path distance, perception error, and
each run's orientation signal or along-edge drag, and two tap runs' edge figures. Text and plots: twin.tools.comparison_report."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
from skimage.metrics import structural_similarity

from twin.analysis.calibration_fit.figures import (
    THETA_TURN_KEYS,
    paired_figure_spread,
    paired_figures,
    pooled_difference,
    side_groups,
)
from twin.analysis.edge_imprint import REACH_AT_MM, edge_figures, is_sheared, usable
from twin.analysis.evaluation import along_edge_drag_px, orientation_signal_px
from twin.core.errors import UserError
from twin.runs.pairing import pair_samples, shared_taps
from twin.runs.record import Run, jsonable, load_run
from twin.sensing.perception import PerceptionModel, angle_error_deg


def paired_runs(a: Run, b: Run) -> tuple[list[tuple[int, int]], str]:
    """The sample pairs (i in a, j in b) two runs are compared on, and how they were
    paired: closed-loop (contour) runs by step, since their targets differ; the others by
    target pose (pair_samples). Raises UserError when they share none."""
    if a.meta["scenario"]["protocol"]["kind"] == "contour":
        pairs, pairing = (
            [(i, i) for i in range(min(len(a.samples), len(b.samples)))],
            "by step (closed loop: targets differ)",
        )
    else:
        pairs, pairing = pair_samples(a, b), "by target pose"
    if not pairs:
        raise UserError(f"{a.path} and {b.path} share no target poses: are they runs of the same scenario?")
    return pairs, pairing


def displacements(run: Run) -> np.ndarray:
    """Each sample's pins (px) less the run's first sample's."""
    pins = run.pins_px
    return pins - pins[0]


def pin_differences(a: Run, b: Run, pairs: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paired samples' indices in a and in b, and each pair's pin distances (pairs, 127) px."""
    ia, ib = (np.array(x) for x in zip(*pairs))
    return ia, ib, np.linalg.norm(a.pins_px[ia] - b.pins_px[ib], axis=2)


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
    return {
        "orientation_rms_deg": float(np.sqrt(np.mean(angle_error_deg(pred.theta_deg, theta) ** 2))),
        "lateral_rms_mm": float(np.sqrt(np.mean((pred.lateral_mm - lateral) ** 2))),
        "ok_fraction": float(np.mean(pred.ok)),
    }


#: bootstrap resamples of the shared taps for the edge figures' differences (`twin compare --resamples`)
FIGURE_RESAMPLES = 50


def taps_both_kept(a: Run, b: Run, pairs: list[tuple[int, int]] | None = None) -> list[tuple[int, int]]:
    """The taps the runs share (twin.runs.pairing.shared_taps; `pairs`: their
    `pair_samples`, where the caller has them) but those only one of them can read
    (`usable`: a tap one run lost a pin in counts in neither)."""
    shared = shared_taps(a, b, pairs)
    if not shared:
        return []
    kept_a, kept_b = usable(a), usable(b)
    return [(i, j) for i, j in shared if kept_a[i] == kept_b[j]]


def figure_differences(a: Run, b: Run, resamples: int, seed: int) -> dict:
    """B's edge figures against A's on the same taps (`a` and `b` hold them in the same
    order): per figure and lateral bin, both values and the standard deviation of their
    difference over `resamples` paired bootstrap resamples (twin.analysis.calibration_fit.
    figures.paired_figure_spread; in the figure's miss units: the ratio's difference for
    the signal, the log of B / A for θ_PC23 and drag / signal); for θ_PC23's rows also B's
    turn read in A's PC2–PC3 plane and its spread, "in_a_plane" and "spread_in_a_plane";
    "b_in_a_plane": the angle between the planes and those turns by l (None where a run
    has no plane); and each figure's difference pooled over the bins on either side of the
    edge (`pooled_differences`): "pooled", and "pooled_in_a_plane" for θ_PC23 read in A's
    plane."""
    paired = paired_figures(a, b)
    spread, spread_in_plane = paired_figure_spread(a, b, resamples, seed, paired)
    rows = []
    for figure, l in sorted(spread):
        row = {"figure": figure, "lateral_mm": l, "a": paired.a[figure, l], "b": paired.b[figure, l]}
        row["spread"] = spread[figure, l]
        if (figure, l) in spread_in_plane:
            row.update(in_a_plane=paired.b_in_a_plane[figure, l], spread_in_a_plane=spread_in_plane[figure, l])
        rows.append(row)
    in_a = None
    if paired.plane_angle_deg is not None:
        in_a = {"angle_deg": paired.plane_angle_deg}
        for figure, key in THETA_TURN_KEYS.items():
            in_a[key] = {l: v for (f, l), v in paired.b_in_a_plane.items() if f == figure}
    return {
        "taps": sum(not s["labels"].get("no_contact") for s in a.samples),
        "resamples": resamples,
        "seed": seed,
        "rows": rows,
        "b_in_a_plane": in_a,
        "pooled": pooled_differences(rows),
        "pooled_in_a_plane": pooled_differences([r for r in map(read_in_a_plane, rows) if r is not None]),
    }


def read_in_a_plane(row: dict) -> dict | None:
    """A θ_PC23 row of `figure_differences` as B read in A's plane gives it (that value and
    its spread as B's); None for a row without that reading."""
    if "in_a_plane" not in row:
        return None
    return {**row, "b": row["in_a_plane"], "spread": row["spread_in_a_plane"]}


def pooled_differences(rows: list[dict]) -> dict[str, dict[str, dict]]:
    """{figure: {side: pooled}} of `figure_differences`'s rows: B's figure less A's over the
    lateral bins on each side of the edge (calibration_fit.figures.SIDES), each bin weighted
    by the inverse of its paired variance (calibration_fit.figures.pooled_difference: a
    bin's figure may be known to a factor of 4 where its neighbour's is known to 20 %, so a
    plain mean over the bins says what the worst-measured bin says). The bins' taps are
    disjoint, so their differences are independent. A side with a bin whose spread is 0 (no
    resamples) is left out: it cannot be weighted."""
    pooled: dict[str, dict[str, dict]] = {}
    for (figure, side), bins in side_groups(rows, "figure").items():
        if any(r["spread"] <= 0 for r in bins):
            continue
        pooled.setdefault(figure, {})[side] = pooled_difference(
            figure, [r["a"] for r in bins], [r["b"] for r in bins], [r["spread"] for r in bins]
        )
    return pooled


#: tap protocols on the straight edge whose runs compare by the edge figures even unpaired
EDGE_TAP_KINDS = ("taps", "sheared_taps")


def compare_runs(
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
    """Pair the runs' samples by target pose and write comparison.json to `out` (the plots:
    twin.tools.comparison_report).

    Each run's perception error: contour runs report their metrics.json; labelled runs
    (taps, slides) are scored with the model file `model_path` when given. Tap runs also
    get each run's orientation signal per lateral position and slide runs each run's
    along-edge drag (twin.analysis.evaluation), the two figures Table I's along-edge cells
    weigh, side by side for a sim and a real sensor. Two tap runs (plain or sheared, e.g. an
    imported lab recording beside the twin's taps) also get the edge figures
    (twin.analysis.edge_imprint; `slides_a`, `slides_b`: a plain tap run's slides run for
    the along-edge drag; `reach_at`: the lateral positions of the reach profile, mm), and compare by those alone when they share no target pose in
    contact (both start with a no-contact frame at one pose) or differ in resolution (a
    lab camera's 256×256 beside the twin's 640×480: pins compare through the figures).

    Where the runs share taps (twin.runs.pairing.shared_taps: a replay of a recording, or
    of some of its taps), the tap figures of both come from those taps alone: a lateral
    bin's signal ratio differs by 0.13–0.33 between quarters of the DigiTac set's taps,
    so figures from different taps do not compare. A tap in which either run lost a pin
    counts in neither (the DigiTac set's tracker lost one in a tenth of its frames, most at
    the deepest presses onto the object, where a replay loses none). Two sheared-tap runs that
    share taps also get the difference of each edge figure (B against A) and its standard
    deviation over `resamples` bootstrap resamples of the shared taps, the same draw for
    both (seeded by `seed`): "edge_figure_differences"."""
    a, b = load_run(dir_a), load_run(dir_b)
    name_a, name_b = a.meta["scenario"]["name"], b.meta["scenario"]["name"]
    kind, kind_b = a.meta["scenario"]["protocol"]["kind"], b.meta["scenario"]["protocol"]["kind"]
    edge_taps = kind in EDGE_TAP_KINDS and kind_b in EDGE_TAP_KINDS
    if kind != kind_b and not edge_taps:
        raise UserError(
            f"{dir_a} ({kind}) and {dir_b} ({b.meta['scenario']['protocol']['kind']}) are different protocols"
        )
    result: dict = {
        "run_a": str(dir_a),
        "run_b": str(dir_b),
        "backend_a": a.meta["backend"],
        "backend_b": b.meta["backend"],
        "fidelity_a": a.meta["scenario"]["fidelity"],
        "fidelity_b": b.meta["scenario"]["fidelity"],
        "scenario_a": name_a,
        "scenario_b": name_b,
        "protocol": kind,
        "state_a": a.state,
        "state_b": b.state,
        "unfinished": [n for n in (a.unfinished_note(), b.unfinished_note()) if n],
    }
    if kind == "contour":
        result["path_distance"] = _path_distance(a, b)
        for tag, run in (("a", a), ("b", b)):
            metrics = run.path / "metrics.json"
            if metrics.exists():
                result[f"metrics_{tag}"] = json.loads(metrics.read_text())
    elif model_path is not None:
        model = PerceptionModel.load(model_path)
        result["perception_a"], result["perception_b"] = perception_error(a, model), perception_error(b, model)
    by_target = pair_samples(a, b) if edge_taps else []
    shared = taps_both_kept(a, b, by_target) if edge_taps and kind == kind_b else []
    if not any(not a.samples[i]["labels"].get("no_contact") for i, _ in shared):
        shared = []  # a no-contact frame at one pose alone is no shared tap
    result["shared_taps"] = len(shared)
    taps_a, taps_b = (a.subset([i for i, _ in shared]), b.subset([j for _, j in shared])) if shared else (a, b)
    if kind == "taps":  # what each sensor's taps carry of the edge's orientation, by lateral position
        result["orientation_signal_px"] = {"a": orientation_signal_px(taps_a), "b": orientation_signal_px(taps_b)}
    elif kind == "slides":  # how far each sensor's skin is dragged along the edge
        result["along_edge_drag_px"] = {"a": along_edge_drag_px(a), "b": along_edge_drag_px(b)}
    if edge_taps:  # what each sensor's taps carry of the edge, and how a slide drags its pins
        result["edge_figures"] = {
            tag: edge_figures(run, None if slides is None else load_run(slides), reach_at)
            for tag, run, slides in (("a", taps_a, slides_a), ("b", taps_b, slides_b))
        }
        if shared and is_sheared(taps_a) and is_sheared(taps_b):
            result["edge_figure_differences"] = figure_differences(taps_a, taps_b, resamples, seed)
        in_contact = [(i, j) for i, j in by_target if not a.samples[i]["labels"].get("no_contact")]
        if kind != kind_b or not in_contact or a.resolution != b.resolution:
            result.update(pairing=None, n_pairs=0, n_a=len(a.samples), n_b=len(b.samples))
            return _written(result, out)
    pairs, result["pairing"] = paired_runs(a, b)
    ia, ib, diff = pin_differences(a, b, pairs)
    disp_a, disp_b = displacements(a)[ia], displacements(b)[ib]
    corr = []
    for k in range(diff.shape[1]):
        va, vb = disp_a[:, k].ravel(), disp_b[:, k].ravel()
        if np.std(va) > 1e-9 and np.std(vb) > 1e-9:
            corr.append(float(np.corrcoef(va, vb)[0, 1]))
    result.update(
        n_pairs=len(pairs),
        n_a=len(a.samples),
        n_b=len(b.samples),
        pin_rms_difference_px=float(np.sqrt(np.nanmean(diff**2))),
        pin_displacement_correlation={
            "mean": float(np.mean(corr)) if corr else None,
            "min": float(np.min(corr)) if corr else None,
            "pins": len(corr),
        },
    )
    ssims = []
    step = max(1, len(pairs) // max_ssim_frames)
    for i, j in pairs[::step]:
        fa, fb = a.frame(i), b.frame(j)
        if fa is not None and fb is not None:
            ssims.append(_ssim(fa, fb))
    result["ssim"] = (
        {"mean": float(np.mean(ssims)), "min": float(np.min(ssims)), "frames": len(ssims)} if ssims else None
    )
    return _written(result, out)


def _written(result: dict, out: Path) -> dict:
    """`result`, after writing it to out/comparison.json."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "comparison.json").write_text(json.dumps(jsonable(result), indent=1, default=float))
    return result
