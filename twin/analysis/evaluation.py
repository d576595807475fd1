"""The paper's offline experiment (§IV-A), behind `twin evaluate`: train PCA+GP and the
raw-pin baseline on a tap run, test on a multi-directional sliding run: Table I, the
lateral error, the variance explained and the PCA figures' projections, with what the
along-edge cells weigh against each other: the taps' orientation signal per lateral
position and the slides' drag (both in px, for a twin's runs and a rig's alike). Tested on
a tap run instead (held-out taps, scenarios/taps_heldout.yaml), the orientation and
lateral errors per lateral position. Text and figures: twin.tools.evaluation_report."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from twin.core.errors import UserError
from twin.core.poses import wrap_deg
from twin.runs.record import Run, jsonable, load_run
from twin.runs.training import train_from_run
from twin.sensing.perception import PerceptionModel, angle_error_deg, pca_fit, pins_to_vectors, without_uniform_shift

DIRECTIONS = (0, 45, 90, 135, 180, 225, 270, 315)
#: Table I of the paper (RMS orientation error, deg): direction → (On, Off); 90°/270° On only.
PAPER_TABLE_I = {
    "GP baseline": {
        0: (26.01, 16.59),
        45: (2.94, 8.02),
        90: (50.68, None),
        135: (92.37, 99.59),
        180: (127.18, 145.27),
        225: (141.56, 153.39),
        270: (90.32, None),
        315: (50.10, 31.97),
    },
    "PCA + GP": {
        0: (49.41, 10.17),
        45: (24.17, 8.24),
        90: (3.27, None),
        135: (22.74, 10.82),
        180: (46.74, 14.61),
        225: (52.67, 11.98),
        270: (12.66, None),
        315: (51.87, 12.77),
    },
}
PAPER_VARIANCE_3PC = 0.883
PAPER_LATERAL_RMS_MM = 2.15
#: the slides along the edge, the contour's own direction (deg; Table I's On-only columns)
ALONG_EDGE_DEG = (90, 270)


def _rms(x: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(x**2))) if len(x) else None


def on_off(rows: dict[int, dict[str, float | None]]) -> dict[int, tuple[float | None, float | None]]:
    """One model's Table I rows, {direction: {"on", "off"}}, as the paper's table holds them:
    {direction: (On, Off)} (deg)."""
    return {d: (rows[d]["on"], rows[d]["off"]) for d in DIRECTIONS}


def paper_finding(table: dict[str, dict[int, tuple[float | None, float | None]]]) -> dict:
    """The paper's finding read off Table I, {model: {direction: (On, Off)}} RMS deg: the
    PCA + GP errors along the edge ("along_deg", {90, 270: deg}), how many times as large the
    raw-pin GP baseline's are there ("raw_over_pca"), and in how many of the columns with an
    Off group the PCA + GP's Off error is below its On error ("off_below_on" of "columns")."""
    pca, raw = table["PCA + GP"], table["GP baseline"]
    crossing = [d for d in DIRECTIONS if pca[d][1] is not None]
    return {
        "along_deg": {d: pca[d][0] for d in ALONG_EDGE_DEG},
        "raw_over_pca": {d: raw[d][0] / pca[d][0] for d in ALONG_EDGE_DEG},
        "off_below_on": sum(pca[d][1] < pca[d][0] for d in crossing),
        "columns": len(crossing),
    }


def table_i(test: Run, predictions: dict[str, np.ndarray]) -> dict:
    """{model: {direction: {"on": rms, "off": rms}}} of the orientation error (deg)."""
    theta = test.label("theta_deg")
    direction = test.label("direction_deg")
    on = np.array([bool(s["labels"].get("on_object", False)) for s in test.samples])
    table = {}
    for name, theta_hat in predictions.items():
        err = angle_error_deg(theta_hat, theta)
        table[name] = {
            int(d): {"on": _rms(err[(direction == d) & on]), "off": _rms(err[(direction == d) & ~on])}
            for d in DIRECTIONS
        }
    return table


