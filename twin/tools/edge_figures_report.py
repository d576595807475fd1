"""The edge figures (twin.analysis.edge_imprint) as text: one column per sensor, so a real
TacTip's runs and the twin's read side by side in `twin compare` and `twin evaluate`."""

from __future__ import annotations

import math

from twin.analysis.calibration_fit.figures import LINEAR
from twin.analysis.comparison import read_in_a_plane
from twin.analysis.edge_imprint import rotating_pair

WIDTH = 22


def _cell(value, fmt: str = "{:.2f}") -> str:
    return ("—" if value is None else fmt.format(value)).rjust(WIDTH)


def _rows_by_lateral(figures: list[dict], key: str, field: str | None, fmt: str, scale: float = 1.0) -> list[str]:
    laterals = sorted({l for f in figures for l in f[key]}, reverse=True)
    lines = []
    for l in laterals:
        cells = []
        for f in figures:
            row = f[key].get(l)
            value = row if field is None else (None if row is None else row.get(field))
            cells.append(_cell(None if value is None else value * scale, fmt))
        lines.append(f"    l {l:+g} mm".ljust(34) + "".join(cells))
    return lines


def _depth_groups(figures: list[dict], key: str) -> list[tuple[str, list[dict]]]:
    """The depth-keyed figure `key` as (depth text, each sensor's {l: value}) groups: one per
    depth, or, when every run is sheared taps (one row each, at a nominal depth that a lab
    set does not record), a single group with the runs' nominal depths."""
    if all(f["kind"] == "sheared_taps" and len(f.get(key, {})) == 1 for f in figures):
        depths = [next(iter(f[key])) for f in figures]
        if len(set(depths)) > 1:
            text = "each run's nominal depth (" + " / ".join(f"{d:g}" for d in depths) + " mm)"
            return [(text, [next(iter(f[key].values())) for f in figures])]
    return [
        (f"{depth:g} mm deep", [f.get(key, {}).get(depth, {}) for f in figures])
        for depth in sorted({d for f in figures for d in f.get(key, {})})
    ]


