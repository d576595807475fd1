"""`twin calibrate`'s report: the fit (twin.analysis.calibration_fit), then report.md and the
residual-field plot residuals.png (mean pin residual per pin, before and after) beside its
report.json; a fit that did not converge exits 1."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from twin.analysis.calibration_fit.fit import calibrate
from twin.analysis.calibration_fit.settings import CalibrationSettings
from twin.core.errors import TwinError
from twin.core.scenario import Scenario
from twin.core.sensor import CameraModel


class CalibrationNotConverged(TwinError):
    """The stop rule was not met within max_generations (exit 1); best point and history kept."""


def _fmt(v: float | None, digits: int = 3) -> str:
    return "–" if v is None else f"{v:.{digits}f}"


def _where(row: dict) -> str:
    """A figure row's lateral bin (mm), or the side of the edge it is pooled over and its bins."""
    if row["lateral_mm"] is not None:
        return f"{row['lateral_mm']:+g}"
    return f"{row['side']} ({row['bins']} bins)"


def _edge_figure_lines(figures: dict | None) -> list[str]:
    """The edge figures' table, recorded beside the twin before and after (misses in tolerances)."""
    if not figures:
        return []
    lines = [
        "",
        f"Edge figures (weight {figures['weight']:g}; the twin's signal from its "
        f"{figures.get('signal_from', 'sheared')} replay of the taps"
        + (
            "; the signal without its rigid shift, the shift's share a figure"
            if figures.get("signal_shift") == "apart"
            else ""
        )
        + ("; its θ_PC23 turn read in the recorded taps' PC2–PC3" if figures.get("theta_plane") == "recorded" else "")
        + (
            "; each figure pooled over either side of the edge, its bins weighted by their recorded spread, "
            "the spread the pooled mean's"
            if figures.get("bins") == "pooled"
            else ""
        )
        + "). Miss: over the tolerance (0.1 for the signal ratio and the shift, a "
        "factor 4/3 for the others) and, fitted, over √(tolerance² + spread²), the spread the recorded figure's "
        "over bootstrap resamples of its frames (the signal's and the shift's in their units, the others' in log units; "
        "twin.analysis.calibration_fit.figures):",
        "",
        "| run | figure | l (mm) | recorded | spread | before | miss | after | miss | fitted miss |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for b, a in zip(figures["before"], figures["after"]):
        lines.append(
            f"| {a['run']} | {a['figure']} | {_where(a)} | {a['recorded']:.3g} | {a['spread']:.2f} | "
            f"{_fmt(b['twin'], 3)} | {b['miss_tolerance']:+.1f} | {_fmt(a['twin'], 3)} | {a['miss_tolerance']:+.1f} | "
            f"{a['miss']:+.1f} |"
        )
    within = [sum(abs(row["miss_tolerance"]) <= 1.0 for row in figures[k]) for k in ("before", "after")]
    lines += ["", f"Within their tolerance: {within[0]} of {len(figures['after'])} before, {within[1]} after."]
    return lines


def report_markdown(r: dict) -> str:
    """The report as markdown: status, pin RMS before/after, fitted values ± std, speed."""
    lines = [
        f"# Calibration: {r['status']}",
        "",
        f"Stop rule: {r['stop_reason']}.",
        "",
        f"Runs: {', '.join(r['runs'])} ({r['samples']} samples: "
        + ", ".join(f"{n} {g}" for g, n in r["samples_per_group"].items() if n)
        + f"); scenario {r['scenario']}.",
        f"Rest pin layout: {r['rest_pins']}.",
        *(
            f"The taps of {run} press from {depth:g} mm (for a lab import, its `--depth-mm`): `tcp.z_mm` is "
            "measured from there."
            for run, depth in r.get("nominal_depth_mm", {}).items()
        ),
        "",
        "| pin RMS (px) | before | after |",
        "|---|---|---|",
        f"| overall | {_fmt(r['before']['overall'])} | {_fmt(r['after']['overall'])} |",
    ]
    for g, v in r["after"]["groups"].items():
        lines.append(f"| {g} frames | {_fmt(r['before']['groups'].get(g))} | {_fmt(v)} |")
    for run, v in r["after"]["runs"].items():
        lines.append(f"| run {run} | {_fmt(r['before']['runs'].get(run))} | {_fmt(v)} |")
    held = r.get("held_out")
    if held:
        lines.append(
            f"| held out, overall ({held['samples']} samples, not fitted) | {_fmt(held['before']['overall'])} | "
            f"{_fmt(held['after']['overall'])} |"
        )
        for g, v in held["after"]["groups"].items():
            lines.append(f"| held out, {g} frames | {_fmt(held['before']['groups'].get(g))} | {_fmt(v)} |")
    rest = r.get("camera_from_rest")
    if rest:
        alone = rest["pin_rms_px"]
        lines.append(
            f"| camera start alone (the twin's physics, rest layout fitted), overall | – | {_fmt(alone['overall'])} |"
        )
        for g, v in alone["groups"].items():
            lines.append(f"| camera start alone, {g} frames | – | {_fmt(v)} |")
        lines += [
            "",
            f"Camera start from the no-contact frames (the pin lattice projected, no rest offsets; pin RMS "
            f"{rest['rms_px']:.3f} px on them):",
            "",
            "| parameter | twin | from the no-contact frames | ± std (Gauss–Newton) | tied: at the fitted camera |",
            "|---|---|---|---|---|",
        ]
        at_fit = rest.get("at_fit") or {}
        for name, v in rest["values"].items():
            flag = " (**at a bound**: widen it)" if name in rest["at_bound"] else ""
            tied = f"{at_fit[name]:.4g}" if name in at_fit else "–"
            if name in rest.get("at_fit_at_bound", []):
                tied += " (**at a bound**: the cameras that meet the no-contact frames end there)"
            lines.append(f"| {name} | {rest['twin'][name]:.4g} | {v:.4g}{flag} | {rest['std'][name]:.2g} | {tied} |")
        if at_fit:
            lines += [
                "",
                "Tied (settings camera_tied_to_rest): fitted to the no-contact frames again at every camera the "
                "fit tried; the calibration file holds their values at the fitted camera.",
            ]
    lines += _edge_figure_lines(r.get("edge_figures"))
    lines += [
        "",
        "| parameter | default | fitted | ± std | resolution | VIF | bounds | identifiable |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, u in r["uncertainty"]["parameters"].items():
        lines.append(
            f"| {name} | {u['default']:.4g} | {u['value']:.4g} | {u['std']:.2g} | {u['resolution']:.2g} | "
            f"{u['variance_inflation']:.3g} | [{u['bounds'][0]:g}, {u['bounds'][1]:g}] | "
            + (
                "yes"
                if u["identifiable"]
                else f"**no** ({'; '.join(u['not_identifiable_because'])}): left at the default"
            )
            + (" (**at a bound**: widen it, or a parameter not fitted is off)" if u.get("at_bound") else "")
            + " |"
        )
    lines += [
        "",
        "± std: the larger of the Gauss–Newton and the cluster-robust (samples as clusters: a frame's pins "
        "share their errors) standard error. Resolution: the change of the parameter that moves the pins by the "
        "fit's pin RMS, what one frame's pins resolve. VIF: variance inflation, 1/(1 − R²) of the parameter's "
        "Jacobian column on the others'. Identifiable: std below the identifiable fraction of the range, "
        "resolution below the range and VIF at most the limit (twin.analysis.calibration_fit.uncertainty).",
    ]
    if r.get("edge_figures"):
        lines.append(
            "With the edge figures weighted, each figure is a cluster of its own, and the resolution is counted in "
            "the whitened residuals, pins and figures together."
        )
    sv = r["uncertainty"]["singular_values"]
    if sv:
        lines += [
            "",
            "Singular values of the Jacobian (whitened residuals per unit of each parameter's range): "
            + ", ".join(f"{v:.3g}" for v in sv)
            + f"; reduced χ² {r['uncertainty']['reduced_chi2']:.3g}.",
        ]
    failed = r.get("failed_simulations") or []
    if failed:
        lines += [
            "",
            f"{len(failed)} candidates could not be simulated (their physics checks failed; the search ranked them "
            f"below every other): first {failed[0]['values']}: {failed[0]['error']}",
        ]
    lines += [
        "",
        f"{r['generations']} CMA-ES generations, {r['simulations']} simulations of the runs "
        f"({r['evaluations_per_s']:.3g} evaluations/s, {r['simulated_frames_per_s']:.0f} simulated frames/s); "
        f"wall time {r['wall_time_s']:.1f} s.",
        "",
    ]
    return "\n".join(lines)


def plot_residuals(r: dict, path: Path) -> None:
    """Mean residual vector (recorded − twin, ×20) at every pin's rest position, before and after."""
    matplotlib.use("Agg")
    # where the pins are in the runs' frames (the no-contact frames' mean); reports written before
    # it was kept show the twin's nominal 640×480 layout
    width, height = r.get("frame_px") or (CameraModel().width, CameraModel().height)
    if r.get("pin_positions_px") is not None:
        rest = np.asarray(r["pin_positions_px"], float)
    else:
        cam = CameraModel()
        rest = cam.project_tool_points(cam.geometry.pin_tip_points())
    fig, axes = plt.subplots(1, 2, figsize=(11, 5), dpi=110)
    for ax, key in zip(axes, ("before", "after")):
        mean = np.asarray(r[key]["mean_residual"], float)
        per_pin = np.asarray(r[key]["per_pin"], float)
        sc = ax.scatter(rest[:, 0], rest[:, 1], c=per_pin, cmap="viridis", s=30)
        ax.quiver(
            rest[:, 0],
            rest[:, 1],
            mean[:, 0],
            mean[:, 1],
            angles="xy",
            scale_units="xy",
            scale=1 / 20,
            color="tab:red",
            width=0.004,
        )
        ax.set_xlim(0, width)
        ax.set_ylim(height, 0)
        ax.set_aspect("equal")
        ax.set_title(f"{key}: pin RMS {r[key]['overall']:.3f} px\nmean residual ×20 (arrows), RMS per pin (colour)")
        fig.colorbar(sc, ax=ax, label="px")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_report(r: dict, out: Path) -> None:
    """report.md and residuals.png in `out`, beside the fit's report.json."""
    (out / "report.md").write_text(report_markdown(r))
    plot_residuals(r, out / "residuals.png")


def calibrate_and_report(
    run_dirs: list[Path],
    scenario: Scenario,
    out: Path,
    settings: CalibrationSettings,
    workers: int | None = None,
    cluster: str | None = None,
    progress: bool = True,
    held_out: list[Path] | None = None,
) -> dict:
    """`twin calibrate`: the fit (twin.analysis.calibration_fit.fit.calibrate, its files in
    `out`), then its report; raises CalibrationNotConverged after writing both when the
    stop rule was not met (DIR/best_calibration.yaml holds the best point)."""
    result = calibrate(
        run_dirs, scenario, out, settings, workers=workers, cluster=cluster, progress=progress, held_out=held_out
    )
    write_report(result, out)
    if result["status"] != "converged":
        raise CalibrationNotConverged(
            f"{result['stop_reason']}; the best point is in {result['calibration_file']}, "
            f"the history in {out / 'history.jsonl'} (run again with the same --out to "
            "continue)"
        )
    return result
