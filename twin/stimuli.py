"""Stimulus geometry: the paper's six objects and user-supplied ones.

Every stimulus is a flat object described by a 2D outline and a thickness.

**Object frame** (mm in outlines and contour helpers, m in meshes and collision pieces):
origin at the object's *reference point* (the centre of the outline; the spiral's pole
for the spiral), +x right and +y up as seen from above, +z up. The *top surface is at
z = 0* and the solid fills z ∈ [−thickness, 0]. The scene places the object so that its
reference point on the top surface is the work-frame origin (README "Conventions":
the work frame is this frame rotated 180° about x, so work +z points into the object).

**Contour following** runs counter-clockwise seen from above (object on the left of the
direction of travel), starting at `Stimulus.start_point_mm`. Closed objects start where
the vertical line through the reference point meets the lowest boundary point; the
spiral is traced from its outer end inwards along the band's outer edge and stops at
`Stimulus.end_point_mm` (`is_open`).

Dimensions are not given in the paper; every number below is an estimate explained in
`assets/stimuli/README.md` (written by `python -m twin.stimuli generate`).
"""
from __future__ import annotations

import argparse
import math
import os
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import mapbox_earcut
import numpy as np
import shapely
import shapely.affinity
import trimesh
from shapely.geometry import LinearRing, LineString, Polygon
from shapely.geometry.polygon import orient

from twin.errors import UserError

MM = 1e-3  # m per mm
SAGITTA_MM = 0.05  # max chord-to-arc deviation when curved outlines are sampled (mm)
MIN_SIZE_MM, MAX_SIZE_MM = 5.0, 500.0  # plausible extent of a user object (mm)
DEFAULT_ASSET_DIR = Path(__file__).resolve().parent.parent / "assets" / "stimuli"
LICENSE_TEXT = (Path(__file__).resolve().parent.parent / "LICENSE").read_text()  # generated assets carry it


# --------------------------------------------------------------------------- materials


@dataclass(frozen=True)
class Material:
    """A stimulus material and its Coulomb friction coefficient against the TacTip skin."""

    name: str
    friction: float  # sliding friction coefficient μ (dimensionless), object on TacTip skin
    reasoning: str


MATERIALS: dict[str, Material] = {
    "pla": Material(
        "pla", 0.7,
        "3D-printed PLA (the paper's four printed shapes). Hard thermoplastic on a soft "
        "rubber-like (Agilus/Tango-type) skin: handbook range for hard polymer on soft "
        "elastomer is about 0.5-1.0; the layer lines of an FDM print add some grip, so "
        "0.7 (middle of the 0.6-0.8 band usually quoted for PLA on silicone).",
    ),
    "acrylic": Material(
        "acrylic", 0.45,
        "Laser-cut cast acrylic (PMMA, the spiral). Smooth, glossy faces and cut edges "
        "slide more easily than printed parts: 0.4-0.5 for PMMA on soft elastomer, 0.45. "
        "The paper notes this is a different material from the training object.",
    ),
    "abs": Material(
        "abs", 0.5,
        "Tape-measure housing: injection-moulded ABS (often with a thin rubber overmould "
        "on the sides, ignored here). Smooth moulded ABS on elastomer is about 0.4-0.6: 0.5.",
    ),
}


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


def flower_outline(r0_mm: float = 50.0, amplitude_mm: float = 8.0, petals: int = 5,
                   samples: int = 180) -> Polygon:
    """Polar flower r(φ) = r0 + a·cos(n(φ − 90°)): `petals` lobes, one petal tip at +y.

    Between the petals the outline is concave; with the defaults the tightest concave
    radius of curvature is 11.2 mm and the petal tips' convex radius 13.0 mm.
    """
    phi = -math.pi / 2 + 2 * math.pi * np.arange(samples) / samples
    r = r0_mm + amplitude_mm * np.cos(petals * (phi - math.pi / 2))
    return _polygon(np.column_stack([r * np.cos(phi), r * np.sin(phi)]))


def flower_curvature_radii(r0_mm: float = 50.0, amplitude_mm: float = 8.0,
                           petals: int = 5) -> tuple[float, float]:
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

    width: float = 8.0         # radial width of the acrylic band
    gap: float = 20.0          # radial clear gap between neighbouring turns
    r_start: float = 22.0      # centreline radius at the inner end
    turns: float = 2.0         # number of turns of the band
    phi_end_deg: float = -90.0  # polar angle of the outer end (start of tracing)
    start_arc: float = 15.0    # tracing starts this far (arc length) from the outer end
    sagitta: float = 0.1       # chord sagitta of the edge sampling (≈ laser kerf); sets the piece count

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


