"""Outline geometry of flat stimuli: the paper's outlines, triangulation, convex
partition and extrusion (mm in outlines, m in meshes; object frame of twin.world.stimuli.objects)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mapbox_earcut
import numpy as np
import trimesh
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

MM = 1e-3  # m per mm
SAGITTA_MM = 0.05  # max chord-to-arc deviation when curved outlines are sampled (mm)


# --------------------------------------------------------------------------- outline builders


def _arc_steps(radius_mm: float, sweep_rad: float, sagitta_mm: float = SAGITTA_MM) -> int:
    """Segments needed so a chord deviates at most `sagitta_mm` from an arc of `radius_mm`."""
    if radius_mm <= sagitta_mm:
        return 1
    step = 2.0 * math.acos(1.0 - sagitta_mm / radius_mm)
    return max(1, math.ceil(abs(sweep_rad) / step))


def _polygon(pts) -> Polygon:
    """CCW polygon from (n, 2) mm vertices rounded to 1e-9 mm (hides libm noise, no −0)."""
    return orient(Polygon(np.round(np.asarray(pts, dtype=float), 9) + 0.0), 1.0)


def rectangle_outline(width_mm: float = 120.0, height_mm: float = 80.0) -> Polygon:
    """Axis-aligned rectangle centred on the origin with sharp corners (mm)."""
    w, h = width_mm / 2, height_mm / 2
    return _polygon([(-w, -h), (w, -h), (w, h), (-w, h)])


def circle_outline(diameter_mm: float) -> Polygon:
    """Regular polygon inscribed in a circle of `diameter_mm`, centred on the origin.

    The vertex count is a multiple of 4 with chord sagitta ≤ SAGITTA_MM; one vertex sits
    at the bottom (−y), where contour following starts.
    """
    r = diameter_mm / 2
    n = 4 * math.ceil(_arc_steps(r, 2 * math.pi) / 4)
    phi = -math.pi / 2 + 2 * math.pi * np.arange(n) / n
    return _polygon(np.column_stack([r * np.cos(phi), r * np.sin(phi)]))


def flower_outline(r0_mm: float = 50.0, amplitude_mm: float = 8.0, petals: int = 5, samples: int = 180) -> Polygon:
    """Polar flower r(φ) = r0 + a·cos(n(φ − 90°)): `petals` lobes, one petal tip at +y.

    Between the petals the outline is concave; with the defaults the tightest concave
    radius of curvature is 11.2 mm and the petal tips' convex radius 13.0 mm.
    """
    phi = -math.pi / 2 + 2 * math.pi * np.arange(samples) / samples
    r = r0_mm + amplitude_mm * np.cos(petals * (phi - math.pi / 2))
    return _polygon(np.column_stack([r * np.cos(phi), r * np.sin(phi)]))


def flower_curvature_radii(r0_mm: float = 50.0, amplitude_mm: float = 8.0, petals: int = 5) -> tuple[float, float]:
    """(concave radius between petals, convex radius at a petal tip) in mm, analytic."""
    n2a = petals**2 * amplitude_mm
    valley, tip = r0_mm - amplitude_mm, r0_mm + amplitude_mm
    # polar curvature κ = (r² + 2r'² − r r'') / (r² + r'²)^1.5 with r' = 0 at both
    return valley**2 / (n2a - valley), tip**2 / (tip + n2a)


@dataclass(frozen=True)
class SpiralParams:
    """Archimedean spiral band (laser-cut acrylic); all lengths in mm.

    Band centreline r(t) = r_start + pitch·t/2π at polar angle φ(t) = φ_end + T − t,
    t ∈ [0, T] (T = 2π·turns): the spiral winds *clockwise* outwards, so tracing its
    outer edge inwards is counter-clockwise. Edges are the centreline ± width/2 measured
    radially; both ends are cut square (radially), giving 4 corners.
    """

    width: float = 8.0  # radial width of the acrylic band
    gap: float = 20.0  # radial clear gap between neighbouring turns
    r_start: float = 22.0  # centreline radius at the inner end
    turns: float = 2.0  # number of turns of the band
    phi_end_deg: float = -90.0  # polar angle of the outer end (start of tracing)
    start_arc: float = 15.0  # tracing starts this far (arc length) from the outer end
    sagitta: float = 0.1  # chord sagitta of the edge sampling (≈ laser kerf); sets the piece count

    @property
    def pitch(self) -> float:
        return self.width + self.gap

    @property
    def t_max(self) -> float:
        return 2 * math.pi * self.turns

    def centre_radius(self, t: np.ndarray | float) -> np.ndarray | float:
        return self.r_start + self.pitch * np.asarray(t) / (2 * math.pi)

    def angle(self, t: np.ndarray | float) -> np.ndarray | float:
        return math.radians(self.phi_end_deg) + self.t_max - np.asarray(t)

    def edge_point(self, t: float, side: float) -> tuple[float, float]:
        """Point on the outer (side=+1) or inner (side=−1) edge at parameter t (mm)."""
        r = float(self.centre_radius(t)) + side * self.width / 2
        a = float(self.angle(t))
        return (round(r * math.cos(a), 9) + 0.0, round(r * math.sin(a), 9) + 0.0)

    def edge_ts(self, side: float) -> np.ndarray:
        """Parameters t sampling one edge with chord sagitta ≤ `sagitta`, ascending."""
        ts = [0.0]
        while True:
            r = float(self.centre_radius(ts[-1])) + side * self.width / 2
            step = 2.0 * math.acos(1.0 - self.sagitta / r)
            if ts[-1] + step >= self.t_max - 0.25 * step:
                break
            ts.append(ts[-1] + step)
        ts.append(self.t_max)
        return np.array(ts)


def spiral_outline(p: SpiralParams = SpiralParams()) -> Polygon:
    """Closed outline of the spiral band (mm), exterior counter-clockwise."""
    to = p.edge_ts(+1.0)
    ti = p.edge_ts(-1.0)[::-1]
    outer = [p.edge_point(float(t), +1.0) for t in to]
    inner = [p.edge_point(float(t), -1.0) for t in ti]
    return _polygon(outer + inner)


def spiral_start_end(p: SpiralParams = SpiralParams()) -> tuple[tuple[float, float], tuple[float, float]]:
    """(start, end) of tracing (mm): on the outer edge `start_arc` from the outer end, and
    the outer-edge corner of the inner end."""
    r_out = float(p.centre_radius(p.t_max)) + p.width / 2
    start = p.edge_point(p.t_max - p.start_arc / r_out, +1.0)
    return start, p.edge_point(0.0, +1.0)


def rounded_rectangle_outline(width_mm: float, height_mm: float, radii_mm: Sequence[float]) -> Polygon:
    """Rectangle centred on the origin with per-corner radii (mm), in the order
    bottom-right, top-right, top-left, bottom-left; a radius of 0 keeps the corner sharp."""
    w, h = width_mm / 2, height_mm / 2
    corners = [(w, -h, -90.0), (w, h, 0.0), (-w, h, 90.0), (-w, -h, 180.0)]
    pts: list[tuple[float, float]] = []
    for (cx, cy, a0), r in zip(corners, radii_mm):
        if r <= 0:
            pts.append((cx, cy))
            continue
        ox, oy = cx - math.copysign(r, cx), cy - math.copysign(r, cy)
        n = _arc_steps(r, math.pi / 2)
        for k in range(n + 1):
            a = math.radians(a0 + 90.0 * k / n)
            pts.append((ox + r * math.cos(a), oy + r * math.sin(a)))
    return _polygon(pts)


TAPE_MEASURE = {"width": 70.0, "height": 70.0, "radii": (0.0, 30.0, 30.0, 12.0)}


def tape_measure_outline() -> Polygon:
    """Tape-measure case seen from above lying on its side (mm): reel housing with two
    R30 corners at the top, an R12 back-bottom corner and a sharp front-bottom corner (+x,
    −y) where the blade exits."""
    t = TAPE_MEASURE
    return rounded_rectangle_outline(t["width"], t["height"], t["radii"])


# --------------------------------------------------------------------------- geometry helpers


def _rings(poly: Polygon) -> list[np.ndarray]:
    """Exterior (CCW) then interiors (CW) as (k, 2) arrays without the closing point."""
    poly = orient(poly, 1.0)
    return [np.asarray(poly.exterior.coords)[:-1]] + [np.asarray(r.coords)[:-1] for r in poly.interiors]


def _triangulate(poly: Polygon) -> tuple[np.ndarray, np.ndarray]:
    """Earcut triangulation: (vertices (n, 2) mm, triangles (m, 3) CCW indices)."""
    rings = _rings(poly)
    verts = np.vstack(rings).astype(np.float64)
    ends = np.cumsum([len(r) for r in rings]).astype(np.uint32)
    tri = mapbox_earcut.triangulate_float64(verts, ends).reshape(-1, 3).astype(np.int64)
    a, b, c = verts[tri[:, 0]], verts[tri[:, 1]], verts[tri[:, 2]]
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    tri[cross < 0] = tri[cross < 0][:, ::-1]
    return verts, tri


def _orient2d(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def _in_circle(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> float:
    """> 0 if d lies inside the circumcircle of the CCW triangle (a, b, c)."""
    m = np.array([[*(p - d), float(np.dot(p - d, p - d))] for p in (a, b, c)])
    return float(np.linalg.det(m))


def _delaunay_flip(verts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Lawson edge flips turning a triangulation into the constrained Delaunay one
    (boundary edges fixed): no slivers from earcut's fans, better-shaped convex pieces."""
    tris = [list(map(int, t)) for t in tris]
    owner = {(t[k], t[(k + 1) % 3]): i for i, t in enumerate(tris) for k in range(3)}
    stack = sorted({(min(u, v), max(u, v)) for (u, v) in owner if (v, u) in owner}, reverse=True)
    scale = float(np.max(np.ptp(verts, axis=0))) ** 4
    budget = 100 * len(tris) + 100
    while stack and budget > 0:
        budget -= 1
        u, v = stack.pop()
        i, j = owner.get((u, v)), owner.get((v, u))
        if i is None or j is None:
            continue
        a = next(x for x in tris[i] if x not in (u, v))  # tris[i] ~ (u, v, a)
        b = next(x for x in tris[j] if x not in (u, v))  # tris[j] ~ (v, u, b)
        if _in_circle(verts[u], verts[v], verts[a], verts[b]) <= 1e-12 * scale:
            continue
        if _orient2d(verts[u], verts[b], verts[a]) <= 0 or _orient2d(verts[b], verts[v], verts[a]) <= 0:
            continue  # quad not strictly convex: the flip would fold
        for t in (tris[i], tris[j]):
            for k in range(3):
                owner.pop((t[k], t[(k + 1) % 3]), None)
        tris[i], tris[j] = [u, b, a], [b, v, a]
        for idx in (i, j):
            t = tris[idx]
            for k in range(3):
                owner[(t[k], t[(k + 1) % 3])] = idx
        for e in ((u, b), (b, v), (v, a), (a, u)):
            stack.append((min(e), max(e)))
    return np.array(tris, dtype=np.int64)