def heldout_table(test: Run, predictions: dict) -> dict:
    """{model: {lateral_mm: {"theta_rms_deg", "lateral_rms_mm", "n"}}} of a tap run's
    errors per lateral position (mm, as labelled; a sheared-taps run's, drawn at random,
    to the nearest mm), from predictions with theta_deg and lateral_mm (deg, mm)."""
    theta, lateral = test.label("theta_deg"), test.label("lateral_mm")
    sheared = test.meta.get("scenario", {}).get("protocol", {}).get("kind") == "sheared_taps"
    group = np.round(lateral) + 0.0 if sheared else lateral
    table = {}
    for name, pred in predictions.items():
        theta_err = angle_error_deg(pred.theta_deg, theta)
        lateral_err = pred.lateral_mm - lateral
        table[name] = {
            float(l): {
                "theta_rms_deg": _rms(theta_err[group == l]),
                "lateral_rms_mm": _rms(lateral_err[group == l]),
                "n": int(np.sum(group == l)),
            }
            for l in sorted(set(group.tolist()), reverse=True)
        }
    return table


def orientation_signal_by_pin_px(taps: Run) -> dict[float, dict[float, np.ndarray]]:
    """{depth_mm: {lateral_mm: (pins,) px}}: each pin's spread over a tap run's
    orientations at each depth and lateral position (RMS distance from its mean position
    there), in px at the run's resolution; positions with one tap or a pin not found are
    left out."""
    pins, depth, lateral = taps.pins_px, taps.label("depth_mm"), taps.label("lateral_mm")
    table: dict[float, dict[float, np.ndarray]] = {}
    for d in sorted(set(depth[np.isfinite(depth)].tolist())):
        table[float(d)] = {}
        for l in sorted(set(lateral[depth == d].tolist()), reverse=True):
            group = pins[(depth == d) & (lateral == l)]
            if len(group) > 1 and np.isfinite(group).all():
                table[float(d)][float(l)] = np.sqrt(np.mean(np.sum((group - group.mean(axis=0)) ** 2, axis=-1), axis=0))
    return table


def orientation_signal_px(taps: Run) -> dict[float, dict[float, float]]:
    """{depth_mm: {lateral_mm: px}}: how much of the edge's orientation a tap run's frames
    carry at each depth and lateral position: each pin's spread over the run's
    orientations (`orientation_signal_by_pin_px`), RMS over the pins, in px at the run's
    resolution. A drag larger than this where a slide runs outweighs the edge in any
    reading of the pins, PCA or raw."""
    return {d: {l: _rms(spread) for l, spread in row.items()} for d, row in orientation_signal_by_pin_px(taps).items()}


def along_edge_drag_px(slides: Run) -> dict[int, float | None]:
    """{direction: px} for the slides along the edge (90°, 270°), where the lateral
    position stays as it was pressed and only the drag changes the pins: the pins' shift
    from each slide's first, unslid sample (`sample_in_slide` 0), RMS over the pins and
    the slide's later samples, in px at the run's resolution. None where the run has no
    such slide."""
    pins, theta = slides.pins_px, slides.label("theta_deg")
    direction, sample = slides.label("direction_deg"), slides.label("sample_in_slide")
    drag: dict[int, float | None] = {}
    for d in (90, 270):
        distances = []
        for t in set(theta[direction == d].tolist()):
            slide = (direction == d) & (theta == t)
            first = slide & (sample == 0)
            if first.sum() == 1:
                distances.append(np.linalg.norm(pins[slide & (sample > 0)] - pins[first], axis=-1).ravel())
        drag[d] = _rms(np.concatenate(distances)) if distances else None
    return drag


