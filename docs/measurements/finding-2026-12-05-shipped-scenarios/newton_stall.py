"""Where the contact solve stalls on the fitted dome at 1.0 mm nodes and μ = 3
(hard_case.py's moves): the first frictional increment on which Newton stalls from the
warm start at every augmentation parameter the solver tries (the first that took over 3 s
before the solver followed the friction up) is kept, and semismooth Newton is run on it alone at augmentation parameters from 1 to 0.003 times each
node's own stiffness. Prints the residual Newton stops at, the nodes that hold it, and how
far each node's compliance row reaches beyond its diagonal.

    python newton_stall.py > newton-stall.txt
"""

import numpy as np
from hard_case import FITTED, environment, moves

import twin.world.dome.compliant.contact as contact

kept: dict = {}


class Kept(Exception):
    """The slow increment is kept: stop the run."""


def keep_first_stall(matrix, offset, friction, start, tolerance, max_iterations, adhesion=None):
    runs = contact.NewtonRuns.of(matrix, offset, tolerance, max_iterations, adhesion)
    f, iterations, residual = runs.from_start(start, friction)
    if residual < tolerance:
        return f, iterations, residual  # what solve_coulomb returns there
    kept.update(matrix=matrix, offset=offset, friction=friction, start=start, tolerance=tolerance)
    raise Kept


contact.solve_coulomb = keep_first_stall
try:
    for _ in moves(environment("default", FITTED | {"surface_spacing_mm": 1.0})):
        pass
except Kept:
    pass
matrix, offset, mu, start, tolerance = (kept[k] for k in ("matrix", "offset", "friction", "start", "tolerance"))
nodes = len(offset) // 3
strengths = contact._strengths(None, nodes)
stiffness_n, stiffness_t = contact.own_stiffness(matrix)
normal = np.arange(nodes) * 3
reach = np.abs(matrix[np.ix_(normal, normal)]).sum(axis=1) / np.diag(matrix)[normal]
print(f"the slow increment: {nodes} candidate nodes, μ = {mu:g}, tolerance {tolerance:.3g} m")
print(
    f"each node's normal compliance row over its diagonal: median {np.median(reach):.1f}, range {reach.min():.1f}–{reach.max():.1f}"
)
stops = {}
for scale in (1.0, 0.3, 0.1, 0.03, 0.01, 0.003):
    stops[scale] = contact._newton(
        matrix,
        offset,
        mu,
        strengths,
        np.ascontiguousarray(start, float),
        scale * stiffness_n,
        scale * stiffness_t,
        1000,
        tolerance,
        contact.FULL_STEPS,
    )
    print(
        f"r = {scale:5.3f} × own stiffness: Newton stops after {stops[scale][1]:4d} iterations "
        f"at a residual of {stops[scale][2]:.2g} m"
    )
f, _, _, in_contact = stops[1.0]
residual = contact._alart_curnier_residual(matrix, offset, mu, strengths, f, stiffness_n, stiffness_t).reshape(-1, 3)
forces, motion = f.reshape(-1, 3), (matrix @ f + offset).reshape(-1, 3)
print(f"at r = 1: {in_contact.sum()} of {nodes} nodes in contact; the six largest residuals:")
print("  node  residual n, t1, t2 (µm)   pressure (N)  |q| / μp   gap (µm)  slip t1, t2 (µm)")
for i in np.argsort(-np.abs(residual).max(axis=1))[:6]:
    ratio = np.linalg.norm(forces[i, 1:]) / (mu * abs(forces[i, 0]) + 1e-30)
    print(
        f"  {i:4d}  {residual[i, 0] * 1e6:+6.2f} {residual[i, 1] * 1e6:+6.2f} {residual[i, 2] * 1e6:+6.2f}"
        f"   {forces[i, 0]:+.5f}      {ratio:6.3f}   {motion[i, 0] * 1e6:+7.3f}  {motion[i, 1] * 1e6:+7.3f} {motion[i, 2] * 1e6:+7.3f}"
    )