def format_edge_figures(figures: list[dict], labels: list[str] | None = None) -> str:
    """The figures of several sensors (twin.analysis.edge_imprint.edge_figures) side by side."""
    labels = labels or [f["name"] for f in figures]
    lines = ["edge figures".ljust(34) + "".join(label[: WIDTH - 1].rjust(WIDTH) for label in labels)]
    for depth, profiles in _depth_groups(figures, "signal_profile"):
        lines.append(f"  orientation signal / its value at l = 0, {depth}:")
        lines += _rows_by_lateral([{"signal_profile": p} for p in profiles], "signal_profile", None, "{:.2f}")
    for depth, profiles in _depth_groups(figures, "signal_by_depth"):
        lines.append(f"  orientation signal / its mean at l = 0 over the depths, the sheared taps {depth}:")
        lines += _rows_by_lateral([{"s": p} for p in profiles], "s", None, "{:.2f}")
    for depth, shares in _depth_groups(figures, "signal_shift_share"):
        lines.append(f"  orientation signal in a rigid shift of the pins, %, {depth}:")
        lines += _rows_by_lateral([{"s": s} for s in shares], "s", None, "{:.0f}", 100.0)
    reach_at = sorted({l for f in figures for l in f["reach"]}, reverse=True)
    for l in reach_at:
        lines.append(
            f"  reach at l {l:+g} mm (mean |pin displacement| in 10 bins along the edge normal, "
            "beyond the edge → object side, / largest bin):"
        )
        for label, f in zip(labels, figures):
            bins = f["reach"].get(l)
            lines.append(f"    {label}: " + ("—" if bins is None else " ".join(f"{v:.2f}" for v in bins)))
    for depth, by_l in _depth_groups(figures, "signal_rings"):
        lines.append(f"  orientation signal by ring of pins (centre → rim), / the whole array's at l = 0, {depth}:")
        for l in sorted({l for rows in by_l for l in rows}, reverse=True):
            for label, rows in zip(labels, by_l):
                rings = rows.get(l)
                values = "—" if rings is None else " ".join(f"{v:.2f}" for v in rings)
                lines.append(f"    l {l:+g} mm, {label}: {values}")
    lines.append(
        "  the edge's orientation pair by ring of pins (centre → rim): its energy, share of the pair's;"
        " the share of that moving the pins radially:"
    )
    for label, f in zip(labels, figures):
        radial = " ".join("—" if v is None else f"{v:.2f}" for v in f["pair_rings"]["radial"])
        lines.append(f"    {label}: " + " ".join(f"{v:.2f}" for v in f["pair_rings"]["energy"]) + f"; radial {radial}")
    for depth, closest in _depth_groups(figures, "closest_pins"):
        lines.append(
            f"  closest pins, {depth} (nearest neighbour / at rest, the frame's smallest: "
            "min / median over taps; frames with a pin lost, %):"
        )
        for l in sorted({l for rows in closest for l in rows}, reverse=True):
            cells = []
            for rows in closest:
                row = rows.get(l)
                cells.append(
                    ("—" if row is None else f"{row['min']:.2f} / {row['median']:.2f}; {100 * row['lost']:.0f}").rjust(
                        WIDTH
                    )
                )
            lines.append(f"    l {l:+g} mm".ljust(34) + "".join(cells))
    if any(f["drag_over_signal"] for f in figures):
        lines.append("  drag / orientation signal (fitted slide and twist terms against the angle term, px/px):")
        lines += _rows_by_lateral(figures, "drag_over_signal", "ratio", "{:.1f}")
        lines.append("  drag, px:")
        lines += _rows_by_lateral(figures, "drag_over_signal", "drag_px", "{:.2f}")
        lines.append("  orientation signal, px:")
        lines += _rows_by_lateral(figures, "drag_over_signal", "signal_px", "{:.2f}")
    if any(f["along_edge"] for f in figures):
        lines.append("  a 1 mm slide along the edge (sheared taps: fitted; plain taps: the slides' first step):")
        for field, what, fmt, scale in (
            ("raw_deg_per_mm", "raw pins, deg of edge angle per mm", "{:.1f}", 1.0),
            ("pc23_deg_per_mm", "θ_PC23 turned, deg per mm", "{:.1f}", 1.0),
            ("plane_share", "drag energy in the taps' PC2–PC3, %", "{:.1f}", 100.0),
            ("translation_share", "drag energy in a rigid shift, %", "{:.0f}", 100.0),
            ("radius_px", "the taps' PC2–PC3 radius, px", "{:.1f}", 1.0),
            ("offset_deg", "the mean frame's offset in PC2–PC3 from a turn about the centre, deg", "{:+.0f}", 1.0),
        ):
            lines.append(f"   {what}:")
            lines += _rows_by_lateral(figures, "along_edge", field, fmt, scale)
    if any(f["across_edge"] for f in figures):
        lines.append("  a 1 mm slide across the edge (sheared taps: fitted):")
        for field, what in (
            ("raw_deg_per_mm", "raw pins, deg of edge angle per mm"),
            ("pc23_deg_per_mm", "θ_PC23 turned, deg per mm"),
        ):
            lines.append(f"   {what}:")
            lines += _rows_by_lateral(figures, "across_edge", field, "{:.1f}")
    lines.append(
        "  PC1/PC2/PC3 of the taps, %".ljust(34)
        + "".join(
            _cell(None, "")
            if not f["pcs_explained"]
            else (
                "/".join(f"{100 * v:.0f}" for v in f["pcs_explained"]) + (" (6-fold)" if f["pcs_turned"] else "")
            ).rjust(WIDTH)
            for f in figures
        )
    )
    for label, f in zip(labels, figures):
        pair = rotating_pair(f["pcs_explained"]) if f["pcs_explained"] else (1, 2)
        if pair != (1, 2):
            shares = "/".join(f"{100 * f['pcs_explained'][i]:.0f}" for i in pair)
            lines.append(
                f"  {label}: the edge's orientation pair is PC{pair[0] + 1}–PC{pair[1] + 1} ({shares} %), not "
                "PC2–PC3: its θ_PC23 reads one half of the pair and the press"
            )
    return "\n".join(lines)


#: the columns of `format_figure_differences`: figure, heading
DIFFERENCE_COLUMNS = (
    ("signal", "signal / l = 0's, B − A"),
    ("theta_pc23", "θ_PC23 per mm, B / A"),
    ("theta_pc23_across", "the same across, B / A"),
    ("drag/signal", "drag / signal, B / A"),
)