def _is_convex_cycle(pts: np.ndarray, idx: Sequence[int], at: Sequence[int]) -> bool:
    """True if the CCW polygon pts[idx] turns left (or goes straight) at positions `at`."""
    n = len(idx)
    for k in at:
        p0, p1, p2 = pts[idx[k - 1]], pts[idx[k]], pts[idx[(k + 1) % n]]
        e1, e2 = p1 - p0, p2 - p1
        cross = e1[0] * e2[1] - e1[1] * e2[0]
        if cross < -1e-9 * (np.hypot(*e1) * np.hypot(*e2) + 1e-300):
            return False
    return True


def convex_partition(poly: Polygon) -> list[np.ndarray]:
    """Split a polygon (holes allowed) into convex pieces, each a (k, 2) CCW array (mm).

    Hertel–Mehlhorn: earcut-triangulate, then remove internal diagonals (longest first)
    whenever the two pieces they separate merge into a convex polygon. At most 4× the
    optimal piece count; exact union (no gaps, no overlaps).
    """
    verts, tris = _triangulate(poly)
    tris = _delaunay_flip(verts, tris)
    pieces: dict[int, list[int]] = {i: [int(v) for v in t] for i, t in enumerate(tris)}
    edge_owner: dict[tuple[int, int], int] = {}  # directed edge (u, v) -> piece id
    for pid, cyc in pieces.items():
        for k in range(3):
            edge_owner[(cyc[k], cyc[(k + 1) % 3])] = pid
    diagonals = sorted(
        {(min(u, v), max(u, v)) for (u, v) in edge_owner if (v, u) in edge_owner},
        key=lambda e: (-float(np.hypot(*(verts[e[0]] - verts[e[1]]))), e),
    )
    next_id = len(pieces)
    for u, v in diagonals:
        a, b = edge_owner.get((u, v)), edge_owner.get((v, u))
        if a is None or b is None or a == b:
            continue
        A, B = pieces[a], pieces[b]
        ia, ib = A.index(u), B.index(v)
        A_rot = A[ia + 1 :] + A[: ia + 1]  # starts at v, ends at u
        B_rot = B[ib + 1 :] + B[: ib + 1]  # starts at u, ends at v
        merged = A_rot + B_rot[1:-1]
        if not _is_convex_cycle(verts, merged, [0, len(A_rot) - 1]):
            continue
        del pieces[a], pieces[b], edge_owner[(u, v)], edge_owner[(v, u)]
        pieces[next_id] = merged
        for k in range(len(merged)):
            edge_owner[(merged[k], merged[(k + 1) % len(merged)])] = next_id
        next_id += 1
    out = []
    for pid in sorted(pieces):
        p = verts[pieces[pid]]
        if abs(_shoelace(p)) > 1e-9:
            out.append(p)
    return out


