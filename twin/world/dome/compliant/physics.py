"""The compliant dome: quasi-static frictional contact at the sensor's own resolution.

`CompliantPhysics` has `SensorPhysics`' interface (move, settle, rest_pins, steps,
converged_pins) and replaces MuJoCo's flex dome by an elastic solid solved exactly at
every increment of the path:

* the object is a MuJoCo scene (the stimulus carrier and its collision pieces, no dome):
  each increment puts the carrier at the object's pose in the tool frame and casts a
  ray from the dome's sphere centre along each surface node's normal (mj_multiRay), which
  gives the node's rigid gap to the object along its normal; only the rays that can meet
  a piece's bounding box near enough to matter are cast (twin.world.dome.rays), which on the
  paper's taps over the rounded edge casts about a tenth of them;
* the dome is the influence model of twin.world.dome.compliant.compliance (Boussinesq–Cerruti, a
  node every `spacing` on the cap, and the sealed gel's pressure keeping its volume);
* each increment is one frictional contact problem (twin.world.dome.compliant.contact): Signorini
  contact and Coulomb friction whose stick/slip state and tractions carry over from the
  previous increment — the path dependence the paper is about;
* the pins are posts on the skin: each base moves with the gel and each post turns with
  the skin's surface (twin.world.dome.compliant.compliance.pin_tip_kernel), so a flattened patch
  swings its pins' tips outwards and a sheared patch carries them along.

A move is cut into increments of at most `step_length` of tool travel and
`step_angle_deg` of rotation; the result of each is an equilibrium, so a frame needs no
settling (`settle` returns the current state). Quasi-static: the speed only sets the
simulated time. Out of contact, an increment whose contact profile is certainly clear of
the object (its bounding sphere against the pieces' bounding boxes, `profile_bound`,
`_out_of_reach`) casts no rays: it would
leave the dome at rest, as it is (taps: 0.83–0.85× the time of casting them). Without the
`contact` effect the object has no collision pieces, no ray hits and no problem is
solved; without `friction` only the normal problem is.

Every increment is checked; a failure raises `PhysicsError` naming the scenario, the
increment, the pose and what failed: a contact problem that did not converge, NaN/Inf,
penetration after the solve beyond `max_penetration`, contact at the rim of the modelled
cap, an indentation beyond what the rays can see, a total force above `max_force`, a pin
farther than `max_pin_excursion` from rest.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import ClassVar, NamedTuple

import mujoco
import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from twin.core.errors import PhysicsError
from twin.core.poses import invert_transform, make_transform
from twin.core.sensor import TacTipGeometry
from twin.world.dome.base import Frame, physics_error
from twin.world.dome.compiled import compiled
from twin.world.dome.compliant.closest import ClosestPoints
from twin.world.dome.compliant.compliance import CapSurface, DomeCompliance
from twin.world.dome.compliant.contact import UNKNOWN_SIGNS, ContactNotConverged, solve_increment
from twin.world.dome.compliant.cut_nodes import (
    FACING_DEG,
    CutNodes,
    boundary_nodes,
    cut_nodes,
    partial_disc_compliance,
    sample_directions,
)
from twin.world.dome.rays import rays_into_boxes

#: how much farther than a gap can matter each ray is cast (m), a node's or a disc sample's:
#: a ray that meets no piece's bounding box within it is left out; a node the solve then
#: moves that far gets its ray (`CompliantPhysics._uncast_reached`), so the margin only sets
#: how often that happens
CAST_SLACK = 0.001
#: with `finite_sliding`, the solves of one increment, each measuring the gaps where the
#: last one displaced the nodes, before the points' drift counts as not settling
FINITE_SLIDING_SWEEPS = 40
#: how far (m) the displaced points may still move in the increment's last solve (0.07 px of pin motion)
FINITE_SLIDING_TOLERANCE = 5e-6
#: solves taken whole towards the points the last one displaced, before each takes half the step before
FINITE_SLIDING_FREE_SWEEPS = 5
#: where the halved steps have settled the points where the contact set switches, how far the
#: solve taken may still move them, in node spacings (a node pressed on one side of the switch,
#: free on the other): half a spacing, the resolution whole nodes place an edge to. On the
#: paper's slides on the sharp rectangle (the fit with finite sliding) one increment needed 0.18
FINITE_SLIDING_SWITCH = 0.5
#: how far (m) a displaced point is drawn back along its outward normal before it is
#: projected onto the object (`_closest_points`): more than an increment presses it in
CLOSEST_SETBACK = 1e-3
#: the pressure (Pa) over which a node's adhesion builds up as it is pressed (`CompliantParams.adhesion`):
#: e^-1 of it is left to build at this pressure, a tenth of a 4 mm tap's mean pressure. Steeper
#: ramps cost Newton iterations for little: on 12 sheared taps onto the object at 10 kPa, 2 kPa
#: took 1.77× the iterations without adhesion, 5 kPa 1.08×, and moved the friction force 4 %
ADHESION_RAMP = 5e3
#: deg: where the object's inward normal turns from its top's by more than this, a node is on
#: an edge's round (or a wall) and `edge_friction` stretches its friction across the turn
EDGE_TILT_DEG = 10.0


@dataclass(frozen=True)
class CompliantParams:
    """Material, resolution and solver parameters of the compliant dome (SI units).

    The defaults are the dome fitted to a real TacTip's edge taps (docs/real-sensor.md, "The
    fit with the slide across the edge"): a skin shell held 75° from the apex over a
    sealed 18.8 kPa gel, pins as 1.55 mm levers, the tip swaying 0.134 mm/N, a 30 mm apex
    profile, on nodes 1.8 mm apart. Each field below says what it does when changed.

    young (Pa), poisson (–): the gel's modulus under the skin (with membrane_young = 0: the
      skin + gel as one elastic solid). The gel is a silicone (ν ≈ 0.5, incompressible).
    spacing (m): node spacing on the outer surface (the pins are 3.3 mm apart).
    extent_deg (deg): half-angle of the cap that can take contact; the pins reach 61°, a
      6 mm press on a flat 51°. The gel's pressure acts beyond it too, to the equator, so
      it does not change the pins (twin.world.dome.compliant.compliance).
    step_length (m), step_angle_deg (deg): largest tool motion per contact increment (the
      resolution of the friction path; a scenario sets step_length as `physics:
      {increment_mm}`). On the benchmark's contour path (twin bench physics) 0.5 mm moves
      the pins ≤ 0.22 px from 0.25 mm for 0.68× the time, 1 mm ≤ 0.36 px;
      sliding 16 mm along the edge at 4 mm depth ≤ 0.13 / 0.35 px; across the edge and back
      at 3 mm, where the edge enters and leaves the contact, ≤ 1.13 / 2.83 px (RMS 0.17 / 0.50).
    candidate_margin (m): nodes whose rigid gap is below this enter the contact problem
      (any other node found penetrating after a solve is added and the increment solved
      again).
    tolerance (m), max_iterations: contact solver residual and iteration limit (1 px of
      pin motion ≈ 75 µm; 0.1 µm moved the pins ≤ 0.003 px from 0.01 µm).
    max_penetration (m), max_force (N), max_pin_excursion (m): the per-increment checks.
    enclosed: the gel is sealed in the dome and keeps its volume (twin.world.dome.compliant.compliance);
      False is an open half-space, the body of the closed-form contact checks.
    membrane_young (Pa): the skin as a membrane over the gel (twin.world.dome.compliant.compliance.
      membrane_stiffness), 0 = none (what it changes is measured in docs/dome/skins.md).
    skin_bending: the skin membrane also resists bending, as a thin shell
      (twin.world.dome.compliant.compliance.bending_stiffness); needs membrane_young.
    bending_young (Pa): the shell's bending modulus, D = E t³ / 12(1 − ν²) with this E, for
      a skin that bends unlike it stretches (a layered skin); None = membrane_young. Needs
      skin_bending.
    skin_held_deg: where the base holds the skin, degrees from the apex: the skin and the
      gel's pressure go on from the cap's rim (extent_deg) down to it. The geometry's dome
      meets its base at the equator (90); a sensor whose skin is bonded higher up holds it
      there.
    skin_tension (N/m): the skin's pretension over the sealed gel (the gel's pressure
      2T/R holds it; twin.world.dome.compliant.compliance.tension_stiffness): it resists
      the skin's short wavelengths more than its long ones. 0 (the default) = none; needs
      membrane_young.
    skin_thickening (–): the skin's thickness where the base holds it over its thickness
      at the apex (the geometry's), linear in the polar angle between (twin.world.dome.
      compliant.compliance.skin_thickness): a skin that thickens towards its base stiffens
      its rim. 1 (the default) = uniform; needs membrane_young.
    pin_lever (m): the lever the skin's turn swings a pin tip by (twin.world.dome.
      compliant.compliance.post_tips); None = the geometry's pin length, 2 mm. Longer: the
      pins amplify the skin's slope more against its displacement.
    pins_in_gel: the pin tips move with the gel at the lever's depth below the skin
      (twin.world.dome.compliant.compliance.pin_tips_in_gel) instead of as posts turning
      with the skin, so neighbouring tips cannot pass each other. Off by default.
    tip_sway (m/N): the tip moves as a whole against the camera by this much per newton
      of net tangential contact force (twin.world.dome.compliant.compliance.sway_block),
      in series with the rest. 0 = none.
    adhesion (Pa): the skin's adhesive shear strength τ on the object, with friction: a
      node slips at a shear stress of μ·pressure + τ once pressed past ADHESION_RAMP
      (twin.world.dome.compliant.contact.friction_bound), so the friction force grows with
      the contact's area as well as its load, as a rubber's does. 0 (the default) =
      Coulomb's μ·pressure alone.
    edge_friction (–): friction across an edge's round over friction along it: where the
      object's surface turns from its top by more than EDGE_TILT_DEG, a node slips once its
      traction reaches an ellipse, edge_friction times μ·pressure across the round and
      μ·pressure along the edge (twin.world.dome.compliant.contact.solve_increment's
      `anisotropy`), as a rubber ploughs over an edge more than it slides along one. 1 (the
      default) = the same disc every way, nothing computed.
    apex_radius (m): the radius of curvature of the outer profile the object meets, a
      sphere through the apex (`apex_lift`); the compliance stays the geometry's dome's, as
      Hertz theory pairs a curved profile with a half-space's compliance. At or below the
      geometry's dome radius (20 mm) the gap is the sphere's own. Its patch
      is √(apex_radius / dome radius) times as wide at a depth: a spacing scaled alike
      keeps as many nodes across it (docs/dome/compliant.md).
    edge_within_node: a node whose disc a face's boundary crosses (a straight edge's
      corner) takes contact over the part of its disc on the face, with that part's gap,
      compliance and centroid (twin.world.dome.compliant.cut_nodes), so an edge is placed
      within a node. Off by default: contact at whole nodes, each by the ray through its
      centre (an edge to within half a spacing). On, the pins converge with the lattice
      twice as fast near an edge, for 1.4× the time of a frame there; what it changes in
      the perception's figures is measured in docs/dome/compliant.md.
    finite_sliding: each node meets the object where friction has dragged it, not where
      it rests: its gap is to the object's closest point to its displaced point
      (twin.world.dome.compliant.closest), and each increment is solved again until those
      points settle (FINITE_SLIDING_TOLERANCE). Off (small sliding): the face under a
      node's rest point holds it, its plane extended, however far friction drags the node;
      exact on a face, wrong where a drag carries a node over an edge. Needs whole nodes
      (edge_within_node off).
    """

    #: the largest Poisson's ratio (–) the model takes (the incompressible gel's ν = 0.5 is the model's own)
    max_poisson: ClassVar[float] = 0.5

    young: float = 1.878e4
    poisson: float = 0.5
    spacing: float = 0.0018
    extent_deg: float = 65.0
    step_length: float = 0.0005
    step_angle_deg: float = 2.0
    candidate_margin: float = 0.0005
    tolerance: float = 1e-7
    max_iterations: int = 20000
    max_penetration: float = 1e-6
    max_force: float = 50.0
    max_pin_excursion: float = 0.012
    enclosed: bool = True
    membrane_young: float = 2.347e5
    skin_bending: bool = True
    skin_held_deg: float = 75.0
    skin_tension: float = 0.0
    pin_lever: float | None = 0.00155
    bending_young: float | None = 4.068e5
    pins_in_gel: bool = False
    skin_thickening: float = 1.0
    tip_sway: float = 1.342e-4
    adhesion: float = 0.0
    edge_friction: float = 1.0
    apex_radius: float = 0.030
    edge_within_node: bool = False
    finite_sliding: bool = False

    def with_(self, **changes) -> CompliantParams:
        return replace(self, **changes)

    @property
    def material(
        self,
    ) -> tuple[float, float, bool, float, bool, float, float, float | None, float | None, bool, float]:
        """`DomeCompliance`'s arguments after the surface: young, poisson, enclosed,
        membrane_young, skin_bending, skin_held_deg, skin_tension, pin_lever, bending_young,
        pins_in_gel, skin_thickening."""
        return (
            self.young,
            self.poisson,
            self.enclosed,
            self.membrane_young,
            self.skin_bending,
            self.skin_held_deg,
            self.skin_tension,
            self.pin_lever,
            self.bending_young,
            self.pins_in_gel,
            self.skin_thickening,
        )


#: Fidelity levels of the compliant dome (scenario `fidelity` with `dome: compliant`).
COMPLIANT_LEVELS: dict[str, CompliantParams] = {
    "fast": CompliantParams(spacing=0.0025, step_length=0.001, step_angle_deg=4.0),
    "default": CompliantParams(),
    "reference": CompliantParams(spacing=0.001, step_length=0.00025, step_angle_deg=1.0, tolerance=1e-8),
}


#: The plain solid, as scenario `physics` entries: one sealed 67 kPa solid with no skin, no
#: sway, 2 mm pin levers and the dome's own 20 mm profile (the compliant dome's material
#: before the fitted dome; its nodes were 1.5 mm apart). With `gel_enclosed: false` it is
#: the elastic half-space that the closed-form contact checks (Hertz, Cattaneo–Mindlin) are
#: stated for.
PLAIN_SOLID: dict[str, float | bool] = {
    "membrane_young_mpa": 0.0,
    "skin_bending": False,
    "gel_young_kpa": 67.0,
    "skin_held_deg": 90.0,
    "pin_lever_mm": 2.0,
    "tip_sway_mm_per_n": 0.0,
    "apex_radius_mm": 20.0,
}


class _LocalMatrix(NamedTuple):
    """`CompliantPhysics._local_matrix`'s last matrix and what it was built for."""

    nodes: np.ndarray  # (m,) candidate nodes
    frames: np.ndarray  # (m, 3, 3) their contact frames
    covered: np.ndarray  # (m,) each one's covered share of its disc
    matrix: np.ndarray  # (3m, 3m) m/N, `unknowns_matrix` of their compliance
    partial: np.ndarray  # (m, 3) m/N, each cut one's partial-disc term (0 where whole)
    turned: np.ndarray  # (3m, 3m) m/N, `matrix` without the partial-disc terms (`local_block`)