#: the columns of B's θ_PC23 turns read in A's plane: the figure, heading
IN_A_PLANE_COLUMNS = (
    ("theta_pc23", "θ_PC23 per mm in A's plane, B / A"),
    ("theta_pc23_across", "the same across"),
)
#: the pooled lines below the bins: side (twin.analysis.calibration_fit.figures.SIDES), label
POOLED_LINES = (("onto", "pooled onto the object (l < 0)"), ("off", "pooled off it (l ≥ 0)"))


def format_figure_differences(differences: dict) -> str:
    """`twin compare`'s edge figures of B against A on the taps both have
    (twin.analysis.comparison.figure_differences): the signal ratio's difference ± its
    paired bootstrap standard deviation; θ_PC23's and drag / signal's factor B / A ×÷ the
    factor of one standard deviation (their spread is in log units); B's θ_PC23 turns,
    along and across the edge, read in A's PC2–PC3 plane over A's own, with the angle
    between the planes; and below the bins, each figure pooled over either side of the edge."""
    rows = {(r["figure"], r["lateral_mm"]): r for r in differences["rows"]}
    in_a = differences.get("b_in_a_plane")
    lines = [
        f"  B against A on the same {differences['taps']} taps (± one standard deviation over "
        f"{differences['resamples']} bootstrap resamples of them, the same for both; seed {differences['seed']}):",
        " " * 34
        + "".join(heading.rjust(WIDTH + 4) for _, heading in DIFFERENCE_COLUMNS)
        + ("".join(heading.rjust(WIDTH + 16) for _, heading in IN_A_PLANE_COLUMNS) if in_a else ""),
    ]
    for l in sorted({l for _, l in rows}, reverse=True):
        line = f"    l {l:+g} mm".ljust(34)
        line += "".join(
            _difference_cell(figure, rows.get((figure, l))).rjust(WIDTH + 4) for figure, _ in DIFFERENCE_COLUMNS
        )
        if in_a:
            for figure, _ in IN_A_PLANE_COLUMNS:
                row = rows.get((figure, l))
                line += _difference_cell(figure, None if row is None else read_in_a_plane(row)).rjust(WIDTH + 16)
        lines.append(line)
    pooled, pooled_in_a = differences.get("pooled", {}), differences.get("pooled_in_a_plane", {})
    for side, label in POOLED_LINES:
        cells = [_pooled_cell(figure, pooled.get(figure, {}).get(side)) for figure, _ in DIFFERENCE_COLUMNS]
        in_a_cells = [_pooled_cell(f, pooled_in_a.get(f, {}).get(side)) for f, _ in IN_A_PLANE_COLUMNS] if in_a else []
        if any(c != "—" for c in cells + in_a_cells):
            lines.append(
                f"    {label}".ljust(34)
                + "".join(c.rjust(WIDTH + 4) for c in cells)
                + "".join(c.rjust(WIDTH + 16) for c in in_a_cells)
            )
    if pooled:
        lines.append(
            "  (pooled: each bin weighted by 1 / its variance, ± one standard error, widened where the bins"
            " scatter more than their spreads allow; twin.analysis.comparison.pooled_differences)"
        )
    if in_a:
        lines.append(
            f"  (the last two columns: B's θ_PC23 read in A's PC2–PC3 plane, which lies {in_a['angle_deg']:.1f}° from"
            " B's; where they meet A's and B's own do not, the planes differ, not the drag)"
        )
    return "\n".join(lines)


def _difference_cell(figure: str, row: dict | None) -> str:
    """One bin's B against A: a linear figure's (calibration_fit.figures.LINEAR: the signal
    ratio, the shift's share) B − A ± its spread, the others' B / A ×÷ the factor of one
    spread (their spreads are in log units)."""
    if row is None:
        return "—"
    if figure in LINEAR:
        return f"{row['b'] - row['a']:+.2f} ± {row['spread']:.2f}"
    return f"{row['b'] / row['a']:.2f} ×÷ {math.exp(row['spread']):.2f}" if row["a"] > 0 else "—"


def _pooled_cell(figure: str, pooled: dict | None) -> str:
    """A pooled difference as the per-bin cells show theirs: a linear figure's B − A ± its
    error, the others' B / A ×÷ the factor of one error (their differences are logs)."""
    if pooled is None:
        return "—"
    if figure in LINEAR:
        return f"{pooled['difference']:+.2f} ± {pooled['error']:.2f}"
    return f"{math.exp(pooled['difference']):.2f} ×÷ {math.exp(pooled['error']):.2f}"
