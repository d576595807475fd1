"""`twin bench sweep`'s files: the sweep (twin.analysis.sweep), then sweep.csv, sweep.json,
the markdown table sweep.md (also printed) and the fronts' plot pareto.png."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from twin.analysis.sweep.fronts import (
    ERROR_MARGIN_ABS,
    ERROR_MARGIN_REL,
    FRONTS,
    PIN_METRICS,
    TIME_MARGIN,
    default_on_front,
    is_finite_number,
)
from twin.analysis.sweep.knobs import BASE_DOME, DEFAULT, REFERENCES, Setting
from twin.analysis.sweep.measure import run_sweep
from twin.analysis.sweep.probe import Probe

#: pareto.png's marker per dome model
DOME_MARKERS: dict[str, str] = {"flex": "o", "compliant": "^"}
#: Axis labels of the accuracy columns (pareto.png: one panel per column of FRONTS).
METRIC_LABELS: dict[str, str] = {
    "pin_rms_px": "pin error (px RMS)",
    "pin_settling_rms_px": "settling error (px RMS)",
    "theta_rms_deg": "orientation error on the slides (deg RMS)",
    "contour_completed_mm": "contour error on the rectangle, completed runs (mm, mean)",
}

#: Column order of the CSV (everything a row can hold; missing values are blank).
CSV_COLUMNS: tuple[str, ...] = (
    "setting",
    "knob",
    "output",
    "dome",
    "fidelity",
    "cellcount",
    "timestep_s",
    "settle_px",
    "camera",
    "msaa",
    "renderer",
    "effects",
    "status",
    "stage",
    "error",
    "physics_ms",
    "render_ms",
    "track_ms",
    "perception_ms",
    "total_ms",
    "time_x_default",
    "time_x_default_min",
    "time_x_default_max",
    "physics_x_default",
    "physics_x_default_min",
    "physics_x_default_max",
    "physics_wall_ms",
    "render_wall_ms",
    "track_wall_ms",
    "perception_wall_ms",
    "total_wall_ms",
    "pin_rms_px",
    "pin_physics_rms_px",
    "pin_tracking_rms_px",
    "pin_settling_rms_px",
    "theta_rms_deg",
    "lateral_rms_mm",
    "contour_path_mean_mm",
    "contour_completed_mm",
    "contour_path_max_mm",
    "contour_orientation_rms_deg",
    "contour_steps",
    "contour_stop",
    "contour_coverage",
    "on_front",
    "dominated_by",
    "on_front_theta",
    "on_front_contour",
    "on_front_all",
    "n_taps",
    "n_slide_frames",
    "n_timed_frames",
    "train_s",
    "wall_s",
    "note",
)


def sweep_and_report(
    out: Path,
    quick: bool = False,
    workers: int | None = None,
    cluster: str | None = None,
    settings: list[Setting] | None = None,
    probe: Probe | None = None,
    seed: int = 0,
    verbose: bool = True,
) -> list[dict]:
    """Run the sweep (twin.analysis.sweep.measure.run_sweep, the same arguments) and write
    sweep.csv, sweep.json, sweep.md and pareto.png to `out`. Returns the rows (dicts with
    the CSV_COLUMNS keys present)."""
    rows, meta = run_sweep(
        quick=quick, workers=workers, cluster=cluster, settings=settings, probe=probe, seed=seed, verbose=verbose
    )
    write_outputs(rows, meta, Path(out), verbose=verbose)
    return rows


def write_outputs(rows: list[dict], meta: dict, out: Path, verbose: bool = False) -> None:
    """Write sweep.csv, sweep.json ({"meta", "rows"}; non-finite numbers as null),
    pareto.png and sweep.md to `out`. To redraw a finished sweep (e.g. with other margins):
    data = json.load(open("sweep.json")); write_outputs(annotate_fronts(data["rows"]), data["meta"], out)."""
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / "sweep.csv")
    clean = [{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()} for r in rows]
    (out / "sweep.json").write_text(json.dumps({"meta": meta, "rows": clean}, indent=1, default=_json_default))
    plot_pareto(rows, out / "pareto.png")
    (out / "sweep.md").write_text(markdown_table(rows, meta))
    if verbose:
        print()
        print(markdown_table(rows, meta))
        print(f"wrote {out / 'sweep.csv'}, {out / 'sweep.md'}, {out / 'pareto.png'}, {out / 'sweep.json'}")


def _json_default(v):
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    return str(v)


def write_csv(rows: list[dict], path: Path) -> Path:
    """All rows with CSV_COLUMNS (blank where a row has no value)."""
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(CSV_COLUMNS), extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _csv_value(row.get(k)) for k in CSV_COLUMNS})
    return path


def _csv_value(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return v


def _fmt(v, digits: int = 1) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def _dominator_text(rows: list[dict]) -> str:
    """'name (Δ ms/frame, Δ px pin error, Δ px settling error)' for each setting that
    dominates the default (no settling term when either row lacks the figure)."""
    by = {r["setting"]: r for r in rows}
    d = by[DEFAULT]
    parts = []
    for name in (d.get("dominated_by") or "").split():
        r = by[name]
        settling = (
            ""
            if not (is_finite_number(r.get("pin_settling_rms_px")) and is_finite_number(d.get("pin_settling_rms_px")))
            else f", {r['pin_settling_rms_px'] - d['pin_settling_rms_px']:+.2f} px settling error"
        )
        parts.append(
            f"{name} ({r['total_ms'] - d['total_ms']:+.1f} ms/frame, "
            f"{r['pin_rms_px'] - d['pin_rms_px']:+.2f} px pin error{settling})"
        )
    return ", ".join(parts) or "another setting"


def _contour_cell(r: dict) -> str:
    """'mean mm (steps, how it ended)' of a row's contour run."""
    if not is_finite_number(r.get("contour_path_mean_mm")):
        return "—"
    return f"{r['contour_path_mean_mm']:.1f} ({r.get('contour_steps')}, {r.get('contour_stop')})"


