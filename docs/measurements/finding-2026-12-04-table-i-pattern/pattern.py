"""Every `twin evaluate` Table I in docs/measurements set against the paper's: how far each
twin variant reads the slides along the edge (90°, 270°) and across it (the twelve On / Off
cells of 0°, 45°, 135°, 180°, 225°, 315°) from the paper's PCA + GP errors, as geometric
means of twin / paper. Prints the table and writes pattern.png.

    python pattern.py [MEASUREMENTS_DIR]
"""

import math
import re
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from scipy.stats import spearmanr

HERE = Path(__file__).resolve().parent
ALONG = (4, 12)  # the 90° and 270° cells in a row's sixteen (on, off) values
ON = (0, 2, 6, 8, 10, 14)
OFF = (1, 3, 7, 9, 11, 15)
#: the points named in the figure: the held skin at 1.8 mm, from the fit's start to its end
NAMED = {
    "table-i-held_s0063_f09_whole_sp18.txt": ("sway 0.063 mm/N, μ 0.9", "left"),
    "table-i-held_s0149_f050_whole_sp18.txt": ("0.149, μ 0.50", "left"),
    "table-i-held_s0197_f057_whole_sp18.txt": ("0.197, μ 0.57 (DigiTac fit)", "right"),
}


def cells(text: str, row: str) -> list[float | None] | None:
    """A Table I row's sixteen values (on, off per direction; None for —), or None if absent."""
    line = next((ln for ln in text.splitlines() if ln.startswith(row)), None)
    if line is None:
        return None
    values = re.findall(r"\d+\.\d+|—", line[len(row) :])
    return [None if v == "—" else float(v) for v in values] if len(values) == 16 else None


def geometric_ratio(twin: list, paper: list, which: tuple[int, ...]) -> float:
    return math.exp(sum(math.log(twin[i] / paper[i]) for i in which) / len(which))


def main(root: Path) -> None:
    rows, seen = [], set()
    for path in sorted(root.glob("**/table-i*.txt")):
        text = path.read_text()
        twin, paper = cells(text, "twin PCA + GP"), cells(text, "paper PCA + GP")
        if twin is None or paper is None or tuple(twin) in seen:  # a copy of an earlier run's table
            continue
        seen.add(tuple(twin))
        along, on, off = (geometric_ratio(twin, paper, w) for w in (ALONG, ON, OFF))
        rows.append((str(path.relative_to(root)), along, on, off, twin))
    if not rows:
        raise SystemExit(f"no twin evaluate Table I under {root}")
    print(f"{len(rows)} distinct Table I outputs of twin evaluate under {root.name}/; twin / paper, geometric means")
    print(f"{'file':78s} {'90°/270°':>9s} {'On':>6s} {'Off':>6s}   worst along, °")
    for name, along, on, off, twin in sorted(rows, key=lambda r: r[1]):
        print(f"{name:78s} {along:9.2f} {on:6.2f} {off:6.2f}   {max(twin[i] for i in ALONG):6.1f}")
    reach = [r for r in rows if r[1] <= 1.5]
    print(
        f"along within 1.5× the paper's: {len(reach)} of {len(rows)}; their On / Off at most "
        f"{max(r[2] for r in reach):.2f} / {max(r[3] for r in reach):.2f} of the paper's"
        if reach
        else "no output reads along the edge within 1.5× the paper's"
    )
    for name, k in (("On", 2), ("Off", 3)):
        rho = spearmanr([r[1] for r in rows], [r[k] for r in rows])
        print(f"rank correlation of along-edge with {name} (twin / paper): {rho.statistic:.2f} (p {rho.pvalue:.0e})")
    across = [r for r in rows if r[2] >= 0.5]
    print(
        f"On within 2× the paper's: {len(across)} of {len(rows)}; their 90°/270° at least "
        f"{min(r[1] for r in across):.2f}× the paper's"
        if across
        else "no output reads the On cells within 2× the paper's"
    )

    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    ax.scatter([r[1] for r in rows], [r[2] for r in rows], s=14, c="tab:blue", label="twin variants, On cells")
    ax.scatter(
        [r[1] for r in rows], [r[3] for r in rows], s=14, marker="x", c="tab:orange", label="the same, Off cells"
    )
    for name, along, on, _off, _ in rows:
        label, side = NAMED.get(Path(name).name, (None, None))
        if label:
            ax.annotate(
                label,
                (along, on),
                fontsize=7,
                ha=side,
                textcoords="offset points",
                xytext=(-5 if side == "right" else 5, 3),
            )
    ax.scatter([1], [1], s=60, marker="*", c="k", label="the paper")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("slides along the edge (90°, 270°): twin / paper error")
    ax.set_ylabel("slides across it (On, Off): twin / paper error")
    ax.axhline(1, c="0.8", lw=0.8)
    ax.axvline(1, c="0.8", lw=0.8)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title("PCA + GP, Table I: every twin variant against the paper", fontsize=9)
    fig.tight_layout()
    fig.savefig(HERE / "pattern.png", dpi=110)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent)
