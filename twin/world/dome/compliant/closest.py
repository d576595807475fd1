"""The object's closest points to points on the dome, for finite sliding
(`CompliantParams.finite_sliding`): each collidable piece is convex (MuJoCo collides a mesh
as its convex hull), so a point outside it has one closest point, which moves continuously
with the point.

Where a point's closest point lies inside one of the piece's faces (the common case: a
node over a face) it is found for every point at once from the piece's face planes: the
plane the point is farthest outside of, if the point's projection onto it lies within the
piece; the direction into the object is then that face's normal, the same bits for every
point over the face, so a contact frame there stays the same while the piece only
translates. The others (near an edge or corner) are measured one by one by MuJoCo's
mj_geomDistance from a probe sphere (`add_probe`), their direction from the point to its
closest point."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial import ConvexHull

#: the body and geom `add_probe` adds; parked this far (m) above the scene between uses
PROBE = "contact_probe"
PROBE_PARKED = 1e3
#: how far (m) a projection may lie outside the piece's other planes and still count as within it
WITHIN = 1e-9


def add_probe(spec: mujoco.MjSpec) -> None:
    """Add the point mj_geomDistance measures from (PROBE): a 1 µm sphere on a mocap body
    parked PROBE_PARKED above the scene, in no collision."""
    body = spec.worldbody.add_body(name=PROBE, mocap=True, pos=[0.0, 0.0, PROBE_PARKED])
    body.add_geom(name=PROBE, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[1e-6, 0, 0], contype=0, conaffinity=0, group=5)


def face_planes(model: mujoco.MjModel, geom: int) -> np.ndarray | None:
    """(F, 4): a box's or a mesh's (its convex hull's) face planes in the geom's frame,
    rows (outward normal, offset): n·x + offset ≤ 0 within it; None for other shapes."""
    kind = model.geom_type[geom]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        half = model.geom_size[geom]
        normals = np.vstack([np.eye(3), -np.eye(3)])
        return np.hstack([normals, -np.concatenate([half, half])[:, None]])
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        return ConvexHull(model.mesh_vert[start : start + count].astype(float)).equations
    return None


class ClosestPoints:
    """The closest points of a scene's collidable pieces (`geoms`) to points in the scene
    frame, within a reach; the scene needs the probe (`add_probe`)."""

    def __init__(self, model: mujoco.MjModel, geoms: np.ndarray) -> None:
        self.model, self.geoms = model, np.asarray(geoms, int)
        self.probe = model.geom(PROBE).id
        self.planes = [face_planes(model, int(g)) for g in self.geoms]
        self._fromto = np.empty(6)

    def __call__(
        self, data: mujoco.MjData, points: np.ndarray, reach: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For `points` (k, 3) m: each one's distance (k,) m to the nearest piece (inf: none
        within `reach` m; ≤ 0: inside one), that piece's closest point (k, 3) m and the unit
        direction (k, 3) from the point into the piece there (undefined where the distance
        is not positive)."""
        distance, closest = np.full(len(points), np.inf), np.zeros((len(points), 3))
        inward = np.zeros((len(points), 3))
        for geom, planes in zip(self.geoms, self.planes):
            to_geom = data.geom_xmat[geom].reshape(3, 3)
            local = (points - data.geom_xpos[geom]) @ to_geom  # the points in the geom's frame
            aabb = self.model.geom_aabb[geom]
            outside_box = np.maximum(np.abs(local - aabb[:3]) - aabb[3:], 0.0)
            todo = np.flatnonzero(np.einsum("ki,ki->k", outside_box, outside_box) <= reach**2)
            if planes is not None and len(todo):
                heights = local[todo] @ planes[:, :3].T + planes[:, 3]
                face = np.argmax(heights, axis=1)
                height = heights[np.arange(len(todo)), face]
                foot = local[todo] - height[:, None] * planes[face, :3]
                within = (height > 0.0) & np.all(foot @ planes[:, :3].T + planes[:, 3] <= WITHIN, axis=1)
                found, height, foot = todo[within], height[within], foot[within]
                nearer = height < distance[found]
                distance[found[nearer]] = height[nearer]
                closest[found[nearer]] = foot[nearer] @ to_geom.T + data.geom_xpos[geom]
                inward[found[nearer]] = -planes[face[within][nearer], :3] @ to_geom.T
                todo = todo[~within]
            for k in todo:
                data.geom_xpos[self.probe] = points[k]
                best = min(reach, distance[k])
                # to the probe's surface: its radius more to its centre, the point
                dist = mujoco.mj_geomDistance(self.model, data, int(geom), self.probe, best, self._fromto)
                dist += self.model.geom_size[self.probe, 0]
                if dist < best:
                    distance[k], closest[k] = dist, self._fromto[:3]
                    towards = closest[k] - points[k]
                    length = np.linalg.norm(towards)
                    if length > 0.0:  # not on or inside the piece
                        inward[k] = towards / length
        data.geom_xpos[self.probe] = (0.0, 0.0, PROBE_PARKED)
        return distance, closest, inward