def pc23_handedness(plane_px: np.ndarray, theta_deg: np.ndarray) -> int:
    """+1 where θ_PC23 turns with θ over these frames (M, 2) px, −1 where against it. Each
    PC's sign is a convention (twin.sensing.perception: its largest loading positive), so a
    tap set's pair can read the edge either way round; the GPs take cos and sin of θ_PC23
    and do not care, but an offset θ_PC23 − θ means something only with the turn's sense."""
    spreads = {s: _offset_deg(plane_px, theta_deg, s)["spread_deg"] for s in (1, -1)}
    return min(spreads, key=spreads.get)


def _offset_deg(plane_px: np.ndarray, theta_deg: np.ndarray, handedness: int = 1) -> dict[str, float]:
    """Frames in the PC2–PC3 plane (M, 2) px against their true θ: "radius_px" (RMS),
    "offset_deg" (the circular mean of θ_PC23 − handedness·θ) and "spread_deg" (RMS about it)."""
    diff = np.radians(np.degrees(np.arctan2(plane_px[:, 1], plane_px[:, 0])) - handedness * theta_deg)
    offset = float(np.degrees(np.angle(np.mean(np.exp(1j * diff)))))
    return {
        "radius_px": float(np.sqrt(np.mean(np.sum(plane_px**2, axis=1)))),
        "offset_deg": offset,
        "spread_deg": float(np.sqrt(np.mean(wrap_deg(np.degrees(diff) - offset) ** 2))),
    }


def _drag_in_plane_px(
    model: PerceptionModel, slides: Run, pins_px: np.ndarray, plane_px: np.ndarray, sliding: np.ndarray
) -> dict[str, float]:
    """The along-edge drag's part in the taps' PC2–PC3 plane, RMS over the `sliding` samples
    (px): "all" (the sliding frame's place there less its slide's unslid first sample's),
    "rigid_shift" (the part of the drag's uniform shift, each pin moved by the drag's mean)
    and "rest" (the rest of the drag, the field's non-uniform part); all = rigid_shift + rest
    as vectors in the plane, so two large parts can cancel. pins_px: the run's pins;
    plane_px: their places in the plane (`PerceptionModel.pc23_px`), where the caller has them."""
    theta, direction = slides.label("theta_deg"), slides.label("direction_deg")
    first = {
        (direction[i], theta[i]): i for i in np.flatnonzero(slides.label("sample_in_slide") == 0)
    }  # a slide recorded without its first sample has no pressed frame to compare with
    sliding = np.array([i for i in sliding if (direction[i], theta[i]) in first], int)
    pressed = np.array([first[direction[i], theta[i]] for i in sliding], int)
    shifted_px = pins_px[pressed] + (pins_px[sliding] - pins_px[pressed]).mean(axis=1, keepdims=True)
    shifted = model.pc23_px(shifted_px, slides.resolution)
    parts = {
        "all": plane_px[sliding] - plane_px[pressed],
        "rigid_shift": shifted - plane_px[pressed],
        "rest": plane_px[sliding] - shifted,
    }
    return {name: float(np.sqrt(np.mean(np.sum(v**2, axis=1)))) for name, v in parts.items()}


