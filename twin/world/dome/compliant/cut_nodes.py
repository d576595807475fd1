"""Nodes cut by the boundary of an object's face: the part of each node's disc on the face.

A node carries the traction on a disc of its own area (twin.world.dome.compliant.compliance),
and its contact is decided by one ray, through its centre. Where a face ends inside the
disc (a straight edge's corner), the node is then either wholly on the face or wholly off
it, so the edge's pressure peak, which the last row of nodes before the edge carries, moves
in steps of a spacing as the edge moves: the pins beside the edge move by up to 3 px
between placements on 1.5 mm nodes (docs/dome/compliant.md).

Here each disc near a face's boundary is sampled by rays through `DISC_SAMPLES`. The part
of the disc where the face lies (`CutNodes.covered`, a fraction of the disc) gives the
node:

* its gap: the mean gap over that part (on a plane, the gap at the part's centroid);
* the face's normal there (its contact frame);
* its compliance as a disc of that smaller area (`partial_disc_compliance`): a smaller
  patch pressed as far takes less force;
* the point the pins take its force at: that part's centroid (`CutNodes.centroids`).

So the edge's load and where it acts follow the edge continuously within a node. A disc
wholly on one face is left as it is: a press or a slide on a face, with no boundary in
reach, is solved as at whole nodes (Hertz and Cattaneo–Mindlin hold as before).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def _hexagonal_samples(rings: int) -> np.ndarray:
    """(S, 3): points of a hexagonal grid within the unit disc, `rings` rings about the
    centre, each standing for an equal share of the disc: (x, y, weight)."""
    points = [
        (i + 0.5 * j, j * math.sqrt(3.0) / 2.0)
        for i in range(-rings, rings + 1)
        for j in range(-rings, rings + 1)
        if math.hypot(i + 0.5 * j, j * math.sqrt(3.0) / 2.0) <= rings + 1e-9
    ]
    xy = np.array(points) / (rings + 0.5)
    return np.column_stack([xy, np.full(len(xy), 1.0 / len(xy))])


#: Where a node's disc is sampled, on the unit disc: (x, y, weight), 19 points. On a 3 mm
#: press and slide beside the straight edge, edges 1.5 mm onto … 1.5 mm off the sensor, they
#: place the pins within 0.09 px RMS (worst pin 0.65 px) of 91 points; Radon's 7 (DISC_RULE)
#: within 0.17 px RMS (0.90 px); 37 within 0.10 px RMS (0.77 px), each with the pins loaded at
#: the node itself (docs/dome/compliant.md).
DISC_SAMPLES = _hexagonal_samples(2)
#: the most a face may turn within one disc and still count as the same surface (deg): a
#: meshed curve's neighbouring facets turn by a few degrees, an edge's corner by tens
SAME_SURFACE_DEG = 30.0
#: a sample sees a face it can meet only where the face turns less than this from the ray (deg):
#: past an edge, the rays that graze the side wall do not cover the disc
FACING_DEG = 60.0


@dataclass(frozen=True)
class CutNodes:
    """The nodes whose disc a face's boundary crosses, and the part of it on the face.

    nodes (k,) indices; covered (k,) the fraction of each disc on the face, in (0, 1);
    gaps (k,) m: the mean rigid gap over that part, along the face's normal; normals (k, 3):
    the face's normal into the object; geoms (k,): the MuJoCo geom of that face;
    centroids (k, 3): the unit direction from the dome's sphere centre through the part's
    centroid.
    """

    nodes: np.ndarray
    covered: np.ndarray
    gaps: np.ndarray
    normals: np.ndarray
    geoms: np.ndarray
    centroids: np.ndarray


def sample_directions(points: np.ndarray, tangents: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """(N, S, 3): unit directions from the sphere `centre` (3,) m through each node's
    `DISC_SAMPLES` on the disc of `radius` (m) about the node, in its tangent plane (points
    (N, 3) m, tangents (N, 2, 3))."""
    offsets = np.einsum("sk,nkj->nsj", DISC_SAMPLES[:, :2] * radius, tangents)
    through = points[:, None, :] + offsets - centre
    return through / np.linalg.norm(through, axis=2)[..., None]


def cut_nodes(
    nodes: np.ndarray,
    directions: np.ndarray,
    hit: np.ndarray,
    along: np.ndarray,
    face_normals: np.ndarray,
    geoms: np.ndarray,
    lift: np.ndarray | None,
    reach: float,
) -> CutNodes:
    """The cut ones among `nodes` (k,), from the rays through their samples: directions
    (k, S, 3) unit; hit (k, S) whether a ray met a face; along (k, S) m: how far beyond the
    dome's outer surface it met it; face_normals (k, S, 3): the face's normal into the
    object; geoms (k, S); lift (k,) m: each node's lift onto a flatter apex profile along
    the dome's axis (None: the sphere's own; twin.world.dome.compliant.physics.apex_lift).

    A sample covers its node's disc where its ray meets a face within `reach` (m) beyond the
    dome, facing it (`FACING_DEG`), and on the surface of the disc's most penetrated sample
    (within `SAME_SURFACE_DEG` of its normal)."""
    weights = DISC_SAMPLES[:, 2]
    facing = np.einsum("ksj,ksj->ks", face_normals, directions)
    valid = hit & (along < reach) & (facing > math.cos(math.radians(FACING_DEG)))
    gap = along * facing
    if lift is not None:
        gap = gap - lift[:, None] * face_normals[..., 2]
    deepest = np.argmin(np.where(valid, gap, np.inf), axis=1)
    rows = np.arange(len(nodes))
    surface_normal = face_normals[rows, deepest]
    same = valid & (np.einsum("ksj,kj->ks", face_normals, surface_normal) > math.cos(math.radians(SAME_SURFACE_DEG)))
    covered = same.astype(float) @ weights
    cut = (covered > 0.0) & (covered < 1.0 - 1e-9)
    share = np.where(same, weights, 0.0)[cut] / covered[cut, None]
    centroids = np.einsum("ks,ksj->kj", share, directions[cut])
    normals = np.einsum("ks,ksj->kj", share, face_normals[cut])
    return CutNodes(
        nodes=np.asarray(nodes)[cut],
        covered=covered[cut],
        gaps=np.einsum("ks,ks->k", share, np.where(same[cut], gap[cut], 0.0)),
        normals=normals / np.linalg.norm(normals, axis=1)[:, None],
        geoms=geoms[rows[cut], deepest[cut]],
        centroids=centroids / np.linalg.norm(centroids, axis=1)[:, None],
    )


def partial_disc_compliance(covered: np.ndarray, own: np.ndarray) -> np.ndarray:
    """(m, 3) m/N: what each node's self-compliance `own` (m, 3) m/N, in its contact frame's
    axes (normal, t1, t2), gains where only the fraction `covered` (m,) of its disc carries
    the traction: a disc's own term goes as 1/radius (twin.world.dome.compliant.compliance.
    self_compliance), so a part of area φA yields 1/√φ times as much. 0 where wholly covered."""
    return (1.0 / np.sqrt(covered) - 1.0)[:, None] * own