def _timing_note(meta: dict) -> str:
    """How the times were measured (a sweep.json from before the timing pass has no 'timing')."""
    timing = meta.get("timing")
    if timing is None:
        return (
            "Times: CPU ms per frame of the accuracy job's process over the slide and contour frames, measured "
            "beside the other parallel jobs."
        )
    angles = ", ".join(f"{a:g}" for a in timing["orientations_deg"])
    return (
        "Times: CPU ms per frame; physics (move into the frame + settle), render and tracking from the timing "
        f"pass (each setting alone on the machine after the accuracy jobs, in rounds that run every setting once, "
        f"best of {timing['repeats']} rounds after an untimed one, over the slides at θ = {angles}°), perception "
        "from the accuracy job; × default: physics + render + tracking against the default's, best against best, "
        "and in brackets the lowest and highest ratio within one round; wall-clock figures of the accuracy jobs "
        "in sweep.csv."
    )


def _ratio_cell(r: dict) -> str:
    """'1.21 (1.18–1.25)': the timed stages against the default's, best against best (the
    lowest–highest ratio within one round); '—' where not timed against a default."""
    if not is_finite_number(r.get("time_x_default")):
        return "—"
    return f"{r['time_x_default']:.2f} ({r['time_x_default_min']:.2f}–{r['time_x_default_max']:.2f})"


