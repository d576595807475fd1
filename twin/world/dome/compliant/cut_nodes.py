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

from twin.world.dome.compiled import compiled


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


def boundary_nodes(
    indptr: np.ndarray,
    indices: np.ndarray,
    gaps: np.ndarray,
    on_face: np.ndarray,
    normals: np.ndarray,
    within: float,
) -> np.ndarray:
    """(N,) bool: the nodes whose discs are sampled: those whose neighbourhood sees a face
    end (`on_face` (N,) bool: the centre ray meets a face it faces, within reach) or turn by
    more than `SAME_SURFACE_DEG` (normals (N, 3): the face's, into the object), where the
    node or a neighbour on the face lies `within` (m) of the object (gaps (N,) m: the
    centre rays'). The neighbourhoods: a CSR pattern (`indptr`, `indices`), each node its
    own neighbour too, reaching farther than a disc's radius plus the lattice's widest gap."""
    return _boundary_nodes(indptr, indices, gaps, on_face, normals, within, math.cos(math.radians(SAME_SURFACE_DEG)))


@compiled
def _boundary_nodes(
    indptr: np.ndarray,
    indices: np.ndarray,
    gaps: np.ndarray,
    on_face: np.ndarray,
    normals: np.ndarray,
    within: float,
    turn: float,
) -> np.ndarray:
    n = len(gaps)
    sampled = np.zeros(n, np.bool_)
    for i in range(n):
        close = gaps[i] < within
        ends = False
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if on_face[j] != on_face[i]:
                ends = True
            elif on_face[i] and (
                normals[i, 0] * normals[j, 0] + normals[i, 1] * normals[j, 1] + normals[i, 2] * normals[j, 2] < turn
            ):
                ends = True
            if on_face[j] and gaps[j] < within:
                close = True
        sampled[i] = ends and close
    return sampled


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
    ray_normals: np.ndarray,
    geoms: np.ndarray,
    lift: np.ndarray | None,
    reach: float,
) -> CutNodes:
    """The cut ones among `nodes` (k,), from the rays through their samples: directions
    (k, S, 3) unit; hit (k, S) whether a ray met a face; along (k, S) m: how far beyond the
    dome's outer surface it met it; ray_normals (k, S, 3): the face's unit normal as the ray
    cast gave it (either way); geoms (k, S); lift (k,) m: each node's lift onto a flatter
    apex profile along the dome's axis (None: the sphere's own;
    twin.world.dome.compliant.physics.apex_lift).

    A sample covers its node's disc where its ray meets a face within `reach` (m) beyond the
    dome, facing it (`FACING_DEG`), and on the surface of the disc's most penetrated sample
    (within `SAME_SURFACE_DEG` of its normal)."""
    covered, gaps, normals, centroids, deepest = _cover(
        directions,
        hit,
        along,
        ray_normals,
        np.zeros(len(nodes)) if lift is None else lift,
        DISC_SAMPLES[:, 2],
        reach,
        math.cos(math.radians(FACING_DEG)),
        math.cos(math.radians(SAME_SURFACE_DEG)),
    )
    cut = np.flatnonzero((covered > 0.0) & (covered < 1.0 - 1e-9))
    return CutNodes(
        nodes=np.asarray(nodes)[cut],
        covered=covered[cut],
        gaps=gaps[cut],
        normals=normals[cut],
        geoms=geoms[cut, deepest[cut]],
        centroids=centroids[cut],
    )


@compiled
def _cover(
    directions: np.ndarray,
    hit: np.ndarray,
    along: np.ndarray,
    ray_normals: np.ndarray,
    lift: np.ndarray,
    weights: np.ndarray,
    reach: float,
    facing_at_least: float,
    same_at_least: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per disc (`cut_nodes`): the covered share (k,), the mean gap over it (k,) m, the
    face's mean normal into the object (k, 3) and the part's centroid direction (k, 3),
    both unit, and the most penetrated sample (k,)."""
    k_count, s_count = hit.shape
    covered = np.zeros(k_count)
    gaps = np.zeros(k_count)
    normals = np.zeros((k_count, 3))
    centroids = np.zeros((k_count, 3))
    deepest = np.zeros(k_count, np.int64)
    face = np.zeros((s_count, 3))
    gap = np.zeros(s_count)
    valid = np.zeros(s_count, np.bool_)
    for k in range(k_count):
        best = np.inf
        for s in range(s_count):
            facing = -(
                ray_normals[k, s, 0] * directions[k, s, 0]
                + ray_normals[k, s, 1] * directions[k, s, 1]
                + ray_normals[k, s, 2] * directions[k, s, 2]
            )
            sign = -1.0 if facing >= 0.0 else 1.0  # into the object, whichever way the face was hit
            for a in range(3):
                face[s, a] = sign * ray_normals[k, s, a]
            facing = abs(facing)
            gap[s] = along[k, s] * facing - lift[k] * face[s, 2]
            valid[s] = hit[k, s] and along[k, s] < reach and facing > facing_at_least
            if valid[s] and gap[s] < best:
                best, deepest[k] = gap[s], s
        if best == np.inf:
            continue
        d = deepest[k]
        for s in range(s_count):
            if valid[s] and face[s, 0] * face[d, 0] + face[s, 1] * face[d, 1] + face[s, 2] * face[d, 2] > same_at_least:
                w = weights[s]
                covered[k] += w
                gaps[k] += w * gap[s]
                for a in range(3):
                    normals[k, a] += w * face[s, a]
                    centroids[k, a] += w * directions[k, s, a]
        gaps[k] /= covered[k]
        normals[k] /= np.sqrt(normals[k, 0] ** 2 + normals[k, 1] ** 2 + normals[k, 2] ** 2)
        centroids[k] /= np.sqrt(centroids[k, 0] ** 2 + centroids[k, 1] ** 2 + centroids[k, 2] ** 2)
    return covered, gaps, normals, centroids, deepest


def partial_disc_compliance(covered: np.ndarray, own: np.ndarray) -> np.ndarray:
    """(m, 3) m/N: what each node's self-compliance `own` (m, 3) m/N, in its contact frame's
    axes (normal, t1, t2), gains where only the fraction `covered` (m,) of its disc carries
    the traction: a disc's own term goes as 1/radius (twin.world.dome.compliant.compliance.
    self_compliance), so a part of area φA yields 1/√φ times as much. 0 where wholly covered."""
    return (1.0 / np.sqrt(covered) - 1.0)[:, None] * own