def rounded_rectangle_outline(width_mm: float, height_mm: float,
                              radii_mm: Sequence[float]) -> Polygon:
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
    return [np.asarray(poly.exterior.coords)[:-1]] + [
        np.asarray(r.coords)[:-1] for r in poly.interiors]


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
        key=lambda e: (-float(np.hypot(*(verts[e[0]] - verts[e[1]]))), e))
    next_id = len(pieces)
    for u, v in diagonals:
        a, b = edge_owner.get((u, v)), edge_owner.get((v, u))
        if a is None or b is None or a == b:
            continue
        A, B = pieces[a], pieces[b]
        ia, ib = A.index(u), B.index(v)
        A_rot = A[ia + 1:] + A[:ia + 1]  # starts at v, ends at u
        B_rot = B[ib + 1:] + B[:ib + 1]  # starts at u, ends at v
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


def _open_edge_count(mesh: trimesh.Trimesh) -> int:
    """Edges used by exactly one face (0 for a closed surface)."""
    edges = np.sort(mesh.edges, axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int(np.sum(counts == 1))


# --------------------------------------------------------------------------- the stimulus


@dataclass(eq=False)
class Stimulus:
    """A flat stimulus object in its object frame (see module docstring).

    `outline` is in mm with the exterior counter-clockwise; `mesh` is the solid in
    metres. `collision` says how `collision_pieces()` is made: "prism" (convex
    partition of the outline, extruded over the thickness) or "convex" (the mesh is
    convex: one piece, its vertices).
    """

    name: str
    outline: Polygon
    thickness_mm: float
    material: str
    friction: float
    mesh: trimesh.Trimesh
    start_point_mm: tuple[float, float]
    is_open: bool = False
    end_point_mm: tuple[float, float] | None = None
    collision: str = "prism"
    source: str = "built-in"
    source_offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # object frame → file coordinates (mm)
    notes: tuple[tuple[str, str, str], ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        self.outline = orient(self.outline, 1.0)
        s = self._ring.project(shapely.Point(self.start_point_mm))
        self.start_point_mm = tuple(float(c) for c in self._ring.interpolate(s).coords[0])
        if self.end_point_mm is not None:
            e = self._ring.project(shapely.Point(self.end_point_mm))
            self.end_point_mm = tuple(float(c) for c in self._ring.interpolate(e).coords[0])

    # -- collision ------------------------------------------------------------------
    @cached_property
    def convex_outlines(self) -> list[np.ndarray]:
        """Convex 2D pieces (k, 2) in mm whose union is the outline (prism collision)."""
        if self.collision == "convex":
            return [np.asarray(orient(self.outline, 1.0).exterior.coords)[:-1]]
        return convex_partition(self.outline)

    def collision_pieces(self) -> list[np.ndarray]:
        """Convex vertex arrays (k, 3) in m whose union is the solid, one per MuJoCo mesh."""
        if self.collision == "convex":
            return [np.asarray(self.mesh.convex_hull.vertices, dtype=float)]
        out = []
        for p in self.convex_outlines:
            k = len(p)
            xyz = np.zeros((2 * k, 3))
            xyz[:k, :2] = xyz[k:, :2] = p
            xyz[k:, 2] = -self.thickness_mm
            out.append(xyz * MM)
        return out

    def add_to_spec(self, spec, body=None, prefix: str | None = None) -> list:
        """Add one mesh asset and one mesh geom per collision piece to a `mujoco.MjSpec`.

        Geoms go into `body` (default: the world body) in the object frame, with sliding
        friction `self.friction`; returns the geoms so the caller can set the rest.
        """
        import mujoco

        body = spec.worldbody if body is None else body
        prefix = self.name if prefix is None else prefix
        geoms = []
        for i, verts in enumerate(self.collision_pieces()):
            mesh = spec.add_mesh()
            mesh.name = f"{prefix}_piece{i}"
            mesh.uservert = verts.ravel().tolist()
            geom = body.add_geom()
            geom.name = f"{prefix}_piece{i}"
            geom.type = mujoco.mjtGeom.mjGEOM_MESH
            geom.meshname = mesh.name
            geom.friction[0] = self.friction
            geoms.append(geom)
        return geoms

    # -- contour --------------------------------------------------------------------
    @cached_property
    def _ring(self) -> LinearRing:
        return self.outline.exterior

    @cached_property
    def _solid(self) -> Polygon:
        return Polygon(self.outline.exterior)

    @property
    def perimeter_mm(self) -> float:
        return float(self._ring.length)

    def contour(self, spacing_mm: float = 1.0) -> np.ndarray:
        """(N, 2) points (mm) evenly spaced along the outer boundary, counter-clockwise,
        starting at `start_point_mm`; the last point is not repeated."""
        if spacing_mm <= 0:
            raise ValueError(f"spacing_mm must be > 0, got {spacing_mm}")
        length = self._ring.length
        n = max(3, round(length / spacing_mm))
        s0 = self._ring.project(shapely.Point(self.start_point_mm))
        return self._points_at((s0 + length * np.arange(n) / n) % length)

    def trace_path(self, spacing_mm: float = 1.0) -> np.ndarray:
        """(N, 2) points (mm) of the path contour following should trace, in travel order.

        Closed objects: the same as `contour`. Open (spiral): from `start_point_mm` to
        `end_point_mm` inclusive along the boundary, counter-clockwise.
        """
        if not self.is_open:
            return self.contour(spacing_mm)
        length = self._ring.length
        s0 = self._ring.project(shapely.Point(self.start_point_mm))
        s1 = self._ring.project(shapely.Point(self.end_point_mm))
        if s1 <= s0:
            s1 += length
        n = max(2, round((s1 - s0) / spacing_mm) + 1)
        return self._points_at(np.linspace(s0, s1, n) % length)

    def _points_at(self, s: np.ndarray) -> np.ndarray:
        return shapely.get_coordinates(shapely.line_interpolate_point(self._ring, s))

    def _nearest(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(points (N, 2), nearest boundary points (N, 2), arc positions (N,)) in mm."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ValueError(f"points must be (N, 2) mm, got shape {np.shape(points)}")
        s = shapely.line_locate_point(self._ring, shapely.points(pts))
        return pts, self._points_at(s), np.asarray(s, dtype=float)

    def distance_to_contour(self, points) -> np.ndarray:
        """(N,) unsigned distance (mm) from each point to the outer boundary."""
        pts, near, _ = self._nearest(points)
        return np.hypot(*(pts - near).T)

    def signed_distance_mm(self, points) -> np.ndarray:
        """(N,) distance (mm) to the outer boundary, positive outside the object (like the
        paper's lateral position l: +9.9 off the object, −6 on it)."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        d = self.distance_to_contour(pts)
        inside = shapely.contains_xy(self._solid, pts[:, 0], pts[:, 1])
        return np.where(inside, -d, d)

    def outward_normal_deg(self, points) -> np.ndarray:
        """(N,) angle (deg, atan2 in the object frame, (−180, 180]) of the true outward
        edge normal at the boundary point nearest to each point.

        Off the boundary it is the direction of the signed-distance gradient (at a sharp
        corner it turns continuously); on the boundary, the edge's normal (the mean of
        the two edges' normals at a vertex).
        """
        pts, near, s = self._nearest(points)
        d = pts - near
        dist = np.hypot(*d.T)
        inside = shapely.contains_xy(self._solid, pts[:, 0], pts[:, 1])
        sign = np.where(inside, -1.0, 1.0)
        coords = np.asarray(self._ring.coords)
        seg = np.diff(coords, axis=0)
        seg_len = np.hypot(*seg.T)
        seg_n = np.column_stack([seg[:, 1], -seg[:, 0]]) / seg_len[:, None]  # right of CCW = outward
        cum = np.concatenate([[0.0], np.cumsum(seg_len)])
        i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
        edge_n = seg_n[i].copy()
        at_vertex = np.isclose(s, cum[i], atol=1e-9)
        edge_n[at_vertex] += seg_n[i[at_vertex] - 1]
        on = dist < 1e-6
        n = np.where(on[:, None], edge_n, d * (sign / np.where(on, 1.0, dist))[:, None])
        deg = np.degrees(np.arctan2(n[:, 1], n[:, 0]))
        return np.where(deg <= -180.0, deg + 360.0, deg)

    @property
    def start_direction_deg(self) -> float:
        """Direction of travel at the start (deg, object frame): the CCW edge tangent."""
        return float(_wrap_deg(self.outward_normal_deg([self.start_point_mm])[0] + 90.0))


def _wrap_deg(a: float) -> float:
    """Angle wrapped to (−180, 180] degrees."""
    return 180.0 - (180.0 - a) % 360.0


def _default_start(outline: Polygon) -> tuple[float, float]:
    """Lowest boundary point on the vertical line through the reference point (x = 0)."""
    minx, miny, maxx, maxy = outline.bounds
    cut = shapely.intersection(LineString([(0.0, miny - 1.0), (0.0, maxy + 1.0)]), outline.exterior)
    pts = shapely.get_coordinates(cut)
    if len(pts) == 0:  # reference point outside the x-range: fall back to the lowest vertex
        pts = np.asarray(outline.exterior.coords)
    k = np.lexsort((pts[:, 0], pts[:, 1]))[0]
    return float(pts[k, 0]), float(pts[k, 1])


# --------------------------------------------------------------------------- built-ins


@dataclass(frozen=True)
class _Builtin:
    title: str
    paper: str
    build: Callable[[], Polygon]
    thickness_mm: float
    material: str
    notes: tuple[tuple[str, str, str], ...]  # (quantity, value, why)
    open_ends: Callable[[], tuple[tuple[float, float], tuple[float, float]]] | None = None
    frame: str = "origin at the centre of the outline"


_SCALE_NOTE = ("the paper gives no dimensions; the contour plots of Figs 7-8 span roughly "
               "100-150 mm, and the TacTip dome (40 mm) fixes the smallest sensible features")
_PRINT_T = ("thickness", "10 mm", "a typical FDM print of a flat stimulus; thicker than any "
            "indentation used (the paper's 2 and 4 mm, at most 6 mm), so the dome apex never "
            "reaches the table beside the object")
_FLOWER_R = flower_curvature_radii()

BUILTINS: dict[str, _Builtin] = {
    "rectangle": _Builtin(
        "Rectangle (3D-printed)",
        "\"The rectangle has zero curvature and corners.\" Also the training object: taps "
        "and multi-directional slides on one of its straight edges.",
        rectangle_outline, 10.0, "pla",
        (("outline", "120 x 80 mm, sharp corners", _SCALE_NOTE + "; long straight edges leave "
          "room for the ±9.9 mm lateral training range away from the corners"),
         _PRINT_T),
    ),
    "large_circle": _Builtin(
        "Large circle (3D-printed)",
        "\"The two circles have different constant curvatures.\"",
        lambda: circle_outline(110.0), 10.0, "pla",
        (("diameter", "110 mm", _SCALE_NOTE + "; clearly larger than the small circle"),
         ("sampling", f"{len(circle_outline(110.0).exterior.coords) - 1}-gon",
          f"inscribed regular polygon, chord sagitta ≤ {SAGITTA_MM} mm"),
         _PRINT_T),
    ),
    "small_circle": _Builtin(
        "Small circle (3D-printed)",
        "\"The two circles have different constant curvatures.\"",
        lambda: circle_outline(60.0), 10.0, "pla",
        (("diameter", "60 mm", "about half the large circle; radius 30 mm is still larger than "
          "the 20 mm dome radius, so the curvature stays distinct from a corner"),
         ("sampling", f"{len(circle_outline(60.0).exterior.coords) - 1}-gon",
          f"inscribed regular polygon, chord sagitta ≤ {SAGITTA_MM} mm"),
         _PRINT_T),
    ),
    "flower": _Builtin(
        "Five-petal flower (3D-printed)",
        "\"The flower-like shape has both negative and positive curvatures.\"",
        flower_outline, 10.0, "pla",
        (("outline", "r(φ) = 50 + 8·cos(5(φ − 90°)) mm, one petal tip at +y",
          "a smooth polar curve with 5 petals; " + _SCALE_NOTE),
         ("span", "Ø 116 mm at the petal tips, Ø 84 mm at the valleys", "r0 ± a"),
         ("concave radius", f"{_FLOWER_R[0]:.1f} mm (between petals)",
          "negative curvature the paper asks for, about the contact-patch radius of the "
          "dome at 2-4 mm indentation (√(2·20·d) ≈ 9-12 mm), so the valleys are felt but "
          "smooth enough to follow"),
         ("convex radius", f"{_FLOWER_R[1]:.1f} mm (petal tips)", "analytic curvature of r(φ)"),
         ("sampling", "180 vertices (every 2°)", f"chord sagitta < {SAGITTA_MM} mm everywhere"),
         _PRINT_T),
    ),
    "spiral": _Builtin(
        "Spiral (laser-cut acrylic)",
        "\"The spiral shape has negative and positive curvatures, contains corners and has "
        "closely spaced features.\" Laser-cut acrylic, a different material from the "
        "training set; traced from the outside inwards (Fig. 8b).",
        spiral_outline, 8.0, "acrylic",
        (("shape", "Archimedean band, 2 turns, winding clockwise outwards",
          "closely spaced turns give the 'closely spaced features'; the band's outer edge is "
          "convex and its inner edge concave; square-cut ends give the corners"),
         ("band width", "8 mm (radial)", "narrow enough that the dome on the band at l = −6 mm "
          "also feels the far edge (closely spaced features)"),
         ("gap between turns", "20 mm (radial), pitch 28 mm", "the dome's contact patch "
          "(radius ≈ 12 mm at 4 mm depth) fits between turns when centred on an edge, but "
          "a lateral error towards +9.9 mm reaches the next turn: the paper's 'upper limit "
          "on the lateral position perception error'"),
         ("inner end", "centreline radius 22 mm (inner edge 18 mm)", "the free centre is "
          "wider than the contact patch, so the sensor can reach the inner end"),
         ("outer end", "centreline radius 78 mm (outer edge 82 mm), at φ = −90°",
          "overall span ≈ 150 mm like the figures"),
         ("thickness", "8 mm", "a stock acrylic sheet thickness; deeper than the 6 mm "
          "the dome ever indents, so the apex never touches the table in the gaps"),
         ("sampling", f"adaptive, chord sagitta ≤ {SpiralParams().sagitta} mm", "about the laser "
          "kerf; keeps the convex partition under 100 pieces (a convex piece of the band "
          "spans at most one segment of its concave inner edge)"),
         ("tracing", "start on the outer edge 15 mm from the outer end; end at the "
          "outer-edge corner of the inner end", "the outer edge of the band, wound inwards, "
          "is counter-clockwise with the object on the left like every other object")),
        open_ends=spiral_start_end, frame="origin at the spiral's pole (not the bounding-box centre)",
    ),
    "tape_measure": _Builtin(
        "Tape measure (natural object)",
        "\"The tape measure is a natural object and has different curvature values and a "
        "corner.\"",
        tape_measure_outline, 38.0, "abs",
        (("outline", "70 x 70 mm case lying on its side", "a common 5 m tape measure case is "
          "about 70-75 mm square and 35-40 mm thick"),
         ("corners", "R30 top-left and top-right (reel housing), R12 back-bottom, sharp "
          "front-bottom (+x, −y) where the blade exits", "'different curvature values and a "
          "corner'; the blade and hook sit below the top 6 mm the dome can reach, so they "
          "are not part of the outline"),
         ("thickness", "38 mm", "case thickness of a 25 mm-blade tape measure"),
         ("shape note", "convex", "so its collision is one piece")),
    ),
}


def builtin_stimulus(name: str) -> Stimulus:
    """One of the paper's six objects by name (see BUILTINS)."""
    spec = BUILTINS[name]
    outline = orient(spec.build(), 1.0)
    if spec.open_ends is not None:
        start, end = spec.open_ends()
    else:
        start, end = _default_start(outline), None
    mat = MATERIALS[spec.material]
    return Stimulus(name=name, outline=outline, thickness_mm=spec.thickness_mm,
                    material=mat.name, friction=mat.friction,
                    mesh=extrude_mesh(outline, spec.thickness_mm), start_point_mm=start,
                    is_open=end is not None, end_point_mm=end, notes=spec.notes)


# --------------------------------------------------------------------------- user objects


def load_stimulus(name_or_spec: str | os.PathLike, *, thickness_mm: float | None = None,
                  material: str | None = None, friction: float | None = None,
                  stl_units: str = "mm", recentre: bool = True) -> Stimulus:
    """A built-in object by name, or a user object from a file.

    * built-in names: rectangle, large_circle, small_circle, flower, spiral, tape_measure;
    * `*.stl`: a closed mesh in `stl_units` ("mm" or "m"); its outline is the
      cross-section at mid-height, its thickness the z-extent; collision is the mesh
      itself if it is convex, else the outline extruded over the full height (objects
      are assumed to be flat prisms, like the paper's);
    * `*.csv` / `*.txt`: outline vertices "x,y" in mm, one per line (optional header,
      '#' comments), extruded to `thickness_mm` (required).

    User objects are moved so the outline's bounding-box centre is the origin and the
    top at z = 0 (unless `recentre` is False; `source_offset_mm` records the shift).
    `material` is a MATERIALS key (default: the built-in's own, "pla" for user files);
    `friction` overrides the material's coefficient.
    Raises UserError naming the file and the problem.
    """
    spec = os.fspath(name_or_spec)
    if material is not None and material not in MATERIALS:
        raise UserError(f"stimulus {spec}: unknown material {material!r} "
                        f"(known: {', '.join(sorted(MATERIALS))})")
    if spec in BUILTINS:
        stim = builtin_stimulus(spec)
        if material is not None:
            stim.material, stim.friction = material, MATERIALS[material].friction
        if friction is not None:
            stim.friction = float(friction)
        return stim
    material = "pla" if material is None else material
    path = Path(spec)
    suffix = path.suffix.lower()
    if suffix not in (".stl", ".csv", ".txt"):
        raise UserError(f"unknown stimulus {spec!r}: not a built-in "
                        f"({', '.join(BUILTINS)}) and not an .stl or outline .csv file")
    if not path.is_file():
        raise UserError(f"stimulus file {path} does not exist")
    mu = MATERIALS[material].friction if friction is None else float(friction)
    if not (0.0 <= mu < 10.0):
        raise UserError(f"stimulus {path}: friction {mu} must be in [0, 10)")
    if suffix == ".stl":
        return _load_stl(path, material, mu, stl_units, recentre)
    if thickness_mm is None:
        raise UserError(f"outline {path}: thickness_mm is required to extrude an outline")
    if not (0.0 < float(thickness_mm) <= MAX_SIZE_MM):
        raise UserError(f"outline {path}: thickness_mm {thickness_mm} must be in (0, {MAX_SIZE_MM}]")
    return _load_outline(path, float(thickness_mm), material, mu, recentre)


def _check_size(path: Path, extent_mm: np.ndarray, what: str) -> None:
    size = float(np.max(extent_mm))
    if not (MIN_SIZE_MM <= size <= MAX_SIZE_MM):
        hint = " (is the file in metres? pass stl_units='m')" if size < MIN_SIZE_MM and what == "mesh" else ""
        raise UserError(f"broken {what} {path}: implausible size {size:.4g} mm, expected "
                        f"{MIN_SIZE_MM:g}-{MAX_SIZE_MM:g} mm{hint}")


def _load_stl(path: Path, material: str, friction: float, units: str, recentre: bool) -> Stimulus:
    scale = {"mm": 1.0, "m": 1000.0}.get(units)
    if scale is None:
        raise UserError(f"stimulus {path}: stl_units must be 'mm' or 'm', got {units!r}")
    try:
        mesh = trimesh.load_mesh(path, file_type="stl", process=True)
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise UserError(f"broken mesh {path}: cannot be read as STL ({exc})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise UserError(f"broken mesh {path}: no triangles")
    open_edges = _open_edge_count(mesh)
    if open_edges or not mesh.is_watertight:
        raise UserError(f"broken mesh {path}: not watertight ({open_edges} open edges)")
    if not mesh.is_winding_consistent:
        raise UserError(f"broken mesh {path}: inconsistent face winding")
    mesh.apply_scale(scale)  # now mm
    if abs(mesh.volume) <= 1e-6 * float(np.max(mesh.extents)) ** 3:
        raise UserError(f"broken mesh {path}: zero volume ({mesh.volume:.3g} mm³)")
    if mesh.volume < 0:
        mesh.invert()
    _check_size(path, mesh.extents, "mesh")
    zmin, zmax = mesh.bounds[:, 2]
    zmid = 0.5 * (zmin + zmax)
    outline = _mesh_section(mesh, zmid, path)
    minx, miny, maxx, maxy = outline.bounds
    cx, cy = ((minx + maxx) / 2, (miny + maxy) / 2) if recentre else (0.0, 0.0)
    dz = zmax if recentre else 0.0
    outline = shapely.affinity.translate(outline, -cx, -cy)
    mesh.apply_translation([-cx, -cy, -dz])
    mesh.apply_scale(MM)
    convex = abs(mesh.convex_hull.volume - mesh.volume) <= 1e-3 * mesh.volume
    return Stimulus(name=path.stem, outline=outline, thickness_mm=float(zmax - zmin),
                    material=material, friction=friction, mesh=mesh,
                    start_point_mm=_default_start(outline),
                    collision="convex" if convex else "prism", source=str(path),
                    source_offset_mm=(float(cx), float(cy), float(dz)))


def _mesh_section(mesh: trimesh.Trimesh, z: float, path: Path) -> Polygon:
    """Cross-section of a mesh (mm) at height z as one simplified polygon (mm)."""
    section = mesh.section(plane_origin=[0.0, 0.0, z], plane_normal=[0.0, 0.0, 1.0])
    if section is None:
        raise UserError(f"broken mesh {path}: empty cross-section at mid-height z = {z:.3g} mm")
    to_2d = np.eye(4)
    to_2d[2, 3] = -z
    planar, _ = section.to_2D(to_2D=to_2d)
    polys = [p for p in planar.polygons_full if p is not None and p.area > 0]
    if len(polys) != 1:
        raise UserError(f"broken mesh {path}: the cross-section at mid-height has {len(polys)} "
                        "separate regions; a stimulus must be one piece")
    poly = polys[0].simplify(0.02, preserve_topology=True)
    return orient(Polygon(poly.exterior, [i for i in poly.interiors]), 1.0)


_SPLIT = re.compile(r"[,;\s]+")


def read_outline_csv(path: Path) -> tuple[np.ndarray, list[int]]:
    """Vertices (N, 2) mm and their 1-based line numbers from an outline file."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"outline {path}: cannot be read ({exc})") from None
    pts: list[tuple[float, float]] = []
    lines: list[int] = []
    header_allowed = True
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = [p for p in _SPLIT.split(line) if p]
        try:
            values = [float(p) for p in parts]
        except ValueError:
            if header_allowed:
                header_allowed = False
                continue
            raise UserError(f"outline {path} line {lineno}: expected 'x,y' in mm, "
                            f"got {raw.strip()!r}") from None
        header_allowed = False
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise UserError(f"outline {path} line {lineno}: expected two finite numbers 'x,y' "
                            f"in mm, got {raw.strip()!r}")
        if pts and values == list(pts[-1]):
            continue  # repeated vertex
        pts.append((values[0], values[1]))
        lines.append(lineno)
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts.pop()
        lines.pop()
    if len(pts) < 3:
        raise UserError(f"outline {path}: needs at least 3 vertices, got {len(pts)}")
    return np.array(pts), lines


def _load_outline(path: Path, thickness_mm: float, material: str, friction: float,
                  recentre: bool) -> Stimulus:
    pts, lines = read_outline_csv(path)
    poly = Polygon(pts)
    if np.linalg.matrix_rank(pts - pts.mean(axis=0), tol=1e-9) < 2:
        raise UserError(f"outline {path}: zero area (the vertices are collinear)")
    if not poly.is_valid:
        raise UserError(f"outline {path}: not a simple polygon ({_crossing(pts, lines)})")
    _check_size(path, np.ptp(pts, axis=0), "outline")
    minx, miny, maxx, maxy = poly.bounds
    cx, cy = ((minx + maxx) / 2, (miny + maxy) / 2) if recentre else (0.0, 0.0)
    poly = orient(shapely.affinity.translate(poly, -cx, -cy), 1.0)
    return Stimulus(name=path.stem, outline=poly, thickness_mm=thickness_mm,
                    material=material, friction=friction,
                    mesh=extrude_mesh(poly, thickness_mm), start_point_mm=_default_start(poly),
                    source=str(path), source_offset_mm=(float(cx), float(cy), 0.0))


def _crossing(pts: np.ndarray, lines: list[int]) -> str:
    """Describe the first pair of crossing edges by their line numbers."""
    n = len(pts)
    segs = shapely.linestrings([[pts[i], pts[(i + 1) % n]] for i in range(n)])
    left, right = shapely.STRtree(segs).query(segs, predicate="intersects")
    for i, j in sorted(zip(left.tolist(), right.tolist())):
        if j <= i or j == (i + 1) % n or i == (j + 1) % n:
            continue
        return (f"edge line {lines[i]}→{lines[(i + 1) % n]} crosses edge line "
                f"{lines[j]}→{lines[(j + 1) % n]}")
    return shapely.is_valid_reason(Polygon(pts))


# --------------------------------------------------------------------------- asset generation


def _stl_bytes(mesh_m: trimesh.Trimesh, header: str) -> bytes:
    """Binary STL in mm with an 80-byte ASCII header."""
    head = header.encode("ascii")
    if len(head) > 80:
        raise ValueError(f"STL header longer than 80 bytes: {header!r}")
    tri = (np.asarray(mesh_m.vertices)[mesh_m.faces] / MM).astype(np.float32)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]).astype(np.float64)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    rec = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["n"], rec["v"] = normals, tri
    return head.ljust(80, b" ") + np.uint32(len(tri)).tobytes() + rec.tobytes()


def _fmt(v: float) -> str:
    s = f"{v:.6f}"
    return "0.000000" if s == "-0.000000" else s


def _object_readme(stim: Stimulus, spec: _Builtin) -> str:
    mat = MATERIALS[stim.material]
    minx, miny, maxx, maxy = stim.outline.bounds
    rows = "\n".join(f"| {q} | {v} | {why} |" for q, v, why in spec.notes)
    end = (f"* Tracing stops at the end point ({_fmt(stim.end_point_mm[0])}, "
           f"{_fmt(stim.end_point_mm[1])}) mm (open path).\n" if stim.is_open else
           "* Closed contour: tracing ends after one full loop.\n")
    return f"""# {spec.title}

Generated by `python -m twin.stimuli generate`; do not edit by hand (edit
`twin/stimuli.py` and regenerate). MIT licensed, see `../LICENSE`.

Paper: {spec.paper}

## Frame and files

* Object frame: {spec.frame}; +x right, +y up seen from above, top surface at z = 0,
  solid over z ∈ [−{stim.thickness_mm:g}, 0] mm.
* `{stim.name}.stl`: binary STL in **millimetres** ({len(stim.mesh.faces)} triangles,
  watertight). In MJCF use `scale="0.001 0.001 0.001"`.
* `outline.csv`: the outline's {len(stim.outline.exterior.coords) - 1} vertices (x, y in mm),
  counter-clockwise, not closed.
* Bounding box: x {_fmt(minx)} … {_fmt(maxx)} mm, y {_fmt(miny)} … {_fmt(maxy)} mm;
  area {stim.outline.area:.1f} mm², perimeter {stim.perimeter_mm:.1f} mm.
* Collision: {len(stim.collision_pieces())} convex prism piece(s) (`Stimulus.collision_pieces()`;
  MuJoCo collides each mesh through its convex hull).

## Dimensions

Estimated: the paper gives none. Each value and why:

| quantity | value | reasoning |
|---|---|---|
{rows}

## Material

{mat.name}, Coulomb friction μ = {mat.friction:g} against the TacTip skin. {mat.reasoning}

## Contour following

* Start point ({_fmt(stim.start_point_mm[0])}, {_fmt(stim.start_point_mm[1])}) mm on the edge,
  travelling counter-clockwise (object on the left), initial direction
  {stim.start_direction_deg:.1f}° in the object frame.
{end}"""


def _index_readme(stims: list[Stimulus]) -> str:
    rows = []
    for s in stims:
        minx, miny, maxx, maxy = s.outline.bounds
        rows.append(f"| [{s.name}]({s.name}/README.md) | {maxx - minx:.1f} x {maxy - miny:.1f} | "
                    f"{s.thickness_mm:g} | {s.material} | {s.friction:g} | "
                    f"{len(s.collision_pieces())} | {'open' if s.is_open else 'closed'} |")
    mats = "\n".join(f"* **{m.name}**, μ = {m.friction:g}: {m.reasoning}" for m in MATERIALS.values())
    return f"""# Stimuli

The six objects of Aquilina, Barton & Lepora (ICRA 2019) §IV-C: four 3D-printed shapes
(rectangle, large and small circle, five-petal flower), a natural object (tape measure)
and a laser-cut acrylic spiral. Generated from documented 2D outlines by
`python -m twin.stimuli generate` (deterministic: the same bytes every run; a test
checks these files equal a fresh generation). MIT licensed, see `LICENSE`.

**The paper gives no dimensions.** Every number is an estimate: the contour plots of
Figs 7-8 span roughly 100-150 mm, the dome is 40 mm across (contact-patch radius
≈ √(2·20·d) ≈ 9-12 mm at the paper's 2-4 mm indentations), and the paper's words fix
the qualitative features (corners, constant curvatures, negative curvature, closely
spaced features). Each object's README gives the value and the reasoning for every
dimension.

## Conventions

* Object frame: origin at the reference point (centre of the outline; the spiral's
  pole), +x right, +y up seen from above, +z up, top surface at z = 0, solid below.
  The scene puts the reference point on the top surface at the work-frame origin.
* STL files are in **mm** (user STL files are assumed to be in mm too); the Python
  meshes (`Stimulus.mesh`, `collision_pieces()`) are in m; outlines in mm.
* Curved edges are polygons with chord sagitta ≤ {SAGITTA_MM} mm ({SpiralParams().sagitta} mm
  for the spiral, to bound its convex piece count).
* Contour following is counter-clockwise (object on the left), from each object's
  start point; the spiral is open: from its outer end inwards to its inner end.
* Collision: MuJoCo collides a mesh through its convex hull, so non-convex outlines
  are split into convex prisms (earcut + Hertel–Mehlhorn).

| object | size x × y (mm) | thickness (mm) | material | μ | convex pieces | contour |
|---|---|---|---|---|---|---|
{chr(10).join(rows)}

## Materials and friction

Friction is the Coulomb coefficient between the object and the TacTip's rubber-like
skin; no measured values exist for this rig, so these are estimates from typical ranges:

{mats}

## User objects

`twin.stimuli.load_stimulus(path)` also takes a closed STL (mm) or an outline CSV
(`x,y` mm per line, extruded to a given thickness); both are validated and re-centred
on their bounding-box centre with the top at z = 0.
"""


def generate_assets(out_dir: Path = DEFAULT_ASSET_DIR) -> list[Path]:
    """Write every built-in's STL, outline.csv and README, plus README.md and LICENSE."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    def write(path: Path, data: bytes | str) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
        written.append(path)

    stims = [builtin_stimulus(n) for n in BUILTINS]
    for stim in stims:
        d = out_dir / stim.name
        header = f"tactip-twin stimulus {stim.name}; units mm; MIT License, see LICENSE"
        write(d / f"{stim.name}.stl", _stl_bytes(stim.mesh, header))
        csv = "x_mm,y_mm\n" + "".join(f"{_fmt(x)},{_fmt(y)}\n"
                                      for x, y in np.asarray(stim.outline.exterior.coords)[:-1])
        write(d / "outline.csv", csv)
        write(d / "README.md", _object_readme(stim, BUILTINS[stim.name]))
    write(out_dir / "README.md", _index_readme(stims))
    write(out_dir / "LICENSE", LICENSE_TEXT)
    return written


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m twin.stimuli", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    gen = sub.add_parser("generate", help="write the built-in stimulus assets")
    gen.add_argument("--out", type=Path, default=DEFAULT_ASSET_DIR, help="output folder")
    args = parser.parse_args(argv)
    for path in generate_assets(args.out):
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
