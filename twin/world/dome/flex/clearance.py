"""Which poses of a move keep every object clear of the dome (axis-aligned boxes).

A fidelity level with ``DomeParams.jump_clear_moves`` does not step the stretches of a
move along which nothing can touch the dome: there the skin is at rest or springs back
freely, and the settling that follows every move finishes that quasi-statically. The
test is conservative: each geom that can collide with the dome is bounded by its own
box, carried with the stimulus carrier; the dome by the box of its collision surface at
rest and as it is now; a pose is clear when no geom's box comes within the gap of the
dome's (the contact margin, how far the objects move in one step, and a safety).
"""

from __future__ import annotations

import mujoco
import numpy as np

from twin.world.dome.flex.grid import TacTipHandles, flex_contact_geoms

#: added to the gap (m): what the dome's surface can move beyond the boxes during a
#: skipped stretch (a springing-back skin overshooting its rest shape)
CLEARANCE_SAFETY = 0.001


def _subtree(model: mujoco.MjModel, root: int) -> np.ndarray:
    """(nbody,) bool: the bodies under `root`, itself included."""
    inside = np.zeros(model.nbody, bool)
    inside[root] = True
    for body in range(root + 1, model.nbody):  # MuJoCo numbers a parent before its children
        inside[body] = inside[model.body_parentid[body]]
    return inside


class Clearance:
    """The boxes of a scene's objects and dome, built once (after mj_forward) for
    `poses_clear`.

    carrier: the stimulus carrier's body id; geoms under it move with it, others are
    fixed in the scene."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles, carrier: int) -> None:
        geoms = flex_contact_geoms(model, handles)
        carried = _subtree(model, carrier)[model.geom_bodyid[geoms]]
        centres, halves = _geom_boxes(model, data, geoms)  # scene frame
        c_rot, c_pos = data.xmat[carrier].reshape(3, 3), data.xpos[carrier]
        # carried boxes in the carrier's frame (a box of the rotated box)
        self._carried_centres = (centres[carried] - c_pos) @ c_rot
        self._carried_halves = halves[carried] @ np.abs(c_rot)
        self._fixed_lo = centres[~carried] - halves[~carried]
        self._fixed_hi = centres[~carried] + halves[~carried]
        self._flex_vertices = slice(handles.vert_adr, handles.vert_adr + int(model.flex_vertnum[handles.flex]))
        rest = data.flexvert_xpos[self._flex_vertices]
        self._rest_lo, self._rest_hi = rest.min(axis=0), rest.max(axis=0)
        # MuJoCo makes a contact within the larger of the two margins; their sum bounds it
        self._margin = float(model.flex_margin[handles.flex]) + (
            float(model.geom_margin[geoms].max()) if len(geoms) else 0.0
        )

    def poses_clear(self, data: mujoco.MjData, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """(n,) bool: at which carrier poses (positions (n, 3) m and rotations (n, 3, 3), scene
        frame) no object comes within the gap of the dome, the gap covering the motion
        between consecutive poses."""
        now = data.flexvert_xpos[self._flex_vertices]
        lo = np.minimum(self._rest_lo, now.min(axis=0))
        hi = np.maximum(self._rest_hi, now.max(axis=0))
        centres = np.einsum("nij,gj->ngi", rotations, self._carried_centres) + positions[:, None, :]
        halves = np.einsum("nij,gj->ngi", np.abs(rotations), self._carried_halves)
        # how far a box moves from one pose to the next, at most
        travel = np.linalg.norm(np.diff(centres, axis=0), axis=-1) + np.linalg.norm(np.diff(halves, axis=0), axis=-1)
        step = float(travel.max()) if travel.size else 0.0
        gap = self._margin + step + CLEARANCE_SAFETY
        apart = (centres + halves < lo - gap) | (centres - halves > hi + gap)  # (n, g, 3)
        clear = apart.any(axis=-1).all(axis=-1)
        if len(self._fixed_lo):
            fixed_apart = ((self._fixed_hi < lo - gap) | (self._fixed_lo > hi + gap)).any(axis=-1).all()
            clear &= bool(fixed_apart)
        return clear


def _geom_boxes(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(g, 3) centres and (g, 3) half-sizes (m) of the geoms' boxes in the scene frame;
    a plane's box is unbounded (never clear)."""
    centres = np.empty((len(geoms), 3))
    halves = np.empty((len(geoms), 3))
    for i, g in enumerate(geoms):
        rot = data.geom_xmat[g].reshape(3, 3)
        local_centre, local_half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        centres[i] = data.geom_xpos[g] + rot @ local_centre
        halves[i] = np.inf if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE else np.abs(rot) @ local_half
    return centres, halves