def markdown_table(rows: list[dict], meta: dict) -> str:
    """The sweep's table (in docs/accuracy-cost.md): one line per setting, then the verdict and how it was measured."""
    head = (
        "| setting | knob | physics | render | tracking | perception | **total ms/frame** | × default | "
        "pin err px (phys / track) | settling err px | θ err ° | l err mm | contour err mm (steps, end) | front | "
        "contour front |"
    )
    lines = [head, "|" + "|".join(["---"] * (head.count("|") - 1)) + "|"]
    for r in rows:
        name = f"**{r['setting']}**" if r["setting"] in (DEFAULT, *REFERENCES.values()) else r["setting"]
        if r["status"] != "ok":
            name += f" ⚠ failed in {r['stage']}"
        pin = (
            f"{_fmt(r.get('pin_rms_px'), 2)} ({_fmt(r.get('pin_physics_rms_px'), 2)} / "
            f"{_fmt(r.get('pin_tracking_rms_px'), 2)})"
        )
        front = {True: "●", False: "", None: "—"}[r.get("on_front")]
        contour_front = {True: "●", False: "", None: "—"}[r.get("on_front_contour")]
        lines.append(
            f"| {name} | {r['knob']} | {_fmt(r.get('physics_ms'))} | {_fmt(r.get('render_ms'))} | "
            f"{_fmt(r.get('track_ms'))} | {_fmt(r.get('perception_ms'))} | **{_fmt(r.get('total_ms'))}** | "
            f"{_ratio_cell(r)} | {pin} | {_fmt(r.get('pin_settling_rms_px'), 2)} | {_fmt(r.get('theta_rms_deg'))} | "
            f"{_fmt(r.get('lateral_rms_mm'), 2)} | "
            f"{_contour_cell(r)} | {front} | {contour_front} |"
        )
    on = default_on_front(rows)
    default_camera = next((r.get("camera") for r in rows if r["setting"] == DEFAULT), "—")
    if on is None:
        verdict = "The default was not measured (or failed), so its place on the front is unknown."
    elif on:
        verdict = (
            "The default lies on the Pareto front (time vs pin and settling error, frame-producing "
            f"settings at {default_camera})."
        )
    else:
        verdict = (
            "**The default is NOT on the Pareto front** (time vs pin and settling error, frame-producing "
            f"settings at {default_camera}): dominated by {_dominator_text(rows)}."
        )
    p = meta["probe"]
    failures = meta["failures"]
    notes = [
        "",
        verdict,
        f"Failures: {len(failures)}" + (": " + "; ".join(failures) if failures else "."),
        "",
        f"Measured {meta['date']} on {meta['machine']}, GL {meta['gl']}, {meta['workers']} parallel job(s) "
        f"({'quick' if meta['quick'] else 'full'} sweep, {meta['wall_s']:.0f} s). Each setting turns one knob of the "
        "default scenario (rectangle, fidelity default, contact + friction + render, 640×480, no MSAA). "
        f"Probe: {len(p['tap_orientations_deg'])} orientations × {len(p['lateral_mm'])} lateral × "
        f"{len(p['tap_depths_mm'])} depths taps train PCA + GP; {len(p['slide_orientations_deg'])} orientations × "
        f"{len(p['directions_deg'])} directions × {len(p['lateral_mm'])} samples of slides test it; contour following "
        f"of the rectangle (≤ {p['contour_max_steps']} steps). {_timing_note(meta)} Pin error: px RMS at 640×480 against the true pins "
        "of its own dome model's reference (flex: reference, compliant: compliant_reference) at the same poses (physics "
        "part: the setting's true pins; tracking part: tracked vs its own true pins); the two models' pin errors are "
        "never compared with each other. "
        "Settling error: px RMS at 640×480 of the setting's true pins against the same frames settled on to "
        "convergence (untimed): what the settle tolerance leaves, which the pin error (mostly the grid's "
        "discretisation) cannot see. "
        "θ/l error: RMS on the slide probe. Contour error: mean distance of the path from the contour. "
        "● = on the Pareto front of time vs pin error and settling error together (dominated only by a setting no "
        "slower and no worse in both, and better in one; time compared round by round: no slower and faster "
        "only if so in every round of the timing pass) among settings of the same output (rendered frames vs "
        "projected pins) and, for frames, the same camera (the resolution is the simulated camera's spec, not a "
        "fidelity knob; other resolutions show what a different camera would cost), with noise margins "
        f"({TIME_MARGIN:.0%} time; {ERROR_MARGIN_REL:.0%} or {ERROR_MARGIN_ABS['pin_rms_px']} px pin error, "
        f"{ERROR_MARGIN_ABS['pin_settling_rms_px']} px settling error) and of the same dome model. Contour front: "
        "time vs the contour error, the same peers but across both dome models (the error is against the true "
        "contour), among the runs that complete the contour (close the loop or reach its end), margin "
        f"{ERROR_MARGIN_ABS['contour_completed_mm']} mm. Full figures: sweep.csv; plot: pareto.png.",
    ]
    return "\n".join(lines + notes) + "\n"


