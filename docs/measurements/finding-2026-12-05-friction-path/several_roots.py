"""Several solutions of one increment: the suite's μ = 3 reversal on the fitted dome
(scaled to the 4.3 N press) at 1.0 mm nodes.

Runs ../finding-2026-12-05-shipped-scenarios/hard_case.py's moves. At each increment of
the reversal on which semismooth Newton stalls from the warm start at every augmentation
parameter, it follows the friction up from μ/10 … μ/2, growing each converged stage by
×1.3 … ×2 (halving where a stage stalls, as twin.world.dome.compliant.contact.
solve_coulomb does), and prints how many of those paths reach μ = 3, their largest
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
from hard_case import FITTED, environment, moves  # noqa: E402

SCALED = {"gel_young_kpa": 18.78, "membrane_young_mpa": 0.2347, "skin_bending_mpa": 0.4068, "tip_sway_mm_per_n": 0.1342}
#: (first stage as a fraction of μ, growth after a converged stage)
PATHS = [(1 / 6, 2.0), (1 / 6, 1.5), (1 / 3, 1.5), (1 / 2, 2.0), (1 / 10, 1.3), (1 / 4, 1.5)]


#: stalled increments looked at before giving up
MAX_STALLS = 25


class Apart(Exception):
    """Stops the run at an increment with solutions apart."""


def stalls(matrix, offset, friction, start, tolerance) -> bool:
    """Whether Newton stalls from `start` at every augmentation parameter."""
    strengths = contact._strengths(None, len(offset) // 3)
    r_n, r_t = contact.own_stiffness(matrix)
    return all(
        contact._newton(
            matrix, offset, friction, strengths, start, s * r_n, s * r_t, 100, tolerance, contact.FULL_STEPS
        )[2]
        >= tolerance
        for s in contact.AUGMENTATION_SCALES
    )


def solve_along_paths(reversing: list[bool], stalled: list[int]):
    """solve_coulomb, which at the reversal's stalled increments reports every path's
    solution, goes on from the first, and raises Apart where they differ."""
    solve = contact.solve_coulomb

    def solve_and_report(matrix, offset, friction, start, tolerance, max_iterations, adhesion=None):
        start = np.ascontiguousarray(start, float)
        if not (reversing[0] and stalls(matrix, offset, friction, start, tolerance)):
            return solve(matrix, offset, friction, start, tolerance, max_iterations, adhesion)
        stalled[0] += 1
        roots = report(matrix, offset, friction, start, tolerance, stalled[0])
        if len(roots) > 1 and max(np.abs(r - roots[0]).max() for r in roots[1:]) > 1e-4:
            raise Apart
        if stalled[0] >= MAX_STALLS:
            sys.exit(f"{MAX_STALLS} stalled increments, each with one solution along every path")
        if not roots:
            sys.exit("no path reached μ")
        return roots[0], 0, 0.0

    return solve_and_report


def report(matrix, offset, friction, start, tolerance, number) -> list[np.ndarray]:
    """The solutions at μ along PATHS, with a line on each."""
    nodes = len(offset) // 3
    strengths = contact._strengths(None, nodes)
    r_n, r_t = contact.own_stiffness(matrix)
    print(f"stalled increment {number} of the reversal: {nodes} candidate nodes, μ = {friction:g}")
    roots = []
    for first, grow in PATHS:
        f = follow(matrix, offset, friction, start, tolerance, first, grow)
        label = f"from {first:.3f} μ, ×{grow:g}"
        if f is None:
            print(f"  {label}: stalled")
            continue
        residual = np.abs(contact._alart_curnier_residual(matrix, offset, friction, strengths, f, r_n, r_t)).max()
        forces, gaps_slips = f.reshape(-1, 3), (matrix @ f + offset).reshape(-1, 3)
        total = forces.sum(axis=0)
        line = f"  {label}: residual {residual * 1e6:.3f} µm, total (p, q1, q2) ({total[0]:.4f}, {total[1]:+.4f}, {total[2]:+.4f}) N"
        if roots:
            apart = np.abs(forces - roots[0].reshape(-1, 3)).max(axis=1)
            line += (
                f"; from the first: force {apart.max() * 1e3:.1f} mN at most, {int((apart > 1e-4).sum())} nodes "
                f"over 0.1 mN, gap/slip {np.abs(gaps_slips - (matrix @ roots[0] + offset).reshape(-1, 3)).max() * 1e6:.1f} µm at most"
            )
        roots.append(f)
        print(line, flush=True)
    return roots


def follow(matrix, offset, friction, start, tolerance, first, grow):
    """Newton along rising friction from `first` × μ; the roots at μ, or None."""
    strengths = contact._strengths(None, len(offset) // 3)
    r_n, r_t = contact.own_stiffness(matrix)
    f, reached, rise = start, 0.0, friction * first
    while rise >= friction / 64:
        target = min(friction, reached + rise)
        for s in contact.AUGMENTATION_SCALES:
            attempt, _, residual, _ = contact._newton(
                matrix, offset, target, strengths, f, s * r_n, s * r_t, 100, tolerance, contact.FULL_STEPS
            )
            if residual < tolerance:
                break
        if residual >= tolerance:
            rise *= 0.5
            continue
        f, reached = attempt, target
        if reached >= friction:
            return f
        rise *= grow
    return None


if __name__ == "__main__":
    reversing, stalled = [False], [0]
    contact.solve_coulomb = solve_along_paths(reversing, stalled)
    env = environment("default", FITTED | SCALED | {"surface_spacing_mm": 1.0}, friction=3.0)
    try:
        for y in moves(env):
            reversing[0] = y == 6.0  # the next move is the reversal
            if y == -6.0:
                sys.exit("the reversal ended with one solution at each stalled increment")
    except Apart:
        print("solutions apart: stopped")
