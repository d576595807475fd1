"""Several solutions of one increment: the suite's μ = 3 reversal on the fitted dome
(scaled to the 4.3 N press) at 1.0 mm nodes.

Runs ../finding-2026-12-05-shipped-scenarios/hard_case.py's moves. At each increment of
the reversal on which semismooth Newton stalls from the warm start at every augmentation
parameter, it follows the friction up from μ/10 … μ/2, growing each converged stage by
×1.3 … ×2 (twin.world.dome.compliant.contact.rising_friction, which solve_coulomb
follows from μ/6, ×2), and prints how many of those paths reach μ = 3, their largest
Alart–Curnier residual (below the 0.1 µm tolerance: each is a solution) and how far
their forces and their nodes' gaps and slips lie apart. The run goes on from the first
path's solution, and stops at the first increment whose paths end apart, or after
MAX_STALLS stalled increments.

    python several_roots.py
"""

import sys
from pathlib import Path

import numpy as np

from twin.world.dome.compliant import contact

sys.path.insert(0, str(Path(__file__).parent.parent / "finding-2026-12-05-shipped-scenarios"))
from hard_case import FITTED, environment, moves, scaled_entries  # noqa: E402

#: (first stage as a fraction of μ, growth after a converged stage)
PATHS = [(1 / 6, 2.0), (1 / 6, 1.5), (1 / 3, 1.5), (1 / 2, 2.0), (1 / 10, 1.3), (1 / 4, 1.5)]
#: stalled increments looked at before giving up
MAX_STALLS = 25


class Apart(Exception):
    """Stops the run at an increment with solutions apart."""


def solve_along_paths(reversing: list[bool], stalled: list[int]):
    """solve_coulomb, which at the reversal's stalled increments reports every path's
    solution, goes on from the first, and raises Apart where they differ."""
    solve = contact.solve_coulomb

    def solve_and_report(matrix, offset, friction, start, tolerance, max_iterations, adhesion=None):
        if not reversing[0]:
            return solve(matrix, offset, friction, start, tolerance, max_iterations, adhesion)
        runs = contact.NewtonRuns.of(matrix, offset, tolerance, max_iterations, adhesion)
        start = np.ascontiguousarray(start, float)
        f, iterations, residual = runs.from_start(start, friction)
        if residual < tolerance:
            return f, iterations, residual  # what solve_coulomb returns there
        stalled[0] += 1
        roots = report(runs, friction, start, stalled[0])
        if len(roots) > 1 and max(np.abs(r - roots[0]).max() for r in roots[1:]) > 1e-4:
            raise Apart
        if stalled[0] >= MAX_STALLS:
            sys.exit(f"{MAX_STALLS} stalled increments, each with one solution along every path")
        if not roots:
            sys.exit("no path reached μ")
        return roots[0], 0, 0.0

    return solve_and_report


def report(runs: contact.NewtonRuns, friction: float, start: np.ndarray, number: int) -> list[np.ndarray]:
    """The solutions at μ along PATHS, with a line on each."""
    nodes = len(runs.offset) // 3
    print(f"stalled increment {number} of the reversal: {nodes} candidate nodes, μ = {friction:g}")
    roots, gaps_slips = [], []
    for first, grow in PATHS:
        f, _, _ = contact.rising_friction(runs, start, friction, first, grow)
        label = f"from {first:.3f} μ, ×{grow:g}"
        if f is None:
            print(f"  {label}: stalled")
            continue
        forces, gaps_slips_f = f.reshape(-1, 3), (runs.matrix @ f + runs.offset).reshape(-1, 3)
        total = forces.sum(axis=0)
        line = (
            f"  {label}: residual {runs.residual(f, friction) * 1e6:.3f} µm, "
            f"total (p, q1, q2) ({total[0]:.4f}, {total[1]:+.4f}, {total[2]:+.4f}) N"
        )
        if roots:
            apart = np.abs(forces - roots[0].reshape(-1, 3)).max(axis=1)
            line += (
                f"; from the first: force {apart.max() * 1e3:.1f} mN at most, {int((apart > 1e-4).sum())} nodes "
                f"over 0.1 mN, gap/slip {np.abs(gaps_slips_f - gaps_slips[0]).max() * 1e6:.1f} µm at most"
            )
        roots.append(f)
        gaps_slips.append(gaps_slips_f)
        print(line, flush=True)
    return roots


if __name__ == "__main__":
    reversing, stalled = [False], [0]
    contact.solve_coulomb = solve_along_paths(reversing, stalled)
    env = environment("default", FITTED | scaled_entries() | {"surface_spacing_mm": 1.0}, friction=3.0)
    try:
        for y in moves(env):
            reversing[0] = y == 6.0  # the next move is the reversal
            if y == -6.0:
                sys.exit("the reversal ended with one solution at each stalled increment")
    except Apart:
        print("solutions apart: stopped")
