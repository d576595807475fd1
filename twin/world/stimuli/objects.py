"""Stimulus geometry: the paper's six objects and user-supplied ones.

Every stimulus is a flat object described by a 2D outline and a thickness.

**Object frame** (mm in outlines and contour helpers, m in meshes and collision pieces):
origin at the object's *reference point* (the centre of the outline; the spiral's pole
for the spiral), +x right and +y up as seen from above, +z up. The *top surface is at
z = 0* and the solid fills z ∈ [−thickness, 0]. The scene places the object so that its
reference point on the top surface is the work-frame origin (docs/conventions.md:
the work frame is this frame rotated 180° about x, so work +z points into the object).

**Contour following** runs counter-clockwise seen from above (object on the left of the
direction of travel), starting at `Stimulus.start_point_mm`. Closed objects start where
the vertical line through the reference point meets the lowest boundary point; the
spiral is traced from its outer end inwards along the band's outer edge and stops at
`Stimulus.end_point_mm` (`is_open`).

Dimensions are not given in the paper; every number below is an estimate explained in
`assets/stimuli/README.md` (written by `python -m twin.tools.assets`).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import mujoco
import numpy as np
import shapely
import shapely.affinity
import trimesh
from shapely.geometry import LinearRing, LineString, Polygon
from shapely.geometry.polygon import orient

from twin.core.errors import UserError
from twin.core.poses import wrap_deg
from twin.world.stimuli.outlines import (
    MM,
    SAGITTA_MM,
    SpiralParams,
    circle_outline,
    convex_partition,
    extrude_mesh,
    flower_curvature_radii,
    flower_outline,
    open_edge_count,
    rectangle_outline,
    rounded_piece_mesh,
    rounded_sections,
    rounded_top_mesh,
    spiral_outline,
    spiral_start_end,
    tape_measure_outline,
)

MIN_SIZE_MM, MAX_SIZE_MM = 5.0, 500.0  # plausible extent of a user object (mm)


# --------------------------------------------------------------------------- materials


@dataclass(frozen=True)
class Material:
    """A stimulus material and its Coulomb friction coefficient against the TacTip skin."""

    name: str
    friction: float  # sliding friction coefficient μ (dimensionless), object on TacTip skin
    reasoning: str


MATERIALS: dict[str, Material] = {
    "pla": Material(
        "pla",
        0.7,
        "3D-printed PLA (the paper's four printed shapes). Hard thermoplastic on a soft "
        "rubber-like (Agilus/Tango-type) skin: handbook range for hard polymer on soft "
        "elastomer is about 0.5-1.0; the layer lines of an FDM print add some grip, so "
        "0.7 (middle of the 0.6-0.8 band usually quoted for PLA on silicone).",
    ),
    "acrylic": Material(
        "acrylic",
        0.45,
        "Laser-cut cast acrylic (PMMA, the spiral). Smooth, glossy faces and cut edges "
        "slide more easily than printed parts: 0.4-0.5 for PMMA on soft elastomer, 0.45. "
        "The paper notes this is a different material from the training object.",
    ),
    "abs": Material(
        "abs",
        0.5,
        "Tape-measure housing: injection-moulded ABS (often with a thin rubber overmould "
        "on the sides, ignored here). Smooth moulded ABS on elastomer is about 0.4-0.6: 0.5.",
    ),
}


# --------------------------------------------------------------------------- the stimulus


@dataclass(eq=False)
class Stimulus:
    """A flat stimulus object in its object frame (see module docstring).

    `outline` is in mm with the exterior counter-clockwise; `mesh` is the solid in
    metres. `collision` says how `collision_pieces()` is made: "prism" (convex
    partition of the outline, extruded over the thickness, each piece's top edge rounded
    with `edge_radius_mm` where the outline bounds it) or "convex" (the mesh is convex:
    one piece, its vertices).
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
    edge_radius_mm: float = 0.0  # the top edge rounded all round (0: sharp); see `with_edge_radius`
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
        if self.edge_radius_mm:
            return [np.asarray(m.vertices, dtype=float) for m in self._rounded_pieces]
        out = []
        for p in self.convex_outlines:
            k = len(p)
            xyz = np.zeros((2 * k, 3))
            xyz[:k, :2] = xyz[k:, :2] = p
            xyz[k:, 2] = -self.thickness_mm
            out.append(xyz * MM)
        return out

    @cached_property
    def _rounded_sections(self) -> list[tuple[Polygon, float]]:
        """The sections of the top edge rounded by `edge_radius_mm` (`rounded_sections`), once
        for every piece and the mesh."""
        return rounded_sections(self.outline, self.edge_radius_mm)

    @cached_property
    def _rounded_pieces(self) -> list[trimesh.Trimesh]:
        """The convex pieces (m) of the outline's partition, each its solid with the top edge
        rounded by `edge_radius_mm` where the outline bounds it (`rounded_piece_mesh`)."""
        return [rounded_piece_mesh(Polygon(p), self._rounded_sections, self.thickness_mm) for p in self.convex_outlines]

    def add_to_spec(self, spec, body=None, prefix: str | None = None) -> list:
        """Add one mesh asset and one mesh geom per collision piece to a `mujoco.MjSpec`.

        Geoms go into `body` (default: the world body) in the object frame, with sliding
        friction `self.friction`; returns the geoms so the caller can set the rest.
        """

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
        return float(wrap_deg(self.outward_normal_deg([self.start_point_mm])[0] + 90.0))


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


