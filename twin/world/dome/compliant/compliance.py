"""The compliant dome's elasticity: surface nodes on the dome's cap and the influence
(compliance) matrix that maps nodal contact forces to the displacements of the surface
nodes and of the pin tips.

Model: the skin + gel under the contact is a linear elastic solid whose response to a
point force on its surface is that of an elastic half-space tangent to the dome at the
force's node — the Boussinesq (normal) and Cerruti (tangential) solutions (K. L. Johnson,
*Contact Mechanics*, 1985, eqs. 3.20–3.21), including their subsurface form, which gives
the gel's displacement at a pin's base (the pins: `pin_tip_kernel`). This is how Kalker's CONTACT describes
elastic bodies; it is exact for Hertz and Cattaneo–Mindlin (the verification tests) and
costs no finite-element precomputation: every matrix entry is closed form.

Discretisation: N nodes on the cap, each carrying the traction on its own area A,
spread uniformly over a disc of that area (radius a = √(A/π)) in its tangent plane: the
influence on another point is the disc-averaged point solution (Radon's 7-point rule on
the disc, exact for cubics; a point load alone underestimates the nearest neighbours'
compliance — the 1/r kernel is convex — and made a Hertz press 3 % too stiff). The
singular self term is the displacement at the disc's centre under the uniform traction
(normal: (1 − ν) F / (π a G); tangential: (2 − ν) F / (2 π a G)). The kernel is evaluated
point by point in compiled code (`_disc_kernel`): the one-off matrices of a cap and its
skin are 10⁷ rule points, which numpy's (Nt, Ns, 3) temporaries made ten times slower.

The sealed dome (`enclosed`): the real gel fills a closed volume — the skin over a rigid
base — so what a contact pushes in must come out elsewhere. A half-space has no such
bound: its surface sinks in around a press (the contact radius is Hertz's √(Rδ), half
the geometric overlap's area) and the displaced volume is lost to infinity; on the
TacTip an edge 6 mm from the centre then never enters a 2–4 mm press. The enclosed
model adds the gel's pressure change p as a Lagrange multiplier: p acts on every cap
node (force p·A·n) and is set by the gel's volume balance, the skin's volume change
equal to the gel's compression: Aᵀu = −p V / K (V the gel's volume, K its bulk modulus;
K = ∞ at ν = 0.5, where the volume is conserved exactly). With h = C A (the nodes'
displacement per Pa), the constrained compliance is C − h hᵀ / (Aᵀh + V/K): symmetric,
positive semi-definite, a rank-one update of the half-space's. (C is symmetric to
0.06 % here — Maxwell–Betti, broken only by the per-node tangent half-spaces — so
h is averaged with Cᵀ A.) The pressure acts on the free skin down to the dome's equator,
where the base clamps it: on the cap, which can take contact, and on a band of nodes
beyond it (`CapSurface.band_to`), which only moves the cap and the pins through h and the
volume balance, so it costs nothing per contact. (Sealing the cap alone made the pins
depend on where the cap ends: 0.8–1.7 px RMS between a 65° and a 75° cap on a press and
slide across an edge, against 0.002 px with the band.)

The skin as a membrane (`membrane_young` > 0, off by default): the real skin is a
rubber shell far stiffer than the gel, which stretches rather than shears. It is added as
constant-strain membrane triangles through the nodes of the whole free skin, the cap's and
the band's, to the equator where the base holds it (`CapSurface.skin_to`,
`membrane_stiffness`; on a sphere it obeys Laplace's law, p = 2 E t w / ((1 − ν) R²),
tested), in series with the gel under all of it: the contact force f is shared between
the skin's stiffness K and the gel's compliance C, u = (I + C K)⁻¹ C f, and the pins
follow the gel under the force the skin passes on to it (`skinned`; computed once per
material and cached). Contact acts on the cap alone. (Ending the skin at the cap's rim,
held there by springs, made the pins depend on where the cap ends: 1.5–2.8 px RMS between
a 65° and a 75° cap on a press and slide across an edge, against 0.001 px now.) The skin
couples normal and tangential motion (stretching a curved membrane moves it normally),
which twin.world.dome.compliant.contact solves jointly. With `skin_bending` the skin is a thin
shell: its bending stiffness (`bending_stiffness`, D = E t³ / 12(1 − ν²), the same E and
t, or a bending modulus of its own: `bending_young`) is added to the membrane's. With `skin_tension` T (N/m) the skin is stretched over the
gel before any contact, the gel's pressure 2T/R (Laplace) holding it: a normal
displacement w then costs ½ T ∫ (|∇w|² − 2w²/R²) dA (`tension_stiffness`; the spherical
harmonic of degree l costs T (l(l+1) − 2)/R² per unit area, rigid translations nothing,
tested). With `skin_thickening` k the skin thickens from the geometry's thickness at the
apex to k times it where the base holds it, linearly in the polar angle (`skin_thickness`):
its membrane stiffness follows t and its bending t³ node by node (Laplace's law then holds
with the local t, and the varying stress resultant adds its meridional gradient, tested);
the pins stay where they are. The pins are levers on the skin (`post_tips`): the
geometry's pin length is the lever its turn swings the tip by, which
`DomeCompliance(pin_lever=…)` replaces; or, with `pins_in_gel`, their tips move with the
gel that far below the skin (`pin_tips_in_gel`).

The tip's sway (`tip_sway`, m/N, off by default): the half-space and the skin held at
its base move the cap and the pins most near the forces and less with distance, while a
real tip also moves as a whole against the camera under the net tangential force — its
base, the skin's skirt down to the mount and the gel's body yielding sideways. The sway is that compliance in
series with the rest: under nodal forces f every cap node and pin tip moves by
s (Σf_x, Σf_y, 0) besides C f (`sway_block`, `sway_shift`; tool x, y across the tip's
axis). It adds a rank-two term to the compliance, symmetric and positive semi-definite,
and leaves the cached matrices as they are: `local_block`, `surface_displacement` and
`pin_displacement` add it for the sway they are given. The rigid shift itself turns no orientation
read from the pins' shape (twin.analysis.edge_imprint.TapPCs); the sway turns θ_PC23 only
through where the moved tip meets the object, so it adds more drag per turn than
friction does (docs/dome/compliant.md).

Everything in the tool frame (m): apex at the origin, +z out of the tip.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np
from scipy import sparse
from scipy.spatial import Delaunay

from twin.core.resources import cached_arrays, code_digest
from twin.core.sensor import TacTipGeometry
from twin.world.dome.compiled import compiled

GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))  # rad
#: Radon's 7-point rule on the unit disc: (x, y, weight), exact for polynomials of degree 3
DISC_RULE = np.array(
    [[0.0, 0.0, 0.25]]
    + [
        [math.sqrt(2 / 3) * math.cos(k * math.pi / 3), math.sqrt(2 / 3) * math.sin(k * math.pi / 3), 0.125]
        for k in range(6)
    ]
)


@dataclass(frozen=True)
class CapSurface:
    """Nodes on the dome's outer surface within `extent_deg` of the apex, spaced about
    `spacing` (m) apart: an equal-area Fibonacci lattice (each node carries the same area).

    points (N, 3) m, normals (N, 3) outward unit, tangents (N, 2, 3) unit (meridian
    direction away from the apex, then azimuthal), area (m²) per node, polar and
    azimuth (N,) rad. `pins_in_gel`: the pin tips move with the gel at their own depth
    (`pin_tips_in_gel`) instead of as posts turning with the skin (`post_tips`); the
    surface carries it, as its geometry carries the pins' lever, so the cached matrices
    are keyed by it.
    """

    geometry: TacTipGeometry
    spacing: float
    extent_deg: float
    pins_in_gel: bool = False

    @cached_property
    def count(self) -> int:
        cap_area = 2 * math.pi * self.geometry.dome_outer_radius**2 * (1 - math.cos(math.radians(self.extent_deg)))
        return max(7, int(round(cap_area / (math.sqrt(3) / 2 * self.spacing**2))))

    @cached_property
    def area(self) -> float:
        r = self.geometry.dome_outer_radius
        return 2 * math.pi * r * r * (1 - math.cos(math.radians(self.extent_deg))) / self.count

    @cached_property
    def polar(self) -> np.ndarray:
        k = np.arange(self.count) + 0.5
        return np.arccos(1.0 - (1.0 - math.cos(math.radians(self.extent_deg))) * k / self.count)

    @cached_property
    def azimuth(self) -> np.ndarray:
        """(N,) rad: the lattice's golden-angle azimuths."""
        return np.arange(self.count) * GOLDEN_ANGLE

    @cached_property
    def normals(self) -> np.ndarray:
        return self.frames[:, 0]

    @cached_property
    def points(self) -> np.ndarray:
        return self._on_dome(self.normals)

    @cached_property
    def tangents(self) -> np.ndarray:
        return self.frames[:, 1:]

    @cached_property
    def frames(self) -> np.ndarray:
        """(N, 3, 3): rows (outward normal, meridian tangent, azimuthal tangent) per node."""
        return _sphere_frames(self.polar, self.azimuth)

    def band_to(self, held_deg: float) -> tuple[np.ndarray, np.ndarray]:
        """The free skin beyond the cap, down to `held_deg` from the apex where the base
        holds it (the equator: 90): points (M, 3) and frames (M, 3, 3) of an equal-area
        lattice whose nodes carry the cap's node `area` (none where the base holds the skin
        at the cap's rim). It takes the sealed gel's pressure but never contact."""
        top = math.cos(math.radians(self.extent_deg))
        bottom = math.sin(math.radians(90.0 - held_deg))  # cos(held), exactly 0 at the equator
        count = int(round(2 * math.pi * self.geometry.dome_outer_radius**2 * (top - bottom) / self.area))
        k = np.arange(count) + 0.5
        frames = _sphere_frames(
            np.arccos(bottom + (top - bottom) * (1.0 - k / count)), (self.count + np.arange(count)) * GOLDEN_ANGLE
        )
        return self._on_dome(frames[:, 0]), frames

    def skin_to(self, held_deg: float) -> SkinSheet:
        """The skin from the apex to `held_deg`, where the base holds it: the cap's nodes,
        then the band's (`band_to`)."""
        band_points, band_frames = self.band_to(held_deg)
        points = np.concatenate([self.points, band_points])
        frames = np.concatenate([self.frames, band_frames])
        polar = np.arccos(np.clip(frames[:, 0, 2], -1.0, 1.0))
        triangles = Delaunay(azimuthal_map(frames[:, 0])).simplices
        held = polar > math.radians(held_deg) - self.spacing / self.geometry.dome_outer_radius
        return SkinSheet(
            points, frames, triangles, held, self.geometry.dome_outer_radius, self.spacing, math.radians(held_deg)
        )

    @property
    def triangulation(self) -> Delaunay:
        """The nodes' Delaunay triangulation in the azimuthal equidistant map about the apex
        (one per lattice in a process: `_triangulated`)."""
        return _triangulated(self)[0]

    def interpolation(self, directions: np.ndarray, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The lattice's linear interpolation at the points of the dome in these unit
        directions (k, 3) from its sphere centre, each near its node of `nodes` (k,) (within
        its disc: it is looked for among that node's triangles first): (k, 3) node indices
        and (k, 3) weights, the corners of the map's triangle each point lies in and its
        barycentric coordinates (beyond the cap: the nearest node alone)."""
        where = azimuthal_map(directions)
        tri, indptr, fans = _triangulated(self)
        simplex, weights = _in_fan(tri.transform, indptr, fans, np.asarray(nodes, np.int64), where)
        elsewhere = np.flatnonzero(simplex < 0)
        if len(elsewhere):
            simplex[elsewhere] = tri.find_simplex(where[elsewhere])
            inside = elsewhere[simplex[elsewhere] >= 0]
            transform = tri.transform[simplex[inside]]
            barycentric = np.einsum("kij,kj->ki", transform[:, :2], where[inside] - transform[:, 2])
            weights[inside] = np.column_stack([barycentric, 1.0 - barycentric.sum(axis=1)])
        corners = tri.simplices[np.maximum(simplex, 0)]
        outside = np.flatnonzero(simplex < 0)
        if len(outside):
            corners[outside] = 0
            corners[outside, 0] = np.argmax(directions[outside] @ self.normals.T, axis=1)
            weights[outside] = [1.0, 0.0, 0.0]
        return corners, weights

    def _on_dome(self, normals: np.ndarray) -> np.ndarray:
        g = self.geometry
        return np.array([0.0, 0.0, g.sphere_centre_z]) + g.dome_outer_radius * normals

    @cached_property
    def rim(self) -> np.ndarray:
        """(N,) bool: nodes in the outermost spacing of the cap (contact there leaves the model)."""
        return self.polar > math.radians(self.extent_deg) - self.spacing / self.geometry.dome_outer_radius


@dataclass(frozen=True, eq=False)
class SkinSheet:
    """The skin as a sheet of nodes over the gel, from the apex to where the base holds
    it (`CapSurface.skin_to`): points (K, 3) m, frames (K, 3, 3) (outward normal,
    meridian, azimuthal), triangles (T, 3) node indices (the Delaunay triangulation of
    the nodes' azimuthal-equidistant map), held (K,) bool: the last ring, within a spacing
    of where the base holds the skin, `held_at` (rad from the apex; the equator: π/2);
    radius R and node spacing (m)."""

    points: np.ndarray
    frames: np.ndarray
    triangles: np.ndarray
    held: np.ndarray
    radius: float
    spacing: float
    held_at: float

    @property
    def normals(self) -> np.ndarray:
        return self.frames[:, 0]

    @property
    def polar(self) -> np.ndarray:
        """(K,) rad from the apex."""
        return np.arccos(np.clip(self.normals[:, 2], -1.0, 1.0))


def disc_averaged_kernel(
    targets: np.ndarray, sources: np.ndarray, frames: np.ndarray, radius: float, poisson: float, shear_modulus: float
) -> np.ndarray:
    """(Nt, 3, Ns, 3) m/N: displacement of each target point per unit force at each source
    ([target, displacement axis, source, force axis]), the force spread uniformly over a
    disc of `radius` (m) about the source in its tangent plane (frames (Ns, 3, 3): outward
    normal, t1, t2), by DISC_RULE; radius 0: a point force.

    Each source is a force on the surface of the half-space tangent to the dome there;
    targets on or below that surface (depth z = −normal·(target − source) ≥ 0).
    Boussinesq + Cerruti (Johnson eqs. 3.20, 3.21) written for an arbitrary force
    direction. A target on a rule point is NaN (the self term is singular: the caller's to
    set).
    """
    return _disc_kernel(
        np.ascontiguousarray(targets, dtype=float),
        np.ascontiguousarray(sources, dtype=float),
        np.ascontiguousarray(frames, dtype=float),
        float(radius),
        DISC_RULE,
        float(poisson),
        float(shear_modulus),
    )


@compiled
def _disc_kernel(
    targets: np.ndarray,
    sources: np.ndarray,
    frames: np.ndarray,
    radius: float,
    rule: np.ndarray,
    poisson: float,
    shear_modulus: float,
) -> np.ndarray:
    """`disc_averaged_kernel` by `rule` (rows x, y, weight on the unit disc), point by point:
    no (Nt, Ns, 3) temporaries (the one-off matrices of a 1.5 mm cap are 10⁷ such points)."""
    nt, ns = len(targets), len(sources)
    out = np.zeros((nt, 3, ns, 3))
    c = 1.0 - 2.0 * poisson
    scale = 1.0 / (4.0 * math.pi * shear_modulus)
    point = np.empty(3)
    r = np.empty(3)
    e = np.empty(3)
    tangential = np.empty(3)
    for j in range(ns):
        for a in range(3):
            e[a] = -frames[j, 0, a]  # into the solid
        for q in range(len(rule)):
            weight = rule[q, 2] * scale
            for a in range(3):
                point[a] = sources[j, a] + radius * (rule[q, 0] * frames[j, 1, a] + rule[q, 1] * frames[j, 2, a])
            for t in range(nt):
                for a in range(3):
                    r[a] = targets[t, a] - point[a]
                z = max(r[0] * e[0] + r[1] * e[1] + r[2] * e[2], 0.0)
                rho = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
                if rho == 0.0:
                    for a in range(3):
                        for b in range(3):
                            out[t, a, j, b] = math.nan
                    continue
                for a in range(3):
                    tangential[a] = r[a] - z * e[a]
                normal_of_tangential = tangential[0] * e[0] + tangential[1] * e[1] + tangential[2] * e[2]
                rz = rho + z
                inv_rho = 1.0 / rho
                inv_rho3 = inv_rho * inv_rho * inv_rho
                for b in range(3):  # the unit force along axis b
                    fe = e[b]  # its normal part (along e)
                    ts = tangential[b] - fe * normal_of_tangential  # its tangential part · tangential
                    along_s = ts * inv_rho3 - c * ts / (rho * rz * rz) + fe * (z * inv_rho3 - c / (rho * rz))
                    along_e = (
                        ts * z * inv_rho3
                        + c * ts / (rho * rz)
                        + fe * (z * z * inv_rho3 + 2.0 * (1.0 - poisson) * inv_rho)
                    )
                    for a in range(3):
                        ft = (1.0 if a == b else 0.0) - fe * e[a]  # its tangential part
                        out[t, a, j, b] += weight * (ft * (inv_rho + c / rz) + along_s * tangential[a] + along_e * e[a])
    return out


def self_compliance(outward: np.ndarray, area: float, poisson: float, shear_modulus: float) -> np.ndarray:
    """(N, 3, 3) m/N: a node's displacement per unit force on its own area (uniform
    traction on a disc of that area, displacement at its centre)."""
    a = math.sqrt(area / math.pi)
    normal = (1.0 - poisson) / (math.pi * a * shear_modulus)
    tangential = (2.0 - poisson) / (2.0 * math.pi * a * shear_modulus)
    nn = np.einsum("ni,nj->nij", outward, outward)
    return tangential * (np.eye(3)[None] - nn) + normal * nn


def pin_tip_kernel(
    surface: CapSurface,
    sources: np.ndarray,
    frames: np.ndarray,
    radius: float,
    poisson: float,
    shear_modulus: float,
    step: float | None = None,
) -> np.ndarray:
    """(127, 3, Ns, 3) m/N: displacement of each pin tip per unit force at each source, on
    the half-space gel (`disc_averaged_kernel`), by the surface's pin model: posts turning
    with the skin (`post_tips`), or tips moving with the gel (`pins_in_gel`:
    `pin_tips_in_gel`), the lever being its geometry's pin length."""

    def gel_at(points: np.ndarray) -> np.ndarray:
        return disc_averaged_kernel(points, sources, frames, radius, poisson, shear_modulus)

    if surface.pins_in_gel:
        return pin_tips_in_gel(surface.geometry, gel_at)
    return post_tips(surface.geometry, gel_at, step)


def _pin_bases(geometry: TacTipGeometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(127, 3) where the pins leave the skin's inner surface, (127, 3) its outward unit
    normals there and (3,) the sphere's centre (m, tool frame)."""
    bases = geometry.pin_base_points()
    centre = np.array([0.0, 0.0, geometry.sphere_centre_z])
    return bases, (bases - centre) / geometry.skin_inner_radius, centre


def pin_tips_in_gel(geometry: TacTipGeometry, gel_at: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """(127, 3, Ns, 3) m/N: displacement of each pin tip per unit force at each of Ns
    sources, the tips moving with the gel around them (`gel_at(points)`: (P, 3, Ns, 3)
    m/N) at the geometry's pin length (the lever) below the skin's inner surface, along
    its inward normal. The gel is continuous, so two tips cannot pass each other as two
    posts turning apart can: a post's tip swings by its length times the skin's turn, and
    where the skin's slope changes sign, at a contact's border, neighbouring tips swing
    towards each other."""
    bases, normals, _ = _pin_bases(geometry)
    return gel_at(bases - geometry.pin_length * normals)


def post_tips(
    geometry: TacTipGeometry, gel_at: Callable[[np.ndarray], np.ndarray], step: float | None = None
) -> np.ndarray:
    """(127, 3, Ns, 3) m/N: displacement of each pin tip per unit force at each of Ns
    sources, given the gel's displacement at any points (`gel_at(points)`: (P, 3, Ns, 3)
    m/N).

    A pin is a rigid post of length L (the geometry's pin_length: the lever, which
    `DomeCompliance(pin_lever=…)` sets) standing on the skin's inner surface along the
    inward normal. Its base moves with the gel there (u_b), and it turns with the skin:
    the skin's outward normal turns by u_t/R − ∇u_n (a tangential displacement on the
    sphere of radius R, and the slope of the normal displacement), so the post's axis
    (−n) turns the other way and its tip moves by u_b + L (∇u_n − u_t/R). This is what
    flattening does to the real pins: under a flat press ∇u_n = r/R inside the contact,
    so a pin's tip swings outwards by L r/R. ∇u_n is a central difference over ±`step`
    (m; default the skin's thickness) along the base's tangents, at the base's depth: the
    skin is stiffer than the gel and does not bend over shorter lengths (a 1 mm step made
    the pins beside a straight edge 1.6 px apart between 1.5 and 0.75 mm node spacings,
    1.5 mm 1.2 px; RMS over all pins 0.24 and 0.21 px).
    """
    step = geometry.skin_thickness if step is None else step
    bases, normals, centre = _pin_bases(geometry)
    helper = np.where(np.abs(normals[:, 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    t1 = _unit(np.cross(helper, normals))
    t2 = np.cross(normals, t1)
    base = gel_at(bases)
    tip = base.copy()
    for tangent in (t1, t2):
        plus = centre + geometry.skin_inner_radius * _unit(bases + step * tangent - centre)
        minus = centre + geometry.skin_inner_radius * _unit(bases - step * tangent - centre)
        slope = np.einsum("pi,piqj->pqj", normals, gel_at(plus) - gel_at(minus)) / (2 * step)  # ∂u_n/∂t per force
        tip += geometry.pin_length * tangent[:, :, None, None] * slope[:, None, :, :]
    normal_part = np.einsum("pi,piqj->pqj", normals, base)
    tangential = base - normals[:, :, None, None] * normal_part[:, None, :, :]
    tip -= geometry.pin_length / geometry.dome_outer_radius * tangential
    return tip


def azimuthal_map(directions: np.ndarray) -> np.ndarray:
    """(N, 2) rad: unit directions (N, 3) from the dome's sphere centre in the azimuthal
    equidistant map about the apex (polar angle along the azimuth), where the cap's lattice
    is triangulated."""
    polar = np.arccos(np.clip(directions[:, 2], -1.0, 1.0))
    azimuth = np.arctan2(directions[:, 1], directions[:, 0])
    return np.column_stack([polar * np.cos(azimuth), polar * np.sin(azimuth)])


@lru_cache(maxsize=8)
def _triangulated(surface: CapSurface) -> tuple[Delaunay, np.ndarray, np.ndarray]:
    """The lattice's triangulation in the azimuthal map (`CapSurface.triangulation`) and each
    node's triangles in it, as a CSR pattern: (indptr (N + 1,), triangle indices)."""
    tri = Delaunay(azimuthal_map(surface.normals))
    owner = tri.simplices.ravel()
    order = np.argsort(owner, kind="stable")
    triangles = np.repeat(np.arange(len(tri.simplices)), 3)[order]
    return tri, np.searchsorted(owner[order], np.arange(surface.count + 1)), triangles


@compiled
def _in_fan(
    transform: np.ndarray, indptr: np.ndarray, fans: np.ndarray, nodes: np.ndarray, where: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The triangle among each node's (`fans`, CSR with `indptr`) that holds its point `where`
    (k, 2) of the map, by the triangulation's barycentric `transform`, and the point's
    barycentric coordinates in it: (k,) triangle indices (−1 if none) and (k, 3) weights."""
    found = np.full(len(nodes), -1, np.int64)
    weights = np.zeros((len(nodes), 3))
    for k in range(len(nodes)):
        for f in range(indptr[nodes[k]], indptr[nodes[k] + 1]):
            t = fans[f]
            dx, dy = where[k, 0] - transform[t, 2, 0], where[k, 1] - transform[t, 2, 1]
            b0 = transform[t, 0, 0] * dx + transform[t, 0, 1] * dy
            b1 = transform[t, 1, 0] * dx + transform[t, 1, 1] * dy
            if b0 >= -1e-12 and b1 >= -1e-12 and 1.0 - b0 - b1 >= -1e-12:
                found[k] = t
                weights[k, 0], weights[k, 1], weights[k, 2] = b0, b1, 1.0 - b0 - b1
                break
    return found, weights


def _dofs(nodes: np.ndarray) -> np.ndarray:
    """The (x, y, z) rows of `nodes` in a (3N, ·) matrix."""
    return (3 * np.asarray(nodes)[:, None] + np.arange(3)).ravel()


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1)[:, None]


def _sphere_frames(polar: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """(N, 3, 3): rows (outward normal, meridian tangent away from the apex, azimuthal
    tangent) at the points of the dome with these polar and azimuth angles (rad)."""
    normal = np.column_stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)])
    east = np.column_stack([-np.sin(azimuth), np.cos(azimuth), np.zeros(len(azimuth))])
    return np.stack([normal, np.cross(east, normal), east], axis=1)


def membrane_stiffness(sheet: SkinSheet, young: float, poisson: float, thickness: float | np.ndarray) -> np.ndarray:
    """(3K, 3K) N/m: stiffness of the skin as a membrane through the sheet's nodes, of
    `thickness` (m): one, or each node's ((K,): `skin_thickness`; a triangle takes its
    corners' mean).

    Constant-strain triangles (plane stress, each in its own plane) on the sheet's
    `triangles`; curvature enters through the facets' orientations, so stretching the
    skin resists normal as well as tangential motion. The base holds the skin at the
    sheet's `held_at`: each `held` node is tied to it by a spring of the skin between
    them, E·t·(node's share of the circumference) / (its distance to the base, at least a
    quarter spacing)."""
    triangles = sheet.triangles
    x = sheet.points[triangles]  # (T, 3 corners, 3)
    e1 = _unit(x[:, 1] - x[:, 0])
    normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    area = 0.5 * np.linalg.norm(normal, axis=1)
    e2 = np.cross(normal / (2.0 * area)[:, None], e1)
    local = np.stack([np.einsum("tck,tk->tc", x - x[:, :1], e) for e in (e1, e2)], axis=2)  # (T, 3, 2)
    lx, ly = local[..., 0], local[..., 1]
    b = np.roll(ly, -1, axis=1) - np.roll(ly, -2, axis=1)  # ∂N/∂x · 2A
    c = np.roll(lx, -2, axis=1) - np.roll(lx, -1, axis=1)  # ∂N/∂y · 2A
    strain = np.zeros((len(triangles), 3, 3, 2))  # [t, strain εxx/εyy/γxy, corner, axis]
    strain[:, 0, :, 0], strain[:, 1, :, 1] = b, c
    strain[:, 2, :, 0], strain[:, 2, :, 1] = c, b
    strain /= (2.0 * area)[:, None, None, None]
    strain = np.einsum("tscl,tlk->tsck", strain, np.stack([e1, e2], axis=1)).reshape(len(triangles), 3, 9)
    elastic = (
        young
        / (1.0 - poisson**2)
        * np.array([[1.0, poisson, 0.0], [poisson, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - poisson)]])
    )
    thickness = _per_node(sheet, thickness)
    element = (thickness[triangles].mean(axis=1) * area)[:, None, None] * np.einsum(
        "tsi,sr,trj->tij", strain, elastic, strain
    )
    dofs = _dofs(triangles.ravel()).reshape(len(triangles), 9)
    n = len(sheet.points)
    stiffness = np.zeros((3 * n, 3 * n))
    np.add.at(stiffness, (dofs[:, :, None], dofs[:, None, :]), element)
    held = np.flatnonzero(sheet.held)
    share = 2.0 * math.pi * sheet.radius * math.sin(sheet.held_at) / len(held)
    to_base = np.maximum(sheet.radius * (sheet.held_at - sheet.polar[held]), 0.25 * sheet.spacing)
    for i, length in zip(held, to_base):
        stiffness[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] += young * thickness[i] * share / length * np.eye(3)
    return stiffness


def bending_stiffness(sheet: SkinSheet, young: float, poisson: float, thickness: float | np.ndarray) -> np.ndarray:
    """(3K, 3K) N/m: the skin's resistance to bending, for the nodes' normal displacement w,
    of `thickness` (m): one, or each node's ((K,): `skin_thickness`).

    The shallow-shell energy ½ D ∫ ((Δ + 2/R²) w)² dA on the sphere of radius R, with
    D = E t³ / 12(1 − ν²): Kirchhoff's plate energy without its Gaussian-curvature term
    (which for a plate integrates to the boundary); + 2/R² makes rigid translations
    (w = n·t, the degree-1 harmonics) cost nothing, and rotations have w = 0. Discretised
    with the cotangent Laplacian and lumped (barycentric) areas on the sheet's
    `triangles`; the held nodes, whose Laplacian is one-sided, carry no energy of their
    own (the membrane's springs hold them)."""
    laplacian, area = _cotangent_laplacian(sheet)
    free = ~sheet.held
    operator = (2.0 / sheet.radius**2 * np.diag(area) - laplacian)[free]  # rows ≈ A_i (Δ + 2/R²) w at node i
    rigidity = young * _per_node(sheet, thickness)[free] ** 3 / (12.0 * (1.0 - poisson**2))
    return _on_normals(sheet, operator.T @ (rigidity[:, None] * operator / area[free, None]))


def _per_node(sheet: SkinSheet, thickness: float | np.ndarray) -> np.ndarray:
    """(K,) m: a thickness given once or node by node, node by node."""
    return np.broadcast_to(np.asarray(thickness, float), (len(sheet.points),))


def skin_thickness(sheet: SkinSheet, apex: float, thickening: float = 1.0) -> np.ndarray:
    """(K,) m: the skin's thickness at the sheet's nodes, `apex` (m) at the apex and
    `thickening` times that where the base holds it, linear in the polar angle between
    (1: uniform). A cast skin that thickens towards its base stiffens its rim, as a
    membrane by t and as a shell by t³, while the pins keep their places."""
    return apex * (1.0 + (thickening - 1.0) * np.minimum(sheet.polar / sheet.held_at, 1.0))


def tension_stiffness(sheet: SkinSheet, tension: float) -> np.ndarray:
    """(3K, 3K) N/m: what the skin's pretension T (N/m, the same both ways) adds for the
    nodes' normal displacement w: the energy ½ T ∫ (|∇w|² − 2 w²/R²) dA on the sphere of
    radius R (the geometric stiffness of a membrane stretched over the gel, whose
    pressure 2T/R holds it; the second term is that pressure following the skin). A
    spherical harmonic of degree l costs T (l(l+1) − 2)/R² per unit area: rigid
    translations (l = 1) nothing, short wavelengths T k². Discretised with the cotangent
    Laplacian and lumped areas on the sheet's `triangles` (the held nodes included: w is
    held there, so the Laplacian is the held skin's)."""
    laplacian, area = _cotangent_laplacian(sheet)
    return _on_normals(sheet, tension * (laplacian - 2.0 / sheet.radius**2 * np.diag(area)))


def _cotangent_laplacian(sheet: SkinSheet) -> tuple[np.ndarray, np.ndarray]:
    """The sheet's cotangent Laplacian S ((K, K) 1/m⁰, positive semi-definite: wᵀ S w =
    ∫ |∇w|² dA for w linear on each triangle) and its nodes' lumped (barycentric) areas
    ((K,) m²)."""
    triangles, x = sheet.triangles, sheet.points
    n = len(x)
    laplacian = np.zeros((n, n))
    area = np.zeros(n)
    for k in range(3):
        i, j, o = triangles[:, k], triangles[:, (k + 1) % 3], triangles[:, (k + 2) % 3]
        a, b = x[i] - x[o], x[j] - x[o]
        half_cot = 0.5 * np.einsum("ij,ij->i", a, b) / np.linalg.norm(np.cross(a, b), axis=1)  # at the corner o
        np.add.at(laplacian, (i, j), -half_cot)
        np.add.at(laplacian, (j, i), -half_cot)
        np.add.at(laplacian, (i, i), half_cot)
        np.add.at(laplacian, (j, j), half_cot)
        np.add.at(area, i, np.linalg.norm(np.cross(x[j] - x[i], x[o] - x[i]), axis=1) / 6.0)
    return laplacian, area


def _on_normals(sheet: SkinSheet, normal_stiffness: np.ndarray) -> np.ndarray:
    """(3K, 3K): a stiffness (K, K) for the nodes' normal displacements, on their (x, y, z)."""
    normals, n = sheet.normals, len(sheet.points)
    return np.einsum("ia,ij,jb->iajb", normals, normal_stiffness, normals).reshape(3 * n, 3 * n)


#: what the cached matrices depend on besides their inputs: the code that computes them
_SOURCE_DIGEST = code_digest(Path(__file__))


def half_space_columns(
    surface: CapSurface, nodes: np.ndarray, poisson: float, shear_modulus: float
) -> tuple[np.ndarray, np.ndarray]:
    """The open half-space's columns of `nodes`: every node's displacement (k, 3, N, 3)
    and the pin tips' (k, 3, 127, 3) per unit force at each (m/N; [source, force axis,
    point, displacement axis])."""
    frames, radius = surface.frames, math.sqrt(surface.area / math.pi)
    block = disc_averaged_kernel(surface.points, surface.points[nodes], frames[nodes], radius, poisson, shear_modulus)
    block[nodes, :, np.arange(len(nodes)), :] = self_compliance(
        surface.normals[nodes], surface.area, poisson, shear_modulus
    )
    pins = pin_tip_kernel(surface, surface.points[nodes], frames[nodes], radius, poisson, shear_modulus)
    return (
        np.ascontiguousarray(np.transpose(block, (2, 3, 0, 1))),
        np.ascontiguousarray(np.transpose(pins, (2, 3, 0, 1))),
    )


def sealed_gel(
    surface: CapSurface, poisson: float, held_deg: float = 90.0, refresh: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The sealed gel's influence matrices at unit shear modulus (G = 1 Pa; at a fixed ν
    linear elasticity scales as 1/G, so one pair serves every modulus): the nodes'
    (N, 3, N, 3) and the pin tips' (N, 3, 127, 3), [source, force axis, point,
    displacement axis], C − h hᵀ / (fᵀh + V/K) (module doc), the gel's pressure acting on
    the cap and on the free skin beyond it down to `held_deg` from the apex, where the
    base holds the skin (`CapSurface.band_to`; the equator: 90). Computed
    once per surface, pin layout and ν and kept in the cache directory
    (twin.core.resources.cached_arrays); `refresh` computes and stores them even if they
    are there (what `twin bench physics` times)."""
    n, pins = surface.count, len(surface.geometry.pin_tip_points())
    key = {
        "surface": dataclasses.asdict(surface),
        "pin_bases": _pin_bases_digest(surface),
        "poisson": poisson,
        "held_deg": held_deg,
        "code": _SOURCE_DIGEST,
    }
    arrays = cached_arrays(
        "compliance",
        key,
        lambda: _sealed_gel(surface, poisson, held_deg),
        shapes={"nodes": (n, 3, n, 3), "pins": (n, 3, pins, 3)},
        refresh=refresh,
    )
    return arrays["nodes"], arrays["pins"]


def _pin_bases_digest(surface: CapSurface) -> str:
    return hashlib.sha256(surface.geometry.pin_base_points().tobytes()).hexdigest()[:16]


def _bulk_ratio(poisson: float) -> float:
    """K / G of the gel (inf at ν = 0.5: incompressible)."""
    return 2.0 * (1.0 + poisson) / (3.0 * (1.0 - 2.0 * poisson)) if poisson < 0.5 else math.inf


def _gel_volume(surface: CapSurface) -> float:
    """m³: the gel, a hemisphere on the rigid base."""
    return 2.0 / 3.0 * math.pi * surface.geometry.skin_inner_radius**3


def _sealed_gel(surface: CapSurface, poisson: float, held_deg: float) -> dict[str, np.ndarray]:
    nodes, pins = half_space_columns(surface, np.arange(surface.count), poisson, 1.0)
    n = 3 * surface.count
    compliance, pin_compliance = nodes.reshape(n, n), pins.reshape(n, -1)  # views, [source, point]
    h, pins_h, volume_compliance = _pressure_response(
        compliance, pin_compliance, (surface.area * surface.normals).ravel()
    )
    band_h, band_pins_h, band_volume = _band_pressure(surface, poisson, held_deg)
    _keep_gel_volume(
        compliance,
        pin_compliance,
        h + band_h.ravel(),
        pins_h + band_pins_h.ravel(),
        volume_compliance + band_volume + _gel_volume(surface) / _bulk_ratio(poisson),
    )
    return {"nodes": nodes, "pins": pins}


def _pressure_response(
    compliance: np.ndarray, pin_compliance: np.ndarray, forces: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """What a unit gel pressure (1 Pa) moves: the nodes h ((3N,) m, symmetrised: C is
    symmetric to 0.06 %, module doc), the pin tips ((381,) m) and the volume fᵀh (m³),
    for the compliances [source, point] ((3N, 3N) and (3N, 381), m/N) and the pressure's
    nodal forces f ((3N,) N per Pa)."""
    h = 0.5 * (compliance @ forces + compliance.T @ forces)
    return h, pin_compliance.T @ forces, float(forces @ h)


def _keep_gel_volume(
    compliance: np.ndarray, pin_compliance: np.ndarray, h: np.ndarray, pins_h: np.ndarray, volume_compliance: float
) -> None:
    """The sealed gel's constraint, in place: C − h hᵀ / c and P − h p_hᵀ / c for the
    compliances [source, point] (m/N), the nodes' and pins' displacement per Pa of gel
    pressure (h, p_h, m) and the volume compliance c = fᵀh + V/K (m³ per Pa; module doc)."""
    compliance -= np.outer(h, h / volume_compliance)
    pin_compliance -= np.outer(h, pins_h / volume_compliance)


def _band_pressure(surface: CapSurface, poisson: float, held_deg: float) -> tuple[np.ndarray, np.ndarray, float]:
    """What a unit gel pressure (1 Pa, G = 1 Pa) on the free skin beyond the cap, down to
    `held_deg` (`CapSurface.band_to`), adds: the cap nodes' displacement (N, 3) m and the
    pin tips' (127, 3) m, and the volume it pushes out, the band's own share and the cross
    terms with the cap's pressure (m³; Maxwell–Betti: the cap's pressure moves the band by
    as much volume as the band's moves the cap)."""
    points, frames = surface.band_to(held_deg)
    radius = math.sqrt(surface.area / math.pi)
    band_forces = surface.area * frames[:, 0]
    cap_forces = surface.area * surface.normals
    cap_from_band = disc_averaged_kernel(surface.points, points, frames, radius, poisson, 1.0)  # [cap, a, band, b]
    band_from_cap = disc_averaged_kernel(points, surface.points, surface.frames, radius, poisson, 1.0)
    h = 0.5 * (
        np.einsum("iajb,jb->ia", cap_from_band, band_forces) + np.einsum("jbia,jb->ia", band_from_cap, band_forces)
    )
    band = disc_averaged_kernel(points, points, frames, radius, poisson, 1.0)
    band[np.arange(len(points)), :, np.arange(len(points)), :] = self_compliance(
        frames[:, 0], surface.area, poisson, 1.0
    )
    band_on_band = float(np.einsum("ia,iajb,jb->", band_forces, band, band_forces))
    pins_h = np.einsum(
        "paqb,qb->pa",
        pin_tip_kernel(surface, points, frames, radius, poisson, 1.0),
        band_forces,
    )
    return h, pins_h, 2.0 * float(np.sum(cap_forces * h)) + band_on_band


def skinned(
    surface: CapSurface,
    poisson: float,
    shear_modulus: float,
    membrane_young: float,
    bending: bool = False,
    enclosed: bool = True,
    held_deg: float = 90.0,
    refresh: bool = False,
    tension: float = 0.0,
    bending_young: float | None = None,
    thickening: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The dome with its skin as a membrane (Young's modulus `membrane_young`, Pa; with
    `bending`, a thin shell: `bending_stiffness` too, of modulus `bending_young` (Pa; None:
    `membrane_young`); stretched by `tension`, N/m: `tension_stiffness`; `thickening` times
    as thick where the base holds it as at the apex: `skin_thickness`) over the gel (shear modulus G, Pa;
    sealed where `enclosed`), in `sealed_gel`'s layout ([source, force axis, point,
    displacement axis], m/N): the cap's columns, the nodes' and the pin tips'. The skin
    and the gel under it are modelled down to `held_deg` from the apex, where the base
    holds the skin (`CapSurface.skin_to`; the equator: 90); contact acts on the cap
    alone; the skin and the gel act in series (`skin_on_gel`).
    Computed once per surface, materials and ν and kept in the cache directory, as
    `sealed_gel`."""
    n, pins = surface.count, len(surface.geometry.pin_tip_points())
    key = {
        "surface": dataclasses.asdict(surface),
        "pin_bases": _pin_bases_digest(surface),
        "poisson": poisson,
        "shear_modulus": shear_modulus,
        "membrane_young": membrane_young,
        "bending": bending,
        "enclosed": enclosed,
        "held_deg": held_deg,
        "tension": tension,
        "bending_young": bending_young,
        "thickening": thickening,
        "code": _SOURCE_DIGEST,
    }
    arrays = cached_arrays(
        "compliance",
        key,
        lambda: _skinned(
            surface,
            poisson,
            shear_modulus,
            membrane_young,
            bending,
            enclosed,
            held_deg,
            tension,
            bending_young,
            thickening,
        ),
        shapes={"nodes": (n, 3, n, 3), "pins": (n, 3, pins, 3)},
        refresh=refresh,
    )
    return arrays["nodes"], arrays["pins"]


def _skinned(
    surface: CapSurface,
    poisson: float,
    shear_modulus: float,
    membrane_young: float,
    bending: bool,
    enclosed: bool,
    held_deg: float,
    tension: float,
    bending_young: float | None,
    thickening: float,
) -> dict[str, np.ndarray]:
    sheet = surface.skin_to(held_deg)
    count, radius = len(sheet.points), math.sqrt(surface.area / math.pi)
    gel = disc_averaged_kernel(sheet.points, sheet.points, sheet.frames, radius, poisson, shear_modulus)
    gel[np.arange(count), :, np.arange(count), :] = self_compliance(sheet.normals, surface.area, poisson, shear_modulus)
    gel = gel.reshape(3 * count, 3 * count)  # displacement per force
    pins = pin_tip_kernel(surface, sheet.points, sheet.frames, radius, poisson, shear_modulus).reshape(-1, 3 * count)
    if enclosed:  # the gel's pressure on the whole free skin, as `_sealed_gel`, here without condensing
        h, pins_h, volume_compliance = _pressure_response(gel.T, pins.T, (surface.area * sheet.normals).ravel())
        _keep_gel_volume(
            gel.T, pins.T, h, pins_h, volume_compliance + _gel_volume(surface) / (_bulk_ratio(poisson) * shear_modulus)
        )
    return skin_on_gel(surface, sheet, gel, pins, membrane_young, bending, tension, bending_young, thickening)


def skin_on_gel(
    surface: CapSurface,
    sheet: SkinSheet,
    gel: np.ndarray,
    pins: np.ndarray,
    membrane_young: float,
    bending: bool,
    tension: float = 0.0,
    bending_young: float | None = None,
    thickening: float = 1.0,
) -> dict[str, np.ndarray]:
    """The cap's columns, in `sealed_gel`'s layout, of the skin (a membrane of Young's
    modulus `membrane_young`, Pa; with `bending`, a thin shell, its bending modulus
    `bending_young` (Pa; None: `membrane_young`); pretensioned by `tension`, N/m; the
    geometry's thickness at the apex, `thickening` times it at the base: `skin_thickness`) over a gel whose
    compliance on the sheet's nodes is `gel` ((3K, 3K) m/N, tool frame, [node, axis]) and
    whose pin tips move by `pins` ((381, 3K) m/N) (`skinned`; with no skin, the gel's own
    columns). The skin's stiffness K and the gel's compliance C act in series with the
    contact force f: the gel takes g = f − K u and u = C g, so u = (I + C K)⁻¹ C f; the
    pins follow the gel under g."""
    count = len(sheet.points)
    thickness = skin_thickness(sheet, surface.geometry.skin_thickness, thickening)
    skin = membrane_stiffness(sheet, membrane_young, 0.5, thickness)
    if bending:
        skin += bending_stiffness(sheet, membrane_young if bending_young is None else bending_young, 0.5, thickness)
    if tension:
        skin += tension_stiffness(sheet, tension)
    skin = sparse.csr_matrix(skin)
    cap = 3 * surface.count
    displacement = np.linalg.solve(np.eye(3 * count) + (skin.T @ gel.T).T, gel[:, :cap])  # u per cap force
    nodes = displacement[:cap]
    nodes = 0.5 * (nodes + nodes.T)
    pin_tips = pins[:, :cap] - (skin.T @ pins.T).T @ displacement
    return {
        "nodes": np.ascontiguousarray(nodes.T).reshape(surface.count, 3, surface.count, 3),
        "pins": np.ascontiguousarray(pin_tips.T).reshape(surface.count, 3, -1, 3),
    }


class DomeCompliance:
    """The dome's influence matrices for a material, stored by source node (column).

    Everything in the tool frame. `block(rows, cols)`: displacements of nodes `rows` per
    unit force at nodes `cols` (m/N); `surface_displacement`, `pin_displacement`: every
    node's and the pin tips' displacement under nodal forces. A column is closed form
    (≈ 0.1 ms): the open half-space computes a node's the first time a contact touches it;
    the sealed gel (`enclosed`) and the skin membrane need them all, loaded or computed at
    the first contact (`sealed_gel`, cached on disk; `skinned`) and kept for the life of
    the dome. The material: the gel's `young` (Pa) and `poisson`; the skin's membrane
    `membrane_young` (Pa, 0 = none), `skin_bending` (its bending modulus `bending_young`,
    Pa; None: `membrane_young`), where the base holds it
    (`skin_held_deg`, deg from the apex) and its pretension `skin_tension` (N/m; needs the
    membrane); `skin_thickening`: the skin is that many times as thick where the base holds
    it as at the apex (`skin_thickness`; needs the membrane); `pin_lever` (m): the lever
    the skin's turn swings a pin tip by (None: the geometry's pin length); `pins_in_gel`:
    the tips move with the gel that far below the skin (`pin_tips_in_gel`) instead.
    """

    def __init__(
        self,
        surface: CapSurface,
        young: float,
        poisson: float,
        enclosed: bool = True,
        membrane_young: float = 0.0,
        skin_bending: bool = False,
        skin_held_deg: float = 90.0,
        skin_tension: float = 0.0,
        pin_lever: float | None = None,
        bending_young: float | None = None,
        pins_in_gel: bool = False,
        skin_thickening: float = 1.0,
    ) -> None:
        if not (young > 0 and 0.0 <= poisson <= 0.5 and membrane_young >= 0):
            raise ValueError(
                f"dome material: need young > 0 Pa, 0 <= poisson <= 0.5 and membrane_young >= 0 Pa, "
                f"got {young}, {poisson}, {membrane_young}"
            )
        if skin_bending and not membrane_young:
            raise ValueError("dome material: skin_bending needs the skin membrane (membrane_young > 0 Pa)")
        if skin_tension < 0 or (skin_tension and not membrane_young):
            raise ValueError(
                f"dome material: skin_tension needs the skin membrane (membrane_young > 0 Pa) and "
                f"≥ 0 N/m, got {skin_tension} N/m over {membrane_young} Pa"
            )
        if skin_thickening <= 0 or (skin_thickening != 1.0 and not membrane_young):
            raise ValueError(
                f"dome material: skin_thickening needs the skin membrane (membrane_young > 0 Pa) and > 0, "
                f"got {skin_thickening} over {membrane_young} Pa"
            )
        if bending_young is not None and not (skin_bending and bending_young > 0):
            raise ValueError(f"dome material: bending_young needs skin_bending and > 0 Pa, got {bending_young} Pa")
        if pin_lever is not None and not 0.0 <= pin_lever < surface.geometry.skin_inner_radius:
            raise ValueError(f"pin lever: need 0 <= pin_lever < the skin's inner radius, got {pin_lever} m")
        if pin_lever is not None:  # the lever is the post's length in post_tips; the surface's key carries it
            surface = dataclasses.replace(surface, geometry=dataclasses.replace(surface.geometry, pin_length=pin_lever))
        surface = dataclasses.replace(surface, pins_in_gel=pins_in_gel)
        if not surface.extent_deg <= skin_held_deg <= 90.0:
            raise ValueError(
                f"the base holds the skin between the cap's rim ({surface.extent_deg:g}°) and the "
                f"equator (90°), got {skin_held_deg}°"
            )
        self.surface = surface
        self.pin_tips = surface.geometry.pin_tip_points()
        self.young, self.poisson, self.enclosed, self.membrane_young = young, poisson, enclosed, membrane_young
        self.skin_bending, self.skin_held_deg, self.skin_tension = skin_bending, skin_held_deg, skin_tension
        self.bending_young, self.skin_thickening = bending_young, skin_thickening
        self.shear_modulus = young / (2.0 * (1.0 + poisson))
        n = surface.count
        # stored by source node (column), so an untouched column's pages are never mapped
        self._surface = np.zeros((n, 3, n, 3))  # [source j, force axis, node i, displacement axis]
        self._pins = np.zeros((n, 3, len(self.pin_tips), 3))
        self._filled = np.zeros(n, bool)

    def fill(self, nodes: np.ndarray) -> None:
        """Compute the columns of `nodes` (indices) not computed yet. The sealed gel and the
        skin take every column at once (`one_off`, from the cache after the first time)."""
        if self.enclosed or self.membrane_young:
            if not self._filled.all():
                self._surface, self._pins = self.one_off()
                self._filled[:] = True
            return
        todo = nodes[~self._filled[nodes]]
        if len(todo):
            self._surface[todo], self._pins[todo] = half_space_columns(
                self.surface, todo, self.poisson, self.shear_modulus
            )
            self._filled[todo] = True

    def one_off(self, refresh: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Every column at once: the skinned dome's (`skinned`) or the sealed gel's
        (`sealed_gel`, scaled to this modulus), loaded from the cache or computed and
        stored (always where `refresh`: what `twin bench physics` times); the open gel's
        without a skin, computed (`fill` computes those only as contacts reach them)."""
        if self.membrane_young:
            return skinned(
                self.surface,
                self.poisson,
                self.shear_modulus,
                self.membrane_young,
                self.skin_bending,
                self.enclosed,
                self.skin_held_deg,
                refresh=refresh,
                tension=self.skin_tension,
                bending_young=self.bending_young,
                thickening=self.skin_thickening,
            )
        if self.enclosed:
            nodes, pins = sealed_gel(self.surface, self.poisson, self.skin_held_deg, refresh=refresh)
            return nodes / self.shear_modulus, pins / self.shear_modulus
        return half_space_columns(self.surface, np.arange(self.surface.count), self.poisson, self.shear_modulus)

    def precompute(self) -> None:
        """Everything a run computes (or loads) at its first contacts: every column where
        the dome needs them all (`one_off`; what `twin bench physics` times as cached)."""
        self.fill(np.arange(self.surface.count))

    def block(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """(3·len(rows), 3·len(cols)) m/N: displacements of `rows` per force at `cols`."""
        self.fill(cols)
        n = 3 * self.surface.count
        return np.ascontiguousarray(self._surface.reshape(n, n)[np.ix_(_dofs(cols), _dofs(rows))].T)

    def local_block(
        self,
        nodes: np.ndarray,
        frames: np.ndarray,
        sway: float = 0.0,
        signs: np.ndarray | None = None,
        kept: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """(3m, 3m) m/N: `block(nodes, nodes)` with each node's displacement and force in its
        own frame (frames (m, 3, 3), rows the frame's axes in the tool frame), plus the tip's
        `sway` (m/N, `sway_block`), each row and column times its axis' sign in `signs` (3,)
        (None: all +1; the contact solve's unknowns, twin.world.dome.compliant.contact.UNKNOWN_SIGNS).
        `kept`: an earlier result for the same sway and signs, its nodes (k,), frames
        (k, 3, 3) and block (3k, 3k): the entries between nodes it holds in the same
        frames are copied from it, bit for bit what they would be turned anew."""
        self.fill(nodes)
        frames = np.ascontiguousarray(frames, dtype=float)
        signs = np.ones(3) if signs is None else np.asarray(signs, dtype=float)
        source = np.full(len(nodes), -1, np.int64)
        earlier = np.zeros((0, 0))
        if kept is not None:
            kept_nodes, kept_frames, earlier = kept
            _, here, there = np.intersect1d(nodes, kept_nodes, assume_unique=True, return_indices=True)
            same = np.all(kept_frames[there] == frames[here], axis=(1, 2))
            source[here[same]] = there[same]
        return _rotated_block(self._surface, nodes, frames, sway, signs, source, earlier)

    def surface_displacement(self, cols: np.ndarray, forces: np.ndarray, sway: float = 0.0) -> np.ndarray:
        """(N, 3) m: every node's displacement under forces (len(cols), 3) N at `cols`, the
        tip swaying by `sway` (m/N, `sway_shift`)."""
        self.fill(cols)
        n = 3 * self.surface.count
        moved = _row_combination(self._surface.reshape(n, n), _dofs(cols), forces.ravel()).reshape(-1, 3)
        return moved + sway_shift(forces, sway) if sway else moved

    def pin_displacement(self, cols: np.ndarray, forces: np.ndarray, sway: float = 0.0) -> np.ndarray:
        """(127, 3) m: the pin tips' displacement under forces (len(cols), 3) N at `cols`, the
        tip swaying by `sway` (m/N, `sway_shift`)."""
        self.fill(cols)
        pins = self._pins.reshape(3 * self.surface.count, -1)
        moved = _row_combination(pins, _dofs(cols), forces.ravel()).reshape(-1, 3)
        return moved + sway_shift(forces, sway) if sway else moved


def sway_block(frames: np.ndarray, sway: float) -> np.ndarray:
    """(3m, 3m) m/N: what the tip's sway `sway` (m/N) adds to the compliance among nodes in
    their frames (m, 3, 3), rows the frame's axes in the tool frame: entry (3i + a, 3j + b)
    is sway · Σ_k∈{x,y} frames[i, a, k] frames[j, b, k]."""
    across = np.ascontiguousarray(frames[:, :, :2]).reshape(-1, 2)
    return sway * (across @ across.T)


def sway_shift(forces: np.ndarray, sway: float) -> np.ndarray:
    """(3,) m: how far the tip's sway `sway` (m/N) moves every node and pin tip under nodal
    forces (m, 3) N, tool frame: sway · (Σf_x, Σf_y, 0)."""
    total = forces.sum(axis=0)
    return sway * np.array([total[0], total[1], 0.0])


@compiled
def _row_combination(matrix: np.ndarray, rows: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Σ_k weights[k] · matrix[rows[k]]: the influence of forces at a few dofs, reading only
    the rows of the nonzero ones (numpy's fancy indexing would copy them all first; the
    candidates out of contact carry none)."""
    out = np.zeros(matrix.shape[1])
    for k in range(len(rows)):
        weight = weights[k]
        if weight == 0.0:
            continue
        row = matrix[rows[k]]
        for i in range(len(out)):
            out[i] += weight * row[i]
    return out


@compiled
def _rotated_block(
    surface: np.ndarray,
    nodes: np.ndarray,
    frames: np.ndarray,
    sway: float,
    signs: np.ndarray,
    source: np.ndarray,
    earlier: np.ndarray,
) -> np.ndarray:
    """(3m, 3m): the compliance among `nodes` in their frames (m, 3, 3), from `surface`
    (N, 3, N, 3) [source node, force axis, node, displacement axis], with the tip's `sway`:
    entry (3i + a, 3j + b) is signs[a] signs[b] (Σ_kl frames[i, a, k] surface[j, l, i, k]
    frames[j, b, l] + `sway_block`'s). Where both nodes have a `source` (m,) ≥ 0, their
    position in `earlier` (the same product for other nodes), the entries are copied."""
    m = len(nodes)
    out = np.empty((3 * m, 3 * m))
    for i in range(m):  # row by row, as both are laid out
        if source[i] < 0:
            continue
        for a in range(3):
            row, kept_row = out[3 * i + a], earlier[3 * source[i] + a]
            for j in range(m):
                if source[j] >= 0:
                    for b in range(3):
                        row[3 * j + b] = kept_row[3 * source[j] + b]
    turned = np.empty((3, 3))
    for j in range(m):
        for i in range(m):
            if source[i] >= 0 and source[j] >= 0:
                continue
            block = surface[nodes[j], :, nodes[i], :]  # [force axis l, displacement axis k]
            for a in range(3):
                for l in range(3):
                    turned[a, l] = (
                        frames[i, a, 0] * block[l, 0] + frames[i, a, 1] * block[l, 1] + frames[i, a, 2] * block[l, 2]
                    )
            for a in range(3):
                for b in range(3):
                    out[3 * i + a, 3 * j + b] = (
                        signs[a]
                        * signs[b]
                        * (
                            turned[a, 0] * frames[j, b, 0]
                            + turned[a, 1] * frames[j, b, 1]
                            + turned[a, 2] * frames[j, b, 2]
                            + sway * (frames[i, a, 0] * frames[j, b, 0] + frames[i, a, 1] * frames[j, b, 1])
                        )
                    )
    return out
