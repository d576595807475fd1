"""`twin evaluate`'s report: the evaluation (twin.analysis.evaluation), then Table I, the
held-out errors, the orientation signal and the along-edge drag as text, and the PCA
figures (Figs. 5–6)."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt

from twin.analysis.edge_imprint import REACH_AT_MM, edge_figures
from twin.analysis.evaluation import ALONG_EDGE_DEG, DIRECTIONS, PAPER_TABLE_I, evaluate, on_off, pca_projections
from twin.runs.record import jsonable, load_run


def _fmt(v) -> str:
    return "—" if v is None else f"{v:.2f}"


def _table_row(label: str, cells: dict) -> str:
    """One row of Table I as text: `cells` {direction: (on, off)} (deg or None)."""
    return label.ljust(24) + "".join(f"{_fmt(cells[d][0])}/{_fmt(cells[d][1])}".rjust(16) for d in DIRECTIONS)


def format_table(table: dict, paper: bool = True) -> str:
    """Table I as text, the paper's figures beside the twin's."""
    head = "model".ljust(24) + "".join(f"{d}° on/off".rjust(16) for d in DIRECTIONS)
    lines = [head]
    for name, rows in table.items():
        lines.append(_table_row(f"twin {name}", on_off(rows)))
        if paper and name in PAPER_TABLE_I:
            lines.append(_table_row(f"paper {name}", PAPER_TABLE_I[name]))
    return "\n".join(lines)


def format_paper_finding(twin: dict, paper: dict) -> str:
    """The paper's finding (twin.analysis.evaluation.paper_finding) as a line, the paper's beside."""
    along = " / ".join(f"{twin['along_deg'][d]:.2f}°" for d in ALONG_EDGE_DEG)
    raw = " / ".join(f"{twin['raw_over_pca'][d]:.1f}×" for d in ALONG_EDGE_DEG)
    paper_raw = " / ".join(f"{paper['raw_over_pca'][d]:.1f}×" for d in ALONG_EDGE_DEG)
    return (
        f"the paper's finding, PCA + GP: along the edge ({' / '.join(f'{d}°' for d in ALONG_EDGE_DEG)}) {along}, "
        f"the raw pins {raw} worse (paper {paper_raw}); Off < On in {twin['off_below_on']} of "
        f"{twin['columns']} columns (paper {paper['off_below_on']} of {paper['columns']})"
    )


def format_heldout(table: dict) -> str:
    """The held-out errors as text: one line per model and lateral position."""
    lines = [
        "model".ljust(16) + "lateral mm".rjust(12) + "θ RMS °".rjust(10) + "lateral RMS mm".rjust(16) + "taps".rjust(6)
    ]
    for name, rows in table.items():
        for l, row in rows.items():
            lines.append(
                name.ljust(16)
                + f"{l:+.1f}".rjust(12)
                + _fmt(row["theta_rms_deg"]).rjust(10)
                + _fmt(row["lateral_rms_mm"]).rjust(16)
                + str(row["n"]).rjust(6)
            )
    return "\n".join(lines)


def format_orientation_signal(signal: dict[float, dict[float, float]], who: str = "the taps'") -> str:
    """`orientation_signal_px` as text, a line per depth."""
    lines = [f"{who} orientation signal (each pin's spread over the orientations, RMS over the pins), px:"]
    for depth, row in signal.items():
        lines.append(f"  {depth:g} mm deep: " + "  ".join(f"l {l:+g}: {v:.2f}" for l, v in row.items()))
    return "\n".join(lines)


def format_along_edge_drag(drag: dict[int, float | None], who: str = "the along-edge slides'") -> str:
    """`along_edge_drag_px` as text, one line."""
    return f"{who} drag (the pins' shift from each slide's unslid first sample, RMS), px: " + "  ".join(
        f"{d}°: {_fmt(v)}" for d, v in drag.items()
    )


def format_along_edge_reading(reading: dict | None) -> str:
    """`along_edge_reading` as text: a line for the taps at the slides' lateral position and
    one per along-edge direction."""
    if reading is None:
        return "no along-edge slides: no reading of them in the taps' PC2–PC3 plane"

    sign = "−" if reading["handedness"] > 0 else "+"

    def figures(f: dict) -> str:
        return f"θ_PC23 {sign} θ {f['offset_deg']:+.1f}° ± {f['spread_deg']:.1f}, radius {f['radius_px']:.2f} px"

    turns = "with θ" if reading["handedness"] > 0 else "against θ (the pair's sign is a convention)"
    lines = [
        f"the along-edge slides in the taps' PC2–PC3 plane (l {reading['lateral_mm']:+g} mm; θ is read from it;"
        f" over all the taps θ_PC23 turns {turns}):"
    ]
    for depth, f in reading["taps"].items():
        lines.append(f"  taps {float(depth):g} mm deep: {figures(f)}")
    for d in (90, 270):
        if d in reading:
            lines.append(
                f"  {d}° pressed: {figures(reading[d]['pressed'])};  sliding: {figures(reading[d]['sliding'])}"
            )
    for d in (90, 270):
        if d in reading:
            drag = reading[d]["drag_in_plane"]
            lines.append(
                f"  {d}° drag in the plane: {drag['all']:.2f} px = its rigid shift's {drag['rigid_shift']:.2f} px"
                f" + the rest's {drag['rest']:.2f} px (as vectors)"
            )
    return "\n".join(lines)


def write_pca_figures(train_dir: Path, test_dir: Path, out: Path) -> list[Path]:
    """Figs. 5–6: the sliding set on its own PCs (PC1–PC2, PC4–PC5) and on the tap set's
    PC2–PC3, one panel per sliding direction, coloured by the true orientation
    (twin.analysis.evaluation.pca_projections)."""

    matplotlib.use("Agg")

    data = pca_projections(load_run(train_dir), load_run(test_dir))
    own, tap, theta, direction = data["own"], data["tap"], data["theta_deg"], data["direction_deg"]
    panels = [
        ("fig5_multidirectional_pc1_pc2.png", own, (0, 1)),
        ("fig5_multidirectional_pc4_pc5.png", own, (3, 4)),
        ("fig6_tap_eigenvectors_pc2_pc3.png", tap, (1, 2)),
    ]
    paths = []
    for name, proj, (a, b) in panels:
        fig, axes = plt.subplots(1, 4, figsize=(13, 3.4), dpi=110, sharex=True, sharey=True)
        for ax, d in zip(axes, (0, 90, 180, 270)):
            m = direction == d
            sc = ax.scatter(proj[m, a], proj[m, b], c=theta[m], cmap="hsv", vmin=-180, vmax=180, s=8)
            ax.set_title(f"sliding direction {d}°")
            ax.set_xlabel(f"PC{a + 1}")
        axes[0].set_ylabel(f"PC{b + 1}")
        fig.colorbar(sc, ax=axes, label="true orientation θ (deg)")
        fig.savefig(out / name)
        plt.close(fig)
        paths.append(out / name)
    return paths


def format_shift_free(table: dict) -> str:
    """Table I's PCA + GP row without the frames' uniform shift, as a row under the table's."""
    return _table_row("twin PCA + GP, shift out", on_off(table["PCA + GP"]))


def evaluate_and_report(
    train_dir: Path,
    test_dir: Path,
    out: Path,
    seed: int = 0,
    reach_at: tuple[float, ...] = REACH_AT_MM,
    shift_free: bool = False,
) -> dict:
    """`twin evaluate`: the evaluation's results and models in `out`
    (twin.analysis.evaluation.evaluate), and for a slides run the PCA figures. A sheared-tap
    training run (an imported lab recording, or the twin's) also gets its edge figures
    (twin.analysis.edge_imprint: the drag separated from the orientation) in
    out/edge_figures.json and the result's "edge_figures" (its reach profiles at `reach_at`, mm).
    `shift_free`: Table I's PCA + GP row also without the frames' uniform shift."""
    result = evaluate(train_dir, test_dir, out, seed=seed, shift_free=shift_free)
    if "table_i_rms_orientation_deg" in result:
        write_pca_figures(train_dir, test_dir, out)
    train = load_run(train_dir)
    if train.meta["scenario"]["protocol"]["kind"] == "sheared_taps":
        result["edge_figures"] = edge_figures(train, reach_at=reach_at)
        (out / "edge_figures.json").write_text(json.dumps(jsonable(result["edge_figures"]), indent=1))
    return result