_SCALE_NOTE = (
    "the paper gives no dimensions; the contour plots of Figs 7-8 span roughly "
    "100-150 mm, and the TacTip dome (40 mm) fixes the smallest sensible features"
)
_PRINT_T = (
    "thickness",
    "10 mm",
    "a typical FDM print of a flat stimulus; thicker than any "
    "indentation used (the paper's 2 and 4 mm, at most 6 mm), so the dome apex never "
    "reaches the table beside the object",
)
_FLOWER_R = flower_curvature_radii()

BUILTINS: dict[str, _Builtin] = {
    "rectangle": _Builtin(
        "Rectangle (3D-printed)",
        '"The rectangle has zero curvature and corners." Also the training object: taps '
        "and multi-directional slides on one of its straight edges.",
        rectangle_outline,
        10.0,
        "pla",
        (
            (
                "outline",
                "120 x 80 mm, sharp corners",
                _SCALE_NOTE + "; long straight edges leave "
                "room for the ±9.9 mm lateral training range away from the corners",
            ),
            _PRINT_T,
        ),
    ),
    "large_circle": _Builtin(
        "Large circle (3D-printed)",
        '"The two circles have different constant curvatures."',
        lambda: circle_outline(110.0),
        10.0,
        "pla",
        (
            ("diameter", "110 mm", _SCALE_NOTE + "; clearly larger than the small circle"),
            (
                "sampling",
                f"{len(circle_outline(110.0).exterior.coords) - 1}-gon",
                f"inscribed regular polygon, chord sagitta ≤ {SAGITTA_MM} mm",
            ),
            _PRINT_T,
        ),
    ),
    "small_circle": _Builtin(
        "Small circle (3D-printed)",
        '"The two circles have different constant curvatures."',
        lambda: circle_outline(60.0),
        10.0,
        "pla",
        (
            (
                "diameter",
                "60 mm",
                "about half the large circle; radius 30 mm is still larger than "
                "the 20 mm dome radius, so the curvature stays distinct from a corner",
            ),
            (
                "sampling",
                f"{len(circle_outline(60.0).exterior.coords) - 1}-gon",
                f"inscribed regular polygon, chord sagitta ≤ {SAGITTA_MM} mm",
            ),
            _PRINT_T,
        ),
    ),
    "flower": _Builtin(
        "Five-petal flower (3D-printed)",
        '"The flower-like shape has both negative and positive curvatures."',
        flower_outline,
        10.0,
        "pla",
        (
            (
                "outline",
                "r(φ) = 50 + 8·cos(5(φ − 90°)) mm, one petal tip at +y",
                "a smooth polar curve with 5 petals; " + _SCALE_NOTE,
            ),
            ("span", "Ø 116 mm at the petal tips, Ø 84 mm at the valleys", "r0 ± a"),
            (
                "concave radius",
                f"{_FLOWER_R[0]:.1f} mm (between petals)",
                "negative curvature the paper asks for, about the contact-patch radius of the "
                "dome at 2-4 mm indentation (√(2·20·d) ≈ 9-12 mm), so the valleys are felt but "
                "smooth enough to follow",
            ),
            ("convex radius", f"{_FLOWER_R[1]:.1f} mm (petal tips)", "analytic curvature of r(φ)"),
            ("sampling", "180 vertices (every 2°)", f"chord sagitta < {SAGITTA_MM} mm everywhere"),
            _PRINT_T,
        ),
    ),
    "spiral": _Builtin(
        "Spiral (laser-cut acrylic)",
        '"The spiral shape has negative and positive curvatures, contains corners and has '
        'closely spaced features." Laser-cut acrylic, a different material from the '
        "training set; traced from the outside inwards (Fig. 8b).",
        spiral_outline,
        8.0,
        "acrylic",
        (
            (
                "shape",
                "Archimedean band, 2 turns, winding clockwise outwards",
                "closely spaced turns give the 'closely spaced features'; the band's outer edge is "
                "convex and its inner edge concave; square-cut ends give the corners",
            ),
            (
                "band width",
                "8 mm (radial)",
                "narrow enough that the dome on the band at l = −6 mm "
                "also feels the far edge (closely spaced features)",
            ),
            (
                "gap between turns",
                "20 mm (radial), pitch 28 mm",
                "the dome's contact patch "
                "(radius ≈ 12 mm at 4 mm depth) fits between turns when centred on an edge, but "
                "a lateral error towards +9.9 mm reaches the next turn: the paper's 'upper limit "
                "on the lateral position perception error'",
            ),
            (
                "inner end",
                "centreline radius 22 mm (inner edge 18 mm)",
                "the free centre is wider than the contact patch, so the sensor can reach the inner end",
            ),
            (
                "outer end",
                "centreline radius 78 mm (outer edge 82 mm), at φ = −90°",
                "overall span ≈ 150 mm like the figures",
            ),
            (
                "thickness",
                "8 mm",
                "a stock acrylic sheet thickness; deeper than the 6 mm "
                "the dome ever indents, so the apex never touches the table in the gaps",
            ),
            (
                "sampling",
                f"adaptive, chord sagitta ≤ {SpiralParams().sagitta} mm",
                "about the laser "
                "kerf; keeps the convex partition under 100 pieces (a convex piece of the band "
                "spans at most one segment of its concave inner edge)",
            ),
            (
                "tracing",
                "start on the outer edge 15 mm from the outer end; end at the outer-edge corner of the inner end",
                "the outer edge of the band, wound inwards, "
                "is counter-clockwise with the object on the left like every other object",
            ),
        ),
        open_ends=spiral_start_end,
        frame="origin at the spiral's pole (not the bounding-box centre)",
    ),
    "tape_measure": _Builtin(
        "Tape measure (natural object)",
        '"The tape measure is a natural object and has different curvature values and a corner."',
        tape_measure_outline,
        38.0,
        "abs",
        (
            (
                "outline",
                "70 x 70 mm case lying on its side",
                "a common 5 m tape measure case is about 70-75 mm square and 35-40 mm thick",
            ),
            (
                "corners",
                "R30 top-left and top-right (reel housing), R12 back-bottom, sharp "
                "front-bottom (+x, −y) where the blade exits",
                "'different curvature values and a "
                "corner'; the blade and hook sit below the top 6 mm the dome can reach, so they "
                "are not part of the outline",
            ),
            ("thickness", "38 mm", "case thickness of a 25 mm-blade tape measure"),
            ("shape note", "convex", "so its collision is one piece"),
        ),
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
    return Stimulus(
        name=name,
        outline=outline,
        thickness_mm=spec.thickness_mm,
        material=mat.name,
        friction=mat.friction,
        mesh=extrude_mesh(outline, spec.thickness_mm),
        start_point_mm=start,
        is_open=end is not None,
        end_point_mm=end,
        notes=spec.notes,
    )


# --------------------------------------------------------------------------- user objects


def load_stimulus(
    name_or_spec: str | os.PathLike,
    *,
    thickness_mm: float | None = None,
    material: str | None = None,
    friction: float | None = None,
    stl_units: str = "mm",
    recentre: bool = True,
) -> Stimulus:
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
        raise UserError(f"stimulus {spec}: unknown material {material!r} (known: {', '.join(sorted(MATERIALS))})")
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
        raise UserError(
            f"unknown stimulus {spec!r}: not a built-in ({', '.join(BUILTINS)}) and not an .stl or outline .csv file"
        )
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


def with_edge_radius(stim: Stimulus, radius_mm: float) -> Stimulus:
    """The object with its top edge rounded all round with `radius_mm` (0: as it is): real
    printed and cut edges are not sharp. The object is taken as the prism of its outline
    over its thickness (an STL object's mesh gives way to it, as its collision does where
    the mesh is not convex), convex or not: each piece of the outline's convex partition is
    rounded where the outline bounds it, and the pieces meet along their cuts at every
    height (beside a concave corner within a hull's chord of the true fillet, under 0.1 mm
    at 1.5 mm). Its mesh is the solid itself (`rounded_top_mesh`; the one piece's hull for
    a convex outline). UserError for a radius beyond the thickness or half the outline's
    narrowest width."""
    if radius_mm == 0.0:
        return stim
    too_wide = (
        f"object {stim.name}: edge radius {radius_mm:g} mm: beyond the object's thickness "
        f"({stim.thickness_mm:g} mm) or half its width"
    )
    if radius_mm > stim.thickness_mm:
        raise UserError(too_wide)
    rounded = replace(stim, collision="prism", edge_radius_mm=radius_mm)
    try:  # the pieces stay cached on `rounded`, which takes its mesh in place
        pieces = rounded._rounded_pieces
        rounded.mesh = pieces[0] if len(pieces) == 1 else rounded_top_mesh(rounded._rounded_sections, stim.thickness_mm)
    except ValueError:
        raise UserError(too_wide) from None
    return rounded


def _check_size(path: Path, extent_mm: np.ndarray, what: str) -> None:
    size = float(np.max(extent_mm))
    if not (MIN_SIZE_MM <= size <= MAX_SIZE_MM):
        hint = " (is the file in metres? pass stl_units='m')" if size < MIN_SIZE_MM and what == "mesh" else ""
        raise UserError(
            f"broken {what} {path}: implausible size {size:.4g} mm, expected {MIN_SIZE_MM:g}-{MAX_SIZE_MM:g} mm{hint}"
        )


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
    open_edges = open_edge_count(mesh)
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
    return Stimulus(
        name=path.stem,
        outline=outline,
        thickness_mm=float(zmax - zmin),
        material=material,
        friction=friction,
        mesh=mesh,
        start_point_mm=_default_start(outline),
        collision="convex" if convex else "prism",
        source=str(path),
        source_offset_mm=(float(cx), float(cy), float(dz)),
    )


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
        raise UserError(
            f"broken mesh {path}: the cross-section at mid-height has {len(polys)} "
            "separate regions; a stimulus must be one piece"
        )
    poly = polys[0].simplify(0.02, preserve_topology=True)
    return orient(Polygon(poly.exterior, [i for i in poly.interiors]), 1.0)


_SPLIT = re.compile(r"[,;\s]+")
#: the most vertices an outline may have: 0.1 mm apart along a 1 m contour (the convex
#: decomposition's cost grows fast with them: 200,000 took minutes before failing to compile)
MAX_OUTLINE_VERTICES = 10_000


def read_outline_csv(path: Path) -> tuple[np.ndarray, list[int]]:
    """Vertices (N, 2) mm and their 1-based line numbers from an outline file."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"outline {path}: cannot be read ({type(exc).__name__})") from None
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
            raise UserError(
                f"outline {path} line {lineno}: expected 'x,y' in mm, the line holds something else"
            ) from None
        header_allowed = False
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise UserError(
                f"outline {path} line {lineno}: expected two finite numbers 'x,y' in mm, "
                f"got {len(values)} numbers" + (" not both finite" if len(values) == 2 else "")
            )
        if pts and values == list(pts[-1]):
            continue  # repeated vertex
        pts.append((values[0], values[1]))
        lines.append(lineno)
        if len(pts) > MAX_OUTLINE_VERTICES:
            raise UserError(
                f"outline {path}: more than {MAX_OUTLINE_VERTICES:,} vertices (line {lineno}); "
                "resample it (0.1 mm apart is finer than the dome resolves)"
            )
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts.pop()
        lines.pop()
    if len(pts) < 3:
        raise UserError(f"outline {path}: needs at least 3 vertices, got {len(pts)}")
    return np.array(pts), lines


def _load_outline(path: Path, thickness_mm: float, material: str, friction: float, recentre: bool) -> Stimulus:
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
    return Stimulus(
        name=path.stem,
        outline=poly,
        thickness_mm=thickness_mm,
        material=material,
        friction=friction,
        mesh=extrude_mesh(poly, thickness_mm),
        start_point_mm=_default_start(poly),
        source=str(path),
        source_offset_mm=(float(cx), float(cy), 0.0),
    )


def _crossing(pts: np.ndarray, lines: list[int]) -> str:
    """Describe the first pair of crossing edges by their line numbers."""
    n = len(pts)
    segs = shapely.linestrings([[pts[i], pts[(i + 1) % n]] for i in range(n)])
    left, right = shapely.STRtree(segs).query(segs, predicate="intersects")
    for i, j in sorted(zip(left.tolist(), right.tolist())):
        if j <= i or j == (i + 1) % n or i == (j + 1) % n:
            continue
        return f"edge line {lines[i]}→{lines[(i + 1) % n]} crosses edge line {lines[j]}→{lines[(j + 1) % n]}"
    return shapely.is_valid_reason(Polygon(pts))