def along_edge_reading(model: PerceptionModel, taps: Run, slides: Run) -> dict | None:
    """Where the along-edge slides (90°, 270°) sit in the taps' PC2–PC3 plane, the plane the
    PCA + GP reads θ from: for the taps at the slides' lateral position, per depth, and for
    each direction's unslid first samples ("pressed") and sliding ones ("sliding"), the
    frames' RMS radius (px, about the model's origin) and θ_PC23 ∓ θ (deg, circular mean,
    with the RMS about it; the sign by the sense all the taps turn in, `pc23_handedness`).
    Frames read as the taps do where their offset is the taps'; a drag that outweighs the
    taps' radius there turns it to the slide's own direction, the two directions' 180°
    apart. Each direction's "drag_in_plane" (`_drag_in_plane_px`) says which part of the
    drag lands there. {"lateral_mm", "handedness", "taps": {depth: figures},
    90: {"pressed", "sliding", "drag_in_plane"}, 270: ...}; None without along-edge slides."""
    direction, sample = slides.label("direction_deg"), slides.label("sample_in_slide")
    along = np.isin(direction, (90, 270))
    if not along.any():
        return None
    lateral = float(slides.label("lateral_mm")[along & (sample == 0)][0])
    t_depth, t_theta = taps.label("depth_mm"), taps.label("theta_deg")
    t_plane = model.pc23_px(taps.pins_px, taps.resolution)
    sense = pc23_handedness(t_plane, t_theta)
    reading: dict = {"lateral_mm": lateral, "handedness": sense, "taps": {}}
    at = np.isclose(taps.label("lateral_mm"), lateral)
    for depth in sorted(set(t_depth[at].tolist())):
        m = at & (t_depth == depth)
        reading["taps"][float(depth)] = _offset_deg(t_plane[m], t_theta[m], sense)
    theta, pins = slides.label("theta_deg"), slides.pins_px
    plane = np.full((len(pins), 2), np.nan)
    plane[along] = model.pc23_px(pins[along], slides.resolution)
    for d in (90, 270):
        phases = {"pressed": (direction == d) & (sample == 0), "sliding": (direction == d) & (sample > 0)}
        if all(m.any() for m in phases.values()):
            reading[d] = {name: _offset_deg(plane[m], theta[m], sense) for name, m in phases.items()}
            reading[d]["drag_in_plane"] = _drag_in_plane_px(
                model, slides, pins, plane, np.flatnonzero(phases["sliding"])
            )
    return reading


def shift_free_table_i(train: Run, test: Run, seed: int = 0) -> dict:
    """Table I's PCA + GP row with every frame's uniform shift (its mean pin displacement
    from the training run's rest pins) taken out before the model is trained and run:
    the paper's pipeline in a PC2–PC3 plane that no rigid shift of the pins enters, as none
    enters the edge figures' (twin.analysis.edge_imprint). Where the along-edge cells read
    well as recorded and poorly without the shift, the shift's part of the drag is what
    cancels the rest in the plane. {"PCA + GP": {direction: {"on", "off"}}} (deg RMS)."""
    rest = train.rest_pins_px
    model = train_from_run(train, "pca", seed, pins_px=without_uniform_shift(train.pins_px, rest))
    theta = model.predict(without_uniform_shift(test.pins_px, rest), resolution=test.resolution).theta_deg
    return table_i(test, {"PCA + GP": theta})