def _shoelace(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def extrude_mesh(poly: Polygon, thickness_mm: float) -> trimesh.Trimesh:
    """Watertight prism of `poly` over z ∈ [−thickness, 0], in metres (outward normals)."""
    verts2, tris = _triangulate(poly)
    n = len(verts2)
    top = np.column_stack([verts2, np.zeros(n)])
    bottom = np.column_stack([verts2, np.full(n, -thickness_mm)])
    faces = [tris, tris[:, ::-1] + n]
    start = 0
    for ring in _rings(poly):
        k = len(ring)
        i = start + np.arange(k)
        j = start + (np.arange(k) + 1) % k
        faces.append(np.column_stack([i, i + n, j + n]))
        faces.append(np.column_stack([i, j + n, j]))
        start += k
    return trimesh.Trimesh(np.vstack([top, bottom]) * MM, np.vstack(faces), process=False)


#: facets of a rounded top edge, over its quarter turn: neighbours turn by under 3°, so a
#: dome's contact reads them as one curved surface
ROUNDED_EDGE_FACETS = 32


def rounded_sections(outline: Polygon, radius_mm: float) -> list[tuple[Polygon, float]]:
    """The sections (mm) of `outline`'s rounded top edge, from the flat top down: the
    outline inset by r(1 − sin φ) at z = −r(1 − cos φ), φ over a quarter turn in
    `ROUNDED_EDGE_FACETS` steps; mitred, so corners seen from above stay as they are. The
    last is the outline itself, where the side meets the round, counter-clockwise and
    without vertices midway along a side (earcut drops those; so then do the sides)."""
    outline = orient(outline.simplify(0.0), 1.0)
    phis = np.linspace(0.0, 0.5 * np.pi, ROUNDED_EDGE_FACETS + 1)[:-1]
    return [
        (outline.buffer(-radius_mm * (1.0 - np.sin(p)), join_style="mitre"), -radius_mm * (1.0 - np.cos(p)))
        for p in phis
    ] + [(outline, -radius_mm)]


def rounded_top_mesh(sections: list[tuple[Polygon, float]], thickness_mm: float) -> trimesh.Trimesh:
    """Watertight solid in metres over z ∈ [−thickness, 0] of the outline whose rounded top
    edge has these `rounded_sections` (convex or not): the flat top, each band between two
    sections and the bottom triangulated by earcut on the sections' own vertices, so every
    band shares its edges with the next. ValueError where a section is not one polygon (a
    radius beyond half the outline's width somewhere)."""
    layers = [*sections, (sections[-1][0], -thickness_mm)]
    if any(section.geom_type != "Polygon" or section.is_empty for section, _ in layers):
        raise ValueError("an inset of the round splits or empties the outline")
    vertices: list[np.ndarray] = []
    index: list[dict[tuple[float, float], int]] = []
    for section, z in layers:
        ring_xy = np.vstack(_rings(section))
        index.append({(float(x), float(y)): len(vertices) + i for i, (x, y) in enumerate(ring_xy)})
        vertices.extend(np.column_stack([ring_xy, np.full(len(ring_xy), z)]))

    def faces(region: Polygon, *levels: int) -> np.ndarray:
        xy, tris = _triangulate(region)
        lookup = {k: v for level in levels for k, v in index[level].items()}
        return np.array([lookup[(float(x), float(y))] for x, y in xy])[tris]

    top, outer = layers[0][0], layers[-2][0]
    parts = [faces(top, 0)]
    for k in range(len(layers) - 2):  # the bands of the round; its last section is the outline itself
        inner, wider = layers[k][0], layers[k + 1][0]
        parts.append(faces(Polygon(wider.exterior, [inner.exterior]), k, k + 1))
        for hole in wider.interiors:
            around = next(h for h in inner.interiors if Polygon(h).contains(Polygon(hole).representative_point()))
            parts.append(faces(Polygon(around, [hole]), k, k + 1))
    bottom = len(layers) - 1
    for ring_top, ring_bottom in zip(_rings(outer), _rings(layers[-1][0]), strict=True):
        i = np.array([index[bottom - 1][(float(x), float(y))] for x, y in ring_top])
        j = np.array([index[bottom][(float(x), float(y))] for x, y in ring_bottom])
        parts.append(np.column_stack([i, np.roll(i, -1), j]))
        parts.append(np.column_stack([np.roll(i, -1), np.roll(j, -1), j]))
    parts.append(faces(layers[-1][0], bottom))
    mesh = trimesh.Trimesh(np.asarray(vertices) * MM, np.vstack(parts), process=False)
    trimesh.repair.fix_normals(mesh)
    return mesh


def rounded_piece_mesh(piece: Polygon, sections: list[tuple[Polygon, float]], thickness_mm: float) -> trimesh.Trimesh:
    """Convex solid in metres of the convex `piece` (mm) of an outline over z ∈ [−thickness, 0],
    the outline's top edge rounded where it bounds the piece as its `rounded_sections` say,
    the piece's cuts through the outline left upright: the hull of the piece within each
    section and of the piece at the bottom. The pieces of a partition then meet along their
    cuts at every height. ValueError where a section leaves nothing of the piece (a radius
    beyond half the outline's width there)."""

    def layer(section: Polygon, z_mm: float) -> np.ndarray:
        within = piece.intersection(section)
        rings = [
            np.asarray(part.exterior.coords)[:-1]
            for part in getattr(within, "geoms", [within])
            if isinstance(part, Polygon) and not part.is_empty
        ]
        if not rings:
            raise ValueError("a section of the round leaves nothing of a piece")
        ring = np.vstack(rings)
        return np.column_stack([ring, np.full(len(ring), z_mm)])

    layers = [layer(section, z) for section, z in sections]
    layers.append(layer(piece, -thickness_mm))
    return trimesh.convex.convex_hull(np.vstack(layers) * MM)


def open_edge_count(mesh: trimesh.Trimesh) -> int:
    """Edges used by exactly one face (0 for a closed surface)."""
    edges = np.sort(mesh.edges, axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int(np.sum(counts == 1))