def plot_pareto(rows: list[dict], path: Path) -> Path:
    """Accuracy against time per frame, one panel per accuracy column of FRONTS; fronts drawn
    per output kind (a line for a one-column front; the members of a several-column front,
    which no single panel can show as a line, ringed), the default starred and the
    reference squared (matplotlib, Agg)."""

    matplotlib.use("Agg")

    panels = [(metric, key, len(metrics) > 1) for key, metrics in FRONTS for metric in metrics]
    ncols = 2
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.4 * ncols, 5.2 * nrows), dpi=110, squeeze=False)
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    colours = {"frames": "tab:blue", "pins": "tab:orange"}
    for ax, (metric, key, ringed) in zip(axes.ravel(), panels):
        label = METRIC_LABELS[metric]
        for output, colour in colours.items():
            pts = [
                r
                for r in rows
                if r["output"] == output and is_finite_number(r.get("total_ms")) and is_finite_number(r.get(metric))
            ]
            bad = [r for r in pts if r["status"] != "ok"]
            pts = [r for r in pts if r["status"] == "ok"]
            if bad:  # figures measured before the failure, never on a front
                ax.scatter(
                    [r["total_ms"] for r in bad],
                    [r[metric] for r in bad],
                    marker="x",
                    c="red",
                    s=30,
                    zorder=3,
                    label="failed (partial figures)",
                )
                for r in bad:
                    ax.annotate(
                        r["setting"],
                        (r["total_ms"], r[metric]),
                        fontsize=6,
                        xytext=(3, 3),
                        textcoords="offset points",
                        color="red",
                    )
            if not pts:
                continue
            for dome, marker in DOME_MARKERS.items():
                mine = [r for r in pts if r.get("dome", BASE_DOME) == dome]
                if mine:
                    ax.scatter(
                        [r["total_ms"] for r in mine],
                        [r[metric] for r in mine],
                        c=colour,
                        s=22,
                        zorder=3,
                        marker=marker,
                        label=("rendered + tracked" if output == "frames" else "projected pins")
                        + ("" if dome == BASE_DOME else f" ({dome} dome)"),
                    )
            # a pin metric's front is per dome model (each against its own reference), the others across both
            for dome in list(DOME_MARKERS) if metric in PIN_METRICS else [None]:
                front = sorted(
                    (r for r in pts if r.get(key) and (dome is None or r.get("dome", BASE_DOME) == dome)),
                    key=lambda r: r["total_ms"],
                )
                if front and ringed:
                    ax.scatter(
                        [r["total_ms"] for r in front],
                        [r[metric] for r in front],
                        s=90,
                        facecolor="none",
                        edgecolor=colour,
                        lw=1.0,
                        zorder=2,
                        label="on the pin + settling error front",
                    )
                elif front:
                    ax.step(
                        [r["total_ms"] for r in front],
                        [r[metric] for r in front],
                        where="post",
                        color=colour,
                        lw=1.0,
                        alpha=0.7,
                        zorder=2,
                    )
            for r in pts:
                ax.annotate(
                    r["setting"], (r["total_ms"], r[metric]), fontsize=6, xytext=(3, 3), textcoords="offset points"
                )
                if r["setting"] == DEFAULT:
                    ax.scatter(
                        [r["total_ms"]],
                        [r[metric]],
                        marker="*",
                        s=220,
                        facecolor="none",
                        edgecolor="red",
                        lw=1.2,
                        zorder=4,
                        label="default",
                    )
                if r["setting"] in REFERENCES.values():
                    ax.scatter(
                        [r["total_ms"]],
                        [r[metric]],
                        marker="s",
                        s=90,
                        facecolor="none",
                        edgecolor="k",
                        lw=1.0,
                        zorder=4,
                        label="reference",
                    )
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("CPU time per frame (ms, log)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    failed = [r["setting"] for r in rows if r["status"] != "ok"]
    title = "What accuracy costs in time (lines and rings: Pareto fronts)"
    if failed:
        title += f" — {len(failed)} failed: {', '.join(failed)}"
    fig.suptitle(title, fontsize=10)
    uniq: dict = {}
    for ax in axes.ravel():
        handles, labels = ax.get_legend_handles_labels()
        uniq.update(zip(labels, handles))
    fig.legend(uniq.values(), uniq.keys(), fontsize=8, loc="lower center", ncol=len(uniq), frameon=False)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path)
    plt.close(fig)
    return path