def evaluate(train_dir: Path, test_dir: Path, out: Path, seed: int = 0, shift_free: bool = False) -> dict:
    """Train on `train_dir` (tap run), test on `test_dir`: a slides run (Table I) or a
    held-out tap run (errors per lateral position); write the results (json, csv) and the
    trained models (Table I) to `out`. The PCA figures are twin.tools.evaluation_report's.
    `shift_free`: Table I's PCA + GP row also without the frames' uniform shift
    (`shift_free_table_i`; one more PCA + GP training), "table_i_shift_free"."""
    train, test = load_run(train_dir), load_run(test_dir)
    taps = not np.isfinite(test.label("direction_deg")).any()
    if not (taps or np.all(np.isfinite(test.label("direction_deg")))):
        raise UserError(f"{test_dir}: not a multi-directional run (samples need direction_deg labels)")
    if taps and shift_free:
        raise UserError(
            f"{test_dir}: --shift-free reads Table I, and this is a tap run (held-out taps); test on a slides run"
        )
    if not np.all(np.isfinite(test.label("theta_deg")) & np.isfinite(test.label("lateral_mm"))):
        raise UserError(f"{test_dir}: neither a slides nor a tap run (samples need theta_deg and lateral_mm labels)")
    models = {"PCA + GP": train_from_run(train, "pca", seed), "GP baseline": train_from_run(train, "baseline", seed)}
    preds = {name: m.predict(test.pins_px, resolution=test.resolution) for name, m in models.items()}
    summary = {
        "train_run": str(train_dir),
        "test_run": str(test_dir),
        "n_train": len(train.samples),
        "n_test": len(test.samples),
        "run_states": {"train": train.state, "test": test.state},
        "unfinished": [n for n in (train.unfinished_note(), test.unfinished_note()) if n],
        "orientation_rms_deg": {
            n: _rms(angle_error_deg(p.theta_deg, test.label("theta_deg"))) for n, p in preds.items()
        },
        "lateral_rms_mm": {n: _rms(p.lateral_mm - test.label("lateral_mm")) for n, p in preds.items()},
    }
    if taps:
        return _write_heldout(summary, heldout_table(test, preds), out)
    table = table_i(test, {n: p.theta_deg for n, p in preds.items()})
    pca = models["PCA + GP"]
    result = {
        **summary,
        "table_i_rms_orientation_deg": table,
        "paper_finding": paper_finding({name: on_off(rows) for name, rows in table.items()}),
        "variance_explained_3pc": float(np.sum(pca.variance_explained[:3])),
        "orientation_signal_px": orientation_signal_px(train),
        "along_edge_drag_px": along_edge_drag_px(test),
        "along_edge_reading": along_edge_reading(pca, train, test),
        **({"table_i_shift_free": shift_free_table_i(train, test, seed)} if shift_free else {}),
        "paper": {
            "table_i": PAPER_TABLE_I,
            "finding": paper_finding(PAPER_TABLE_I),
            "variance_explained_3pc": PAPER_VARIANCE_3PC,
            "lateral_rms_mm": PAPER_LATERAL_RMS_MM,
        },
        "training": {n: m.training_summary for n, m in models.items()},
    }
    _write_results(
        out,
        "table_i",
        result,
        ["model", "direction_deg", "group", "rms_orientation_error_deg", "paper_deg"],
        [
            [name, d, group, rows[d][group], PAPER_TABLE_I[name][d][i]]
            for name, rows in table.items()
            for d in DIRECTIONS
            for i, group in enumerate(("on", "off"))
        ],
    )
    for name, m in models.items():
        m.save(out / f"model_{'pca' if name == 'PCA + GP' else 'baseline'}.npz")
    return result


def _write_heldout(summary: dict, table: dict, out: Path) -> dict:
    """The held-out taps' results (`summary` with the per-lateral `table`): heldout.json and
    heldout.csv in `out`."""
    result = {**summary, "heldout_by_lateral_mm": table}
    _write_results(
        out,
        "heldout",
        result,
        ["model", "lateral_mm", "theta_rms_deg", "lateral_rms_mm", "n"],
        [
            [name, l, row["theta_rms_deg"], row["lateral_rms_mm"], row["n"]]
            for name, rows in table.items()
            for l, row in rows.items()
        ],
    )
    return result


def _write_results(out: Path, stem: str, result: dict, header: list[str], rows: list[list]) -> None:
    """`result` as out/<stem>.json and its table (`header`, `rows`) as out/<stem>.csv."""
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps(jsonable(result), indent=1))
    with open(out / f"{stem}.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)


def pca_projections(train: Run, test: Run) -> dict[str, np.ndarray]:
    """The data of Figs. 5–6: the sliding set on its own first 5 PCs ("own", (N, 5)) and on
    the tap set's first 3 ("tap", (N, 3)), with each sample's true orientation and sliding
    direction ("theta_deg", "direction_deg", (N,), deg)."""
    z_test = pins_to_vectors(test.pins_px)
    mean_t, comps_t, _ = pca_fit(z_test, 5)
    mean_tap, comps_tap, _ = pca_fit(pins_to_vectors(train.pins_px), 3)
    return {
        "own": (z_test - mean_t) @ comps_t.T,
        "tap": (z_test - mean_tap) @ comps_tap.T,
        "theta_deg": test.label("theta_deg"),
        "direction_deg": test.label("direction_deg"),
    }