class _LastIncrement(NamedTuple):
    """What `CompliantPhysics._increment` keeps of the increment before the last one, from
    which a straight move's next one is extrapolated (`_warm_start`, `_predicted_through`)."""

    forces: np.ndarray  # (N, 3) N, tool frame
    candidates: np.ndarray  # (m,) the nodes solved
    shift: np.ndarray  # 4×4, the object's motion over it
    displacement: np.ndarray  # (N, 3) m, tool frame


class CompliantPhysics:
    """Moves the sensor and solves the dome's frictional contact at every increment.

    model, data: a compiled scene holding only the stimulus carrier (a free body named
      `carrier`) and the object's collision pieces on it, poses in the lab world frame.
    params: CompliantParams. friction: the skin–object Coulomb coefficient (0 = the
      scenario has no `friction`: no tangential problem). start_tool2world: the
      sensor's initial lab pose (4×4, m), out of contact. stimulus2world: the carrier's
      lab pose (4×4, m). work2world: only to report poses in errors (lab convention).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        params: CompliantParams,
        friction: float,
        scenario_name: str,
        start_tool2world: np.ndarray,
        stimulus2world: np.ndarray | None = None,
        carrier: str = "stimulus",
        work2world: np.ndarray | None = None,
        geometry: TacTipGeometry | None = None,
        angular_speed_deg_s: float = 45.0,
    ) -> None:
        if params.finite_sliding and params.edge_within_node:
            raise ValueError("finite_sliding needs whole nodes: edge_within_node off")
        self.model, self.data, self.params = model, data, params
        self.friction = float(friction)
        self.scenario_name = scenario_name
        self.geometry = TacTipGeometry() if geometry is None else geometry
        self.surface = CapSurface(self.geometry, params.spacing, params.extent_deg)
        self.compliance = dome_compliance(self.surface, *params.material)
        self.world2work = np.eye(4) if work2world is None else invert_transform(np.asarray(work2world, float))
        self.stimulus2world = np.eye(4) if stimulus2world is None else np.asarray(stimulus2world, float)
        self.angular_speed = math.radians(angular_speed_deg_s)
        body = model.body(carrier).id
        self._qadr = int(model.jnt_qposadr[model.body_jntadr[body]])
        n = self.surface.count
        self._centre = np.array([0.0, 0.0, self.geometry.sphere_centre_z])
        self._ray_dist = np.zeros(n)
        self._ray_geom = np.zeros(n, np.int32)
        self._ray_normal = np.zeros(3 * n)
        #: each node's lift along the dome's axis onto the flatter apex profile (m), None: the sphere's own
        self._lift = apex_lift(self.surface.points, self.geometry.dome_outer_radius, params.apex_radius)
        #: the sphere through the apex (centre (3,) m, tool frame; radius m) that holds every
        #: node's point of the contact profile: the clearance bound's (`_clearance`)
        self._bound_centre, self._bound_radius = profile_bound(
            self.surface.points, self._centre, self.geometry.dome_outer_radius, self._lift
        )
        #: how far along its ray (m, from the sphere centre) each node's ray is cast: as far as a
        #: gap can be near (candidate_margin and the node's lift) or a face within a disc's reach
        #: (a spacing more), and CAST_SLACK beyond
        self._cast_length = np.full(
            n, self.geometry.dome_outer_radius + params.candidate_margin + params.spacing + CAST_SLACK
        )
        if self._lift is not None:
            self._cast_length += self._lift
        #: the nodes whose ray the last `_contact_geometry` cast, and each node's ray direction (`_ray_directions`)
        self._cast = np.zeros(n, bool)
        self._dirs = self.surface.normals
        #: each node's rest point on the contact profile (N, 3) m, tool frame (`finite_sliding`)
        self._rest_points = self.surface.points.copy()
        if self._lift is not None:
            self._rest_points[:, 2] += self._lift
        self._through = np.zeros((n, 3))
        #: each node's disc's share on a face that ends within it, where `edge_within_node` (1: whole)
        self._covered = np.ones(n)
        self._cut: CutNodes | None = None
        #: where edges are placed within nodes: each node's neighbours and its discs' rays (`_edge_lattice`)
        self._edge_lattice = _edge_lattice(self.surface) if params.edge_within_node else None
        #: geoms the dome can touch (the scene builds the object without collision when `contact` is off)
        self._collidable = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
        self._bounded = np.flatnonzero(self._collidable)
        self._unbounded = bool(np.any(model.geom_type[self._bounded] == mujoco.mjtGeom.mjGEOM_PLANE))
        #: the collidable pieces' closest points to the nodes (`finite_sliding`)
        self._closest = ClosestPoints(model, self._bounded) if params.finite_sliding else None
        #: where the dome's sphere centre was (lab frame, m) when it was last found farther than
        #: candidate_margin + `_reach` (m) from the object; increments within `_reach` of it skip the rays
        self._clear_centre: np.ndarray | None = None
        self._reach = 0.0
        self.forces = np.zeros((n, 3))  # N on the dome, tool frame
        #: the increment before, from which a straight move's next one is extrapolated
        self._before: _LastIncrement | None = None
        self.displacement = np.zeros((n, 3))  # m, tool frame
        self._local: _LocalMatrix | None = None  # `_local_matrix`'s last
        self.rest_pins = self.geometry.pin_tip_points()
        self._pins = self.rest_pins.copy()
        self._steps = 0
        self._since_frame = 0
        self.time = 0.0
        self.step_seconds = 0.0  # wall time in increments (s), for benchmarks
        self.solve_seconds = 0.0  # of which in the contact solver (s)
        self.iterations = 0  # solver iterations, all increments
        self.solves = 0  # contact problems solved, all increments
        self.skipped = 0  # increments proven out of the object's reach, no rays cast
        #: with `finite_sliding`, increments settled where the contact set switches (FINITE_SLIDING_SWITCH)
        self.contact_switches = 0
        self.switch_drift = 0.0  # m, the farthest the solve taken at such a switch still moved the points
        #: with `finite_sliding`, increments settled as the last solve's displacement left the contact problem as it was
        self.geometry_kept = 0
        self._commanded = np.asarray(start_tool2world, float)
        self._at = self._commanded  # the pose of the increment being solved (named in errors)
        self._object2tool = self._object_pose(self._commanded)
        self._increment(self._object2tool)

    # ------------------------------------------------------------------ motion
    def move(self, target_tool2world: np.ndarray, speed_mm_s: float) -> int:
        """Move the tool frame to `target_tool2world` (4×4, m) along a straight line (the
        orientation slerped), solving the contact at every increment; returns how many."""
        if not speed_mm_s > 0:
            raise PhysicsError(f"[{self.scenario_name}] move speed must be > 0 mm/s, got {speed_mm_s}")
        p = self.params
        target = np.asarray(target_tool2world, float)
        start = self._commanded
        delta = target[:3, 3] - start[:3, 3]
        rotvec = Rotation.from_matrix(start[:3, :3].T @ target[:3, :3]).as_rotvec()
        distance, angle = float(np.linalg.norm(delta)), float(np.linalg.norm(rotvec))
        n = max(1, math.ceil(distance / p.step_length - 1e-9), math.ceil(math.degrees(angle) / p.step_angle_deg - 1e-9))
        duration = max(distance / (speed_mm_s * 1e-3), angle / self.angular_speed)
        for k in range(1, n + 1):
            s = k / n
            turned = start[:3, :3] @ Rotation.from_rotvec(rotvec * s).as_matrix() if angle else start[:3, :3]
            self._at = make_transform(turned, start[:3, 3] + delta * s)
            self.time += duration / n
            if self._out_of_reach(self._at):
                continue
            self._increment(self._object_pose(self._at))
        self._commanded = target
        return n

    def settle(self) -> Frame:
        """The frame at the current pose: every increment ends in equilibrium."""
        force = self.contact_force_tool()
        frame = Frame(
            pins_tool=self._pins.copy(),
            time=self.time,
            contact_force=float(np.linalg.norm(force)),
            contact_force_tool=force,
            n_steps=self._since_frame,
            settled=True,
            tool2world=self._commanded.copy(),
            settle_steps=0,
            last_motion_px=0.0,
        )
        self._since_frame = 0
        return frame

    def converged_pins(self, settle_px: float | None = None, max_steps: int = 0) -> np.ndarray:
        """(127, 3) m: the current frame's pins — already the converged equilibrium."""
        return self._pins.copy()

    @property
    def steps(self) -> int:
        """Contact increments taken."""
        return self._steps

    def touched_geoms(self) -> set[int]:
        """Ids of the object's collision pieces that carry contact force now."""
        touching = np.any(self.forces != 0.0, axis=1)
        return set(self._ray_geom[touching].tolist())

    def contact_force_tool(self) -> np.ndarray:
        """(3,) N: total contact force on the dome, tool frame."""
        return self.forces.sum(axis=0)

    # ------------------------------------------------------------------ internals
    def _object_pose(self, tool2world: np.ndarray) -> np.ndarray:
        return invert_transform(tool2world) @ self.stimulus2world

    def _contact_geometry(
        self, object2tool: np.ndarray, through: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each node's rigid gap to the object (N,) m, measured along the object's surface
        normal where the node's normal ray hits it (inf: no hit, or no ray cast), and its
        contact frame (N, 3, 3): rows (c, t1, t2), c the object's inward normal (from the
        dome into the object), t1, t2 the object's tangent plane. The object's normal, not
        the dome's, is the direction of non-penetration: a slide along a flat then changes
        no gap. Nodes farther than candidate_margin along their ray keep the ray distance.
        Only the rays that can meet a piece's bounding box within `_cast_length` are cast,
        and those of loaded nodes: a node beyond that cannot enter the contact problem or
        be reached by its place among the edges (`_uncast_reached` covers what the solve
        moves towards the object). With `finite_sliding` the nodes are where `through`
        (N, 3) m displaces them (None: the last increment's displacement): their rays go
        through those points and their gaps are to the object's closest points
        (`_closest_points`)."""
        gaps, frames = np.full(self.surface.count, np.inf), self.surface.frames.copy()
        self._ray_dist[:] = -1.0
        self._ray_geom[:] = -1
        if not self._collidable.any():  # no `contact` effect: the object has no collision pieces
            self._cast[:] = True
            return gaps, frames
        d = self.data
        d.qpos[self._qadr : self._qadr + 3] = object2tool[:3, 3]
        # MuJoCo's own conversion into its qpos (w first): scipy's, through matrix_to_quat_wxyz,
        # cost 0.15 ms of each increment's ~2
        mujoco.mju_mat2Quat(d.qpos[self._qadr + 3 : self._qadr + 7], object2tool[:3, :3].ravel())
        mujoco.mj_kinematics(self.model, d)
        through = self.displacement if through is None else through
        self._dirs, self._through = self._ray_directions(through), through
        nodes = rays_into_boxes(self.model, d, self._centre, self._dirs, self._cast_length, -1)
        nodes = np.union1d(nodes, np.flatnonzero(np.any(self.forces != 0.0, axis=1)))
        self._cast[:] = False
        self._cast[nodes] = True
        self._cast_rays(nodes, gaps, frames)
        if self.params.edge_within_node:
            self._place_edges(gaps, frames)
        return gaps, frames

    def _ray_directions(self, through: np.ndarray) -> np.ndarray:
        """(N, 3) unit: each node's ray from the sphere centre, through its rest point, or
        with `finite_sliding` through its point displaced by `through` (N, 3) m along the
        surface (a displacement along its normal keeps the direction)."""
        if not self.params.finite_sliding:
            return self.surface.normals
        n, u = self.surface.normals, through
        through = self.geometry.dome_outer_radius * n + u - np.einsum("ij,ij->i", u, n)[:, None] * n
        return through / np.linalg.norm(through, axis=1)[:, None]

    def _cast_rays(self, nodes: np.ndarray, gaps: np.ndarray, frames: np.ndarray) -> None:
        """Cast the normal rays of `nodes` (k,) at the object where `_contact_geometry` posed
        it: their hits in `_ray_dist`, `_ray_geom`, `_ray_normal`, their gaps and contact
        frames in `gaps` (N,) and `frames` (N, 3, 3), in place."""
        if not len(nodes):
            return
        r = self.geometry.dome_outer_radius
        dist, geom, normal = np.empty(len(nodes)), np.empty(len(nodes), np.int32), np.empty(3 * len(nodes))
        mujoco.mj_multiRay(
            self.model,
            self.data,
            self._centre,
            np.ascontiguousarray(self._dirs[nodes].ravel()),
            None,
            1,
            -1,
            geom,
            dist,
            normal,
            len(nodes),
            3.0 * r,
        )
        self._ray_dist[nodes], self._ray_geom[nodes] = dist, geom
        self._ray_normal.reshape(-1, 3)[nodes] = normal.reshape(-1, 3)
        seen = (dist >= 0.0) & self._collidable[geom]
        hit = nodes[seen]
        normals, dirs = self.surface.normals[hit], self._dirs[hit]
        c = -normal.reshape(-1, 3)[seen]
        c *= np.sign(np.einsum("ij,ij->i", c, dirs))[:, None]  # into the object, whichever way the face was hit
        frames[hit] = contact_frames(c, frames[hit, 1])
        along_ray = dist[seen] - r
        # The distance to the face's plane is the gap only near the hit point: a ray that
        # grazes a face far away (an edge's side wall seen past the edge) is not a contact.
        margin = self.params.candidate_margin
        # the face's distance from the rest point along c (the ray's hit point less the rest point)
        c_normal = np.einsum("ij,ij->i", c, normals)
        if self.params.finite_sliding:
            normal_gap = dist[seen] * np.einsum("ij,ij->i", c, dirs) - r * c_normal
        else:  # the ray through the rest point: the same, with one product less
            normal_gap = along_ray * c_normal
        if self._lift is None:
            near = along_ray < margin
        else:
            # a node lifted along the axis (z) comes nearer a face by the lift's part along its normal
            lift = self._lift[hit]
            normal_gap -= lift * c[:, 2]
            near = (along_ray < margin + lift) & (normal_gap < margin)
        gaps[hit] = np.where(near, normal_gap, along_ray)
        if self.params.finite_sliding:
            self._closest_points(nodes, gaps, frames)

    def _closest_points(self, nodes: np.ndarray, gaps: np.ndarray, frames: np.ndarray) -> None:
        """With `finite_sliding`: the gaps and contact frames of `nodes` (k,) where their
        displaced points are, in place. Each node's rest point on the profile, moved by
        `_through`, is drawn back CLOSEST_SETBACK along its outward normal (out of the object
        however deep the increment pressed it) and projected onto the nearest piece; the
        projection's direction is the contact normal c and the tangent plane there is the
        node's face: g = c·(projection − rest point). Projection onto a convex piece is
        continuous, so a node dragged round an edge meets the edge's round, then its wall,
        without the jump of a ray's hit. Nodes no piece is within reach of keep their ray's
        gap and frame."""
        if not len(nodes) or not len(self._bounded):
            return
        rest = self._rest_points[nodes]
        setback = rest + self._through[nodes] - CLOSEST_SETBACK * self.surface.normals[nodes]
        reach = self.params.candidate_margin + self.params.spacing + CAST_SLACK + CLOSEST_SETBACK
        distance, closest, inward = self._closest(self.data, setback, reach)
        found = np.flatnonzero(np.isfinite(distance) & (distance > 0.0))  # not inside a piece
        c = inward[found]
        node = nodes[found]
        frames[node] = contact_frames(c, frames[node, 1])
        gaps[node] = np.einsum("ij,ij->i", c, closest[found] - rest[found])

    def _uncast_reached(self, displacement: np.ndarray, gaps: np.ndarray, frames: np.ndarray) -> None:
        """Cast the rays `_contact_geometry` left out where the solve's `displacement` (N, 3)
        m moves a node farther than their length could rule out: its gap, for the check
        against penetration, is then measured as any other (`gaps`, `frames` in place)."""
        reached = ~self._cast & (
            np.linalg.norm(displacement, axis=1) >= self._cast_length - self.geometry.dome_outer_radius
        )
        if reached.any():
            nodes = np.flatnonzero(reached)
            self._cast[nodes] = True
            self._cast_rays(nodes, gaps, frames)

    def _place_edges(self, gaps: np.ndarray, frames: np.ndarray) -> None:
        """Where a face's boundary crosses a node's disc, give the node the part on the face
        (twin.world.dome.compliant.cut_nodes): its gap and contact frame (in `gaps` and
        `frames`, in place), its covered share (`_covered`) and the centroid the pins take its
        force at (`_cut`), from the centre rays `_contact_geometry` cast."""
        self._covered[:] = 1.0
        self._cut = None
        p = self.params
        near = gaps < p.candidate_margin
        if not near.any():
            return
        reach = p.candidate_margin + p.spacing
        # the centre rays that see a face within reach, facing it, and that face's normal
        hit = (self._ray_dist >= 0.0) & self._collidable[self._ray_geom]
        along_ray = self._ray_dist[hit] - self.geometry.dome_outer_radius
        inward = frames[hit, 0]
        normals = np.zeros((len(gaps), 3))
        normals[hit] = inward
        on_face = np.zeros(len(gaps), bool)
        on_face[hit] = (along_ray < reach) & (
            np.einsum("ij,ij->i", inward, self.surface.normals[hit]) > math.cos(math.radians(FACING_DEG))
        )
        indptr, indices, rays = self._edge_lattice
        sampled = boundary_nodes(indptr, indices, gaps, on_face, normals, p.candidate_margin)
        nodes = np.flatnonzero(sampled)
        if not len(nodes):
            return
        directions = rays[nodes]
        count = directions.shape[0] * directions.shape[1]
        geom, dist, normal = np.full(count, -1, np.int32), np.full(count, -1.0), np.zeros((count, 3))
        # a sample counts only where its ray meets a face within reach (cut_nodes): cast no other
        radius = self.geometry.dome_outer_radius
        flat = directions.reshape(-1, 3)
        cast = rays_into_boxes(self.model, self.data, self._centre, flat, radius + reach + CAST_SLACK, -1)
        if len(cast):
            cast_geom, cast_dist, cast_normal = (
                np.empty(len(cast), np.int32),
                np.empty(len(cast)),
                np.empty(3 * len(cast)),
            )
            mujoco.mj_multiRay(
                self.model,
                self.data,
                self._centre,
                np.ascontiguousarray(flat[cast].ravel()),
                None,
                1,
                -1,
                cast_geom,
                cast_dist,
                cast_normal,
                len(cast),
                3.0 * radius,
            )
            geom[cast], dist[cast], normal[cast] = cast_geom, cast_dist, cast_normal.reshape(-1, 3)
        shape = directions.shape[:2]
        sample_hit = ((dist >= 0.0) & self._collidable[geom]).reshape(shape)
        along = (dist - radius).reshape(shape)
        lift = None if self._lift is None else self._lift[nodes]
        cut = cut_nodes(
            nodes, directions, sample_hit, along, normal.reshape(*shape, 3), geom.reshape(shape), lift, reach
        )
        if not len(cut.nodes):
            return
        gaps[cut.nodes] = cut.gaps
        frames[cut.nodes] = contact_frames(cut.normals, self.surface.frames[cut.nodes, 1])
        self._ray_geom[cut.nodes] = cut.geoms
        self._covered[cut.nodes] = cut.covered
        self._cut = cut

    def _clearance(self) -> float:
        """A lower bound (m) on the distance from the contact profile's bounding sphere
        (`profile_bound`; the dome's outer sphere where the profile is its own) to the
        object at the pose `_contact_geometry` last set: each collidable piece's distance
        to the sphere's centre is at least that of its bounding box (inf: nothing
        collidable, −inf: an unbounded plane). Every node's gap along its ray is at least
        as long."""
        if not len(self._bounded):
            return math.inf
        if self._unbounded:
            return -math.inf
        d = self.data
        box = self.model.geom_aabb[self._bounded]  # centre (3) and half sizes (3), geom frame
        rel = self._bound_centre - d.geom_xpos[self._bounded]
        local = np.einsum("gji,gj->gi", d.geom_xmat[self._bounded].reshape(-1, 3, 3), rel) - box[:, :3]
        outside = np.maximum(np.abs(local) - box[:, 3:], 0.0)
        return float(np.linalg.norm(outside, axis=1).min()) - self._bound_radius

    def _out_of_reach(self, tool2world: np.ndarray) -> bool:
        """True, counted as an increment, where the dome at `tool2world` (4×4, m) is
        certainly out of contact: it carried no load where last found clear and its sphere's
        centre has since moved less than that clearance beyond candidate_margin. The sphere
        turns about its centre, so its distance to the object changes by at most the
        centre's motion; such an increment would find no node within candidate_margin and
        leave the dome at rest, as it is."""
        if self._clear_centre is None:
            return False
        if np.linalg.norm(self._sphere_centre(tool2world) - self._clear_centre) >= self._reach:
            return False
        self._steps += 1
        self._since_frame += 1
        self.skipped += 1
        self._object2tool = self._object_pose(tool2world)
        return True

    def _sphere_centre(self, tool2world: np.ndarray) -> np.ndarray:
        """(3,) m: the clearance bound's sphere centre in the lab frame with the tool at `tool2world`."""
        return tool2world[:3, :3] @ self._bound_centre + tool2world[:3, 3]

    def _increment(self, object2tool: np.ndarray) -> None:
        t0 = time.perf_counter()
        self._steps += 1
        self._since_frame += 1
        self._clear_centre = None
        p = self.params
        shift = object2tool @ invert_transform(self._object2tool)  # the object's motion since the last increment
        self._object2tool = object2tool.copy()
        loaded = np.flatnonzero(np.any(self.forces != 0.0, axis=1))
        points = self.surface.points + self.displacement
        moved = points @ shift[:3, :3].T + shift[:3, 3] - points  # the object's displacement at each node (tool)
        through, resolved = self._predicted_through(shift), None
        gaps, frames, candidates = self._measured(object2tool, through, loaded)
        halving_from, last_drift = None, math.inf
        closest: tuple = (math.inf,)  # the solve whose displacement came nearest the points it was measured at
        for sweep in range(FINITE_SLIDING_SWEEPS if p.finite_sliding else 1):
            if not len(candidates):
                self.forces[:] = 0.0
                self._before = None
                self.displacement[:] = 0.0
                self._pins = self.rest_pins.copy()
                reach = self._clearance() - p.candidate_margin
                if reach > 0.0:
                    self._clear_centre, self._reach = self._sphere_centre(self._at), reach
                self.step_seconds += time.perf_counter() - t0
                return
            candidates, forces, displacement, after = self._solve(candidates, gaps, frames, moved, shift, resolved)
            if not p.finite_sliding:
                break
            resolved = (candidates, forces)
            cast = self._cast
            drift = float(np.max(np.linalg.norm(displacement[cast] - through[cast], axis=1), initial=0.0))
            if drift <= FINITE_SLIDING_TOLERANCE:
                break
            if drift < closest[0]:
                closest = (drift, candidates, forces, displacement, after)
            # the step taken towards the new points: whole, then halved each solve once the
            # drift stops shrinking (or after FINITE_SLIDING_FREE_SWEEPS), so that where the
            # points cycle (a node in and out of contact at an edge) they settle where the
            # contact set switches
            if halving_from is None and (drift >= last_drift or sweep >= FINITE_SLIDING_FREE_SWEEPS):
                halving_from = sweep
            relax = 1.0 if halving_from is None else 0.5 ** (sweep + 1 - halving_from)
            last_drift = drift
            if relax * drift <= FINITE_SLIDING_TOLERANCE:
                # the points have stopped at a switch of the contact set: the increment takes
                # the solve that came nearest its points, the last or (where a node is thrown
                # to and fro over a sharp edge) an earlier one
                drift, candidates, forces, displacement, after = closest
                if drift > FINITE_SLIDING_SWITCH * p.spacing:
                    self._fail_unsettled(drift, sweep + 1)
                self.contact_switches += 1
                self.switch_drift = max(self.switch_drift, drift)
                break
            through = through + relax * (displacement - through)
            measured = self._measured(object2tool, through, loaded)
            if relax == 1.0 and self._same_contact(candidates, gaps, frames, *measured):
                self.geometry_kept += 1
                break
            gaps, frames, candidates = measured
        else:
            self._fail_unsettled(drift, FINITE_SLIDING_SWEEPS)
        self._before = _LastIncrement(self.forces, candidates, shift, self.displacement)
        self.forces = np.zeros_like(self.forces)
        self.forces[candidates] = forces
        self.displacement = displacement
        self._pins = self.rest_pins + self.compliance.pin_displacement(*self._pin_loads(candidates, forces), p.tip_sway)
        self.step_seconds += time.perf_counter() - t0
        self._check(after)

    def _measured(
        self, object2tool: np.ndarray, through: np.ndarray, loaded: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The nodes' gaps (N,) m and contact frames (N, 3, 3) with the object at
        `object2tool` (4×4) and the nodes displaced by `through` (N, 3) m
        (`_contact_geometry`), and the contact problem's candidates: the nodes within
        candidate_margin and the `loaded` ones, where the object is still in sight."""
        gaps, frames = self._contact_geometry(object2tool, through)
        reach = 0.5 * self.geometry.dome_outer_radius
        depth = gaps
        if self.params.finite_sliding:
            carried = np.linalg.norm(through, axis=1)
            node = int(np.argmax(carried))
            if carried[node] > reach:
                self._fail(
                    f"a skin node carried {carried[node] * 1e3:.2f} mm by the object (friction holds it where "
                    f"the object drags it): farther than the dome model reaches ({reach * 1e3:.0f} mm); a sharp "
                    "edge can hook the skin so where a rounded one lets it slip (object edge_radius_mm)"
                )
            depth = gaps_at_displaced_points(gaps, frames, through)
        if np.min(depth) < -reach:
            self._fail(
                f"indentation {-np.min(depth) * 1e3:.2f} mm: deeper than the dome model reaches ({reach * 1e3:.0f} mm)"
            )
        candidates = np.union1d(np.flatnonzero(gaps < self.params.candidate_margin), loaded)
        candidates = candidates[np.isfinite(gaps[candidates])]  # a node the object left carries nothing
        return gaps, frames, candidates

    def _same_contact(
        self,
        solved: np.ndarray,
        gaps: np.ndarray,
        frames: np.ndarray,
        new_gaps: np.ndarray,
        new_frames: np.ndarray,
        candidates: np.ndarray,
    ) -> bool:
        """With finite sliding: whether the contact problem measured where the last solve
        displaced the nodes (`new_gaps`, `new_frames`, its `candidates`) is the one solved
        on `solved` (gaps, frames): no other candidate, every gap within the solver's
        tolerance and every frame turned by less than it over the dome's radius. A solve
        of it would then return the last one's forces, so the increment is settled without
        it: where the nodes slide over one face of the object, only where they meet it
        along the face changes (a press on the edge's top: 1 solve where 2 were taken)."""
        if len(np.setdiff1d(candidates, solved, assume_unique=True)):
            return False
        moved_gap = np.abs(new_gaps[solved] - gaps[solved])
        if not np.all(moved_gap <= self.params.tolerance):  # an infinite gap: the node left the object
            return False
        turned = np.abs(new_frames[solved] - frames[solved]).max(initial=0.0)
        return bool(turned <= self.params.tolerance / self.geometry.dome_outer_radius)

    def _predicted_through(self, shift: np.ndarray) -> np.ndarray:
        """(N, 3) m: where finite sliding first measures the nodes' gaps in the increment
        with the object's motion `shift` (4×4): where the last increment left them, or,
        where the object moves as it did over the last increment (a straight move), that
        displacement extrapolated linearly, which the increment's solve then confirms
        without a second one more often."""
        if self.params.finite_sliding and self._straight_move(shift):
            return 2.0 * self.displacement - self._before.displacement
        return self.displacement

    def _straight_move(self, shift: np.ndarray) -> bool:
        """Whether the object's motion `shift` (4×4) over this increment is the one over the
        increment before (a straight move)."""
        return self._before is not None and np.abs(self._before.shift - shift).max() <= 1e-12

    def _solve(
        self,
        candidates: np.ndarray,
        gaps: np.ndarray,
        frames: np.ndarray,
        moved: np.ndarray,
        shift: np.ndarray,
        resolved: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Solve the increment's contact problem on `candidates` (k,), adding any node found
        penetrating after a solve: the nodes solved, their forces (N, tool frame), every
        node's displacement (N, 3) m and gap after it (N,) m (`gaps`, `frames` as
        `_contact_geometry` gives them; `moved` (N, 3) m the object's displacement at each
        node, `shift` its motion 4×4 since the last increment; `resolved` the nodes and forces
        of the increment's last solve when finite sliding re-solves it, see `_warm_start`)."""
        p = self.params
        for _ in range(10):
            t1 = time.perf_counter()
            f = frames[candidates]
            local = self._local_matrix(candidates, f)
            previous = np.einsum("nij,nj->ni", f[:, 1:], self.displacement[candidates])
            shift_t = np.einsum("nij,nj->ni", f[:, 1:], moved[candidates])
            begin = self._warm_start(candidates, shift, resolved)
            start = np.einsum("nij,nj->ni", f, begin)
            try:
                solution = solve_increment(
                    local,
                    gaps[candidates],
                    previous,
                    shift_t,
                    self.friction,
                    -start[:, 0],
                    start[:, 1:],
                    p.tolerance,
                    p.max_iterations,
                    self._adhesion(candidates),
                    self._edge_friction(f),
                )
            except ContactNotConverged as err:
                self._fail(f"contact solve did not converge ({len(candidates)} nodes, μ = {self.friction:g}): {err}")
            self.solve_seconds += time.perf_counter() - t1
            self.iterations += solution.iterations
            self.solves += 1
            forces = np.einsum("ni,nij->nj", solution.forces, f)  # tool frame
            displacement = self.compliance.surface_displacement(candidates, forces, p.tip_sway)
            self._add_partial_displacement(displacement, candidates, f, solution.forces)
            self._uncast_reached(displacement, gaps, frames)
            after = gaps_at_displaced_points(gaps, frames, displacement)
            penetrating = after < -p.max_penetration
            penetrating[candidates] = False
            outside = np.flatnonzero(penetrating)
            if not len(outside):
                return candidates, forces, displacement, after
            candidates = np.union1d(candidates, outside)
        self._fail("the contact set did not settle within 10 re-solves")

    def _edge_friction(self, frames: np.ndarray) -> np.ndarray | None:
        """(m, 2, 2): each node's friction ellipse in its (t1, t2) (`solve_increment`'s
        `anisotropy`), `edge_friction` across the edge's round where the object's inward
        normal turns from its top's by more than EDGE_TILT_DEG, the identity elsewhere; None
        at `edge_friction` 1 or without friction (`edge_friction_ellipses`)."""
        ratio = self.params.edge_friction
        if ratio == 1.0 or not self.friction:
            return None
        return edge_friction_ellipses(frames, self._object_pose(self._at)[:3, 2], ratio)

    def _adhesion(self, nodes: np.ndarray) -> np.ndarray | None:
        """(m, 2) N: the adhesive strength and ramp of `nodes` (`friction_bound`), over the
        part of each one's area on the object (a cut node's covered share); None without
        adhesion or without friction."""
        if not self.params.adhesion or not self.friction:
            return None
        area = self.surface.area * self._covered[nodes]
        return np.column_stack([self.params.adhesion * area, ADHESION_RAMP * area])

    def _warm_start(
        self, candidates: np.ndarray, shift: np.ndarray, resolved: tuple[np.ndarray, np.ndarray] | None = None
    ) -> np.ndarray:
        """(m, 3) N, tool frame: where the solver starts at `candidates`. A re-solve of the
        same increment (finite sliding; `resolved` the nodes and forces of its last solve)
        starts from that solve's forces, zero at nodes it did not hold (10,990 → 5,636 Newton
        iterations on every 20th DigiTac tap). Otherwise the last increment's forces; where the
        same nodes carry contact and the object moves as it did over the last increment (a
        straight move), their linear extrapolation, which takes Newton to the same solution in
        fewer iterations while friction builds up (128 → 106 iterations on `twin bench
        physics`'s path)."""
        if resolved is not None:
            nodes, forces = resolved
            begin = np.zeros((len(candidates), 3))
            _, here, there = np.intersect1d(candidates, nodes, assume_unique=True, return_indices=True)
            begin[here] = forces[there]
            return begin
        if self._straight_move(shift) and np.array_equal(self._before.candidates, candidates):
            return 2.0 * self.forces[candidates] - self._before.forces[candidates]
        return self.forces[candidates]

    def _add_partial_displacement(
        self, displacement: np.ndarray, nodes: np.ndarray, frames: np.ndarray, local_forces: np.ndarray
    ) -> None:
        """Add to `displacement` (N, 3) m, tool frame, what the cut ones among `nodes` yield
        more under their forces (m, 3) N in their contact frames (m, 3, 3), as the smaller
        discs they press with: `_local_matrix`'s `partial_disc_compliance`."""
        cut = self._covered[nodes] < 1.0
        if cut.any():
            extra = self._local.partial[cut] * local_forces[cut]
            displacement[nodes[cut]] += np.einsum("ni,nij->nj", extra, frames[cut])

    def _pin_loads(self, nodes: np.ndarray, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nodes and forces (N, tool frame) the pins take: a cut node's force moved to
        the centroid of its part on the face, shared among the lattice's nodes there by
        linear interpolation (CapSurface.interpolation)."""
        cut = self._cut
        if cut is None:
            return nodes, forces
        moved = self._covered[nodes] < 1.0
        if not moved.any():
            return nodes, forces
        order = np.searchsorted(cut.nodes, nodes[moved])
        corners, weights = self.surface.interpolation(cut.centroids[order], cut.nodes[order])
        shared = (weights[..., None] * forces[moved][:, None, :]).reshape(-1, 3)
        return np.concatenate([nodes[~moved], corners.ravel()]), np.concatenate([forces[~moved], shared])

    def _local_matrix(self, nodes: np.ndarray, frames: np.ndarray) -> np.ndarray:
        """(3m, 3m) m/N: the compliance among `nodes` in their contact frames (m, 3, 3), as
        the contact solve's unknowns see it (`unknowns_matrix`), a cut node's own term
        raised as for the part of its disc on the face (`partial_disc_compliance`, kept in
        `_local` for `_add_partial_displacement`). Kept while the nodes, their frames and
        their covered shares stay the same, as on a slide over one face (on the sweep
        probe's slides across and along the edge, 132 of 340 solves kept it). Otherwise
        only the entries of nodes new to the set or in another frame are turned anew
        (`local_block`'s `kept`): finite sliding moves the frames of a few nodes on the
        edge's round each solve, a growing contact adds a ring of nodes."""
        kept = self._local
        covered = self._covered[nodes]
        if (
            kept is not None
            and np.array_equal(kept.nodes, nodes)
            and np.array_equal(kept.frames, frames)
            and np.array_equal(kept.covered, covered)
        ):
            return kept.matrix
        sway = self.params.tip_sway
        earlier = None if kept is None else (kept.nodes, kept.frames, kept.turned)
        turned = self.compliance.local_block(nodes, frames, sway, UNKNOWN_SIGNS, earlier)
        local, extra = turned, np.zeros((len(nodes), 3))
        if (covered < 1.0).any():
            # each node's self-compliance in its frame, m/N, without the tip's sway (a diagonal keeps its sign)
            own = np.diagonal(turned).reshape(-1, 3) - sway * np.einsum(
                "nak,nak->na", frames[:, :, :2], frames[:, :, :2]
            )
            extra = partial_disc_compliance(covered, own)
            local = turned.copy()
            local[np.diag_indices_from(local)] += extra.ravel()
        self._local = _LocalMatrix(nodes.copy(), frames.copy(), covered, local, extra, turned)
        return local

    def _check(self, gaps_after: np.ndarray) -> None:
        p = self.params
        if not (np.isfinite(self.forces).all() and np.isfinite(self._pins).all()):
            self._fail("NaN/Inf in the contact forces or pin tips")
        depth = -float(np.min(gaps_after[np.isfinite(gaps_after)], initial=0.0))
        if depth > p.max_penetration:
            self._fail(f"penetration {depth * 1e6:.2f} µm after the contact solve (> {p.max_penetration * 1e6:.2f} µm)")
        if self.forces[self.surface.rim].any():
            self._fail(f"the contact reaches the rim of the modelled {p.extent_deg:g}° cap")
        total = float(np.linalg.norm(self.contact_force_tool()))
        if total > p.max_force:
            self._fail(f"contact force {total:.3g} N > {p.max_force:.3g} N")
        moved = np.linalg.norm(self._pins - self.rest_pins, axis=1).max()
        if moved > p.max_pin_excursion:
            self._fail(f"a pin moved {moved * 1e3:.3f} mm from rest (> {p.max_pin_excursion * 1e3:.3f} mm)")

    def _fail_unsettled(self, drift: float, solves: int) -> None:
        """Raise: finite sliding's points still `drift` (m) from where the last of `solves` put them."""
        self._fail(
            f"finite sliding: the nodes' points still moved {drift * 1e6:.2f} µm after {solves} "
            f"solves (at most {FINITE_SLIDING_SWITCH * self.params.spacing * 1e6:.0f} µm, half a node spacing, "
            "where the contact set switches)"
        )

    def _fail(self, what: str) -> None:
        raise physics_error(self.scenario_name, f"increment {self._steps}", self.time, self.world2work, self._at, what)


def gaps_at_displaced_points(gaps: np.ndarray, frames: np.ndarray, through: np.ndarray) -> np.ndarray:
    """(N,) m: each node's gap where `through` (N, 3) m has displaced it, from its gap
    measured from its rest point along its contact normal (`gaps`, (N,) m; frames (N, 3, 3)
    with rows (c, t1, t2)): g − c · u, the contact problem's gap after deformation. With
    finite sliding a node carried along the object by friction has a rest-point gap as
    large as how far it was carried and a displaced one of about 0."""
    return gaps - np.einsum("ij,ij->i", frames[:, 0], through)


@compiled
def contact_frames(normals: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(k, 3, 3): contact frames with rows (c, t1, t2) from the unit normals c (k, 3) and
    reference directions (k, 3): t1 the reference's part in the tangent plane, made unit,
    t2 = c × t1."""
    frames = np.empty((len(normals), 3, 3))
    for k in range(len(normals)):
        c, x = normals[k], reference[k]
        along = x[0] * c[0] + x[1] * c[1] + x[2] * c[2]
        t = x - along * c
        t /= math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
        frames[k, 0] = c
        frames[k, 1] = t
        frames[k, 2, 0] = c[1] * t[2] - c[2] * t[1]
        frames[k, 2, 1] = c[2] * t[0] - c[0] * t[2]
        frames[k, 2, 2] = c[0] * t[1] - c[1] * t[0]
    return frames


def edge_friction_ellipses(frames: np.ndarray, top: np.ndarray, ratio: float) -> np.ndarray:
    """(k, 2, 2): the friction ellipses of nodes in contact frames (k, 3, 3) (rows c, t1, t2;
    c the object's inward normal) on an object whose top faces along `top` (3,), the object's
    z axis in the same frame. Where c turns from the top's normal by more than EDGE_TILT_DEG
    (an edge's round, a wall), `ratio` along the top's normal as the tangent plane holds it
    (up the slope: across the round, up a wall) and 1 along the edge; the identity elsewhere."""
    up_slope = np.einsum("kij,j->ki", frames[:, 1:], top)  # |.| = the sine of the turn
    size = np.linalg.norm(up_slope, axis=1)
    tilted = size > math.sin(math.radians(EDGE_TILT_DEG))
    up_slope = up_slope / np.where(tilted, size, 1.0)[:, None]
    return np.eye(2) + (ratio - 1.0) * tilted[:, None, None] * np.einsum("ki,kj->kij", up_slope, up_slope)


@lru_cache(maxsize=8)
def _edge_lattice(surface: CapSurface) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What placing edges within nodes needs of a lattice, once per lattice in a process: each
    node's neighbours within 1.6 spacings (a disc's radius, 0.53 spacings, plus the
    lattice's widest gap), each its own too, as a CSR pattern (indptr (N + 1,), indices),
    and the unit rays from the dome's sphere centre through each node's disc samples (N, S,
    3) (twin.world.dome.compliant.cut_nodes.sample_directions)."""
    points = surface.points
    pairs = cKDTree(points).query_pairs(1.6 * surface.spacing, output_type="ndarray")
    n = len(points)
    rows = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(n)])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(n)])
    pattern = sparse.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    centre = np.array([0.0, 0.0, surface.geometry.sphere_centre_z])
    rays = sample_directions(points, surface.tangents, centre, math.sqrt(surface.area / math.pi))
    return pattern.indptr, pattern.indices, rays


def apex_lift(points: np.ndarray, dome_radius: float, apex_radius: float) -> np.ndarray | None:
    """(N,) m: how far each outer node (N, 3) m, tool frame, the dome's centre on the z axis
    and its apex towards +z) rises along the axis onto a sphere of `apex_radius` (m) through
    the apex: the flatter profile's sag is smaller than the dome's at the same distance from
    the axis. None where `apex_radius` is not above `dome_radius` (m): the sphere's own gap."""
    if apex_radius <= dome_radius * (1.0 + 1e-9):
        return None
    axis2 = np.minimum(np.einsum("ij,ij->i", points[:, :2], points[:, :2]), dome_radius**2)
    return (dome_radius - np.sqrt(dome_radius**2 - axis2)) - (apex_radius - np.sqrt(apex_radius**2 - axis2))


def profile_bound(
    points: np.ndarray, centre: np.ndarray, dome_radius: float, lift: np.ndarray | None
) -> tuple[np.ndarray, float]:
    """The smallest sphere through the apex, centred on the axis, that holds each node's
    point of the contact profile: the node (N, 3) m on the dome's sphere (`centre` (3,) m,
    `dome_radius` m, apex towards +z) moved `lift` (N,) m further along its ray, where the
    node's gap is measured. Its centre (3,) m and radius (m); the dome's own sphere where
    `lift` is None. A point q is in the sphere of radius h centred h below the apex a where
    |q − a|² ≤ 2h (a − q)_z."""
    if lift is None:
        return centre.copy(), dome_radius
    apex = centre + np.array([0.0, 0.0, dome_radius])
    profile = centre + (points - centre) * (1.0 + lift / dome_radius)[:, None]
    rel = profile - apex
    below = -rel[:, 2]
    away = below > 1e-9 * dome_radius  # the apex itself bounds nothing
    radius = max(dome_radius, float(np.max(np.einsum("ij,ij->i", rel[away], rel[away]) / (2.0 * below[away]))))
    return apex - np.array([0.0, 0.0, radius]), radius


@lru_cache(maxsize=8)
def dome_compliance(
    surface: CapSurface,
    young: float,
    poisson: float,
    enclosed: bool,
    membrane_young: float = 0.0,
    skin_bending: bool = False,
    skin_held_deg: float = 90.0,
    skin_tension: float = 0.0,
    pin_lever: float | None = None,
    bending_young: float | None = None,
    pins_in_gel: bool = False,
    skin_thickening: float = 1.0,
) -> DomeCompliance:
    """The influence matrices for this surface and material, shared within the process
    (the sealed gel's loaded from the cache, or computed, at the first contact). Eight
    are kept (8–218 MB each): `twin bench physics` alternates between five."""
    return DomeCompliance(
        surface,
        young,
        poisson,
        enclosed,
        membrane_young,
        skin_bending,
        skin_held_deg,
        skin_tension,
        pin_lever,
        bending_young,
        pins_in_gel,
        skin_thickening,
    )
