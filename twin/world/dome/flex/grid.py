"""The compliant TacTip dome: a MuJoCo flex with the 127 pin tips as vertices.

Model. The dome is a *solid* hemisphere of gel under the skin, meshed into
tetrahedra whose vertices include the 127 pin tips, and simulated as one 3-D flex with
``dof="trilinear"``: the degrees of freedom live on a coarse background grid of nodes
(``cellcount`` cells, (cx+1)(cy+1)(cz+1) nodes) and every mesh vertex — the pin tips
included — follows by trilinear interpolation. Elasticity is Saint Venant–Kirchhoff
(``young``, ``poisson``) with Rayleigh damping, integrated implicitly by MuJoCo's
``discrete`` integrator (required for flex elasticity) with the Newton solver and an
elliptic friction cone (a pyramidal cone made contacts ≈7× softer). The grid nodes on
the dome's base plane (the equator, where the real skin is clamped to the rigid base)
are pinned to the sensor mount; the collision surface is the outer layer of tetrahedra,
so contacts are resolved on the fine mesh even though deformation lives on the grid.

Contact geometry. The collision surface is the dome shrunk by ``margin`` (0.5 mm) and
MuJoCo's contact margin is the same 0.5 mm, so contacts form, and stay, while the surfaces
are still ``margin`` apart: the skin's true surface touches the object exactly where the
undeformed dome would, but the solver sees each contact before it is reached. Contact
points and normals then come from the *distance* between the separated shapes (smooth
around an edge: the object's edges act as if rounded with a 0.5 mm radius, as real cut
and printed edges are), not from the penetration direction, which jumps between an edge's
two faces (measured: horizontal normals fighting at 150 N at the rectangle's edge, and
contacts lost and regained every step).

Pin tips move with the gel around them (they are interpolated vertices, read by
``pin_tips_tool`` in the tool frame); the grid is too coarse for the skin's local bending
at the border of a contact, which twin.world.dome.flex.skin adds to every settled frame (SensorPhysics).

Frames and units: docs/conventions.md. Tool frame: origin at the undeformed dome apex
(the TCP), +z along the sensor axis out of the tip. All lengths in m, forces in N.

Attaching: ``add_tactip(spec, spec.worldbody, geometry, params, friction)`` adds a
jointless body holding the rigid base and the flex; the physics scene is built in the
tool frame (dome still at the origin, stimuli on ``add_stimulus_carrier``'s body, moved
by twin.world.dome.flex.physics.SensorPhysics — see add_stimulus_carrier for why). ``add_tactip`` also
applies ``configure_options`` (discrete integrator, Newton, elliptic cone, impratio,
viscosity, timestep) to the whole spec; ``apply_contact_law`` (called by SensorPhysics)
gives every contact with the dome the dome's normal contact law.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar

import mujoco
import numpy as np
from scipy.spatial import Delaunay

from twin.core.errors import PhysicsError
from twin.core.poses import invert_transform, make_transform, matrix_to_quat_wxyz, transform_points
from twin.core.sensor import N_PINS, TacTipGeometry

#: Real mass of the dome's gel + skin (kg): a 20 mm-radius hemisphere of ≈1.0 g/cm³ gel.
DOME_REAL_MASS = 0.017


@dataclass(frozen=True)
class DomeParams:
    """Material, contact and numerical parameters of the dome (SI units; settling in px).

    Material
      young (Pa): effective Young's modulus of the skin+gel solid. The real TacTip is an
        Agilus30/Tango-like rubber skin (E ≈ 0.5–1 MPa, 1.5 mm thick) over a very soft
        gel (E ≈ 10–50 kPa); the *effective* solid modulus of the composite is of order
        0.1 MPa. A coarse trilinear grid is stiffer than a continuum (few modes, mild
        volumetric locking), so the value is calibrated per grid to forces, not to a
        datasheet: every fidelity level gives ≈ 4.2–4.3 N for a 4 mm press centred on a
        straight edge (half the dome in contact; default: 1.7 / 4.3 / 7.3 N at 2 / 4 / 6 mm),
        the "a few N at 4 mm" the real sensor shows.
      poisson (–): gel is nearly incompressible, but ν → 0.5 locks a trilinear grid
        (it stiffens and stops bulging); 0.40 keeps the lateral bulge without locking.
      membrane_young (Pa): the skin as a membrane (``membrane_mjcf``): a 2-D flex of
        thickness ``TacTipGeometry.skin_thickness`` stretched over the grid's top node
        layer and clamped where that layer is pinned. The gel alone gives the dome a
        tangential stiffness of the order of its normal one, so friction dragged the
        whole cap along (along-edge slides on PLA, μ 0.7, 3 mm: pins 17–20 px common-mode,
        tap-trained orientation error 48–68° RMS); the real skin is a rubber membrane
        that carries tangential load to the clamped rim. 3e5 Pa (a soft Agilus/Tango
        skin is 0.3–1 MPa): 5–6.5 px, 9–19° (measured, docs/paper.md,
        "How the twin gets there"); 1e6 Pa made a slide's pins oscillate unsettled. The membrane has no
        bending stiffness and lies flat, so it barely stiffens a press (4.3 → 4.7 N at
        4 mm). 0 = gel only.
      damping (s): Rayleigh stiffness-proportional damping β (damping matrix = β·K). It
        damps the dynamics *during moves*: without it the flower's contour blew up (a pin
        13 mm from rest) and, at mass ×10, a slide along an edge tunnelled 2.5 mm into the
        object (measured). Frames are settled quasi-statically, see quasi_static_settle.
      mass_scale (–): the dome's mass is DOME_REAL_MASS × mass_scale. Frames are
        quasi-static, so the mass is a numerical device: MuJoCo's soft contact and friction
        constraints are stiff in proportion to the effective mass they act on, so ×100
        keeps contacts stiff (≈ 0.05 mm beyond the margin at 3 N) and the friction creep
        slow; ×10 let a stuck skin creep 3 px within 400 steps, ×1000 slowed settling.

    Contact (MuJoCo soft constraints; apply_contact_law writes them into the model so they
    hold whichever geom wins MuJoCo's priority mix)
      friction (–): sliding friction coefficient of the skin. The object's geoms get
        priority in twin.world.scene, so the contact μ is the object's (its material). With
        ``add_tactip(..., friction=False)`` the flex gets condim=1 and contact priority 1,
        so contacts are frictionless (no friction rows are even built).
      solref (s, –): contact time constant and damping ratio; MuJoCo raises the time
        constant to 2·timestep (the stable limit), so the effective value is 2·timestep.
      solimp (–, –, m, –, –): impedance d from 0.99 (at the surface) to 0.999 (0.5 mm in).
        The constraint "softness" R ∝ (1 − d)/d sets both how far a loaded contact sinks
        and how fast a stuck skin creeps under shear; 0.999 (vs MuJoCo's default 0.95)
        cut the creep of a sheared skin over 400 steps from 0.8 px to 0.07 px (measured).
      impratio (–): frictional/normal impedance ratio (elliptic cones): makes static
        friction ≈ 30× harder than the normal contact. MuJoCo's noslip post-solver, the
        textbook cure for soft-friction creep, is refused by MuJoCo 4.0 for flexes with
        the discrete integrator ("PGS and noslip not yet supported with flex").
      margin (m): contact margin = inset of the collision surface (module docstring).
        0.5 mm: larger than how far a loaded contact sinks (≈ 0.05–0.1 mm up to 10 N), so
        contacts stay in the smooth "separated" regime; a real 0.2–0.5 mm edge radius.

    Resolution
      surface_spacing (m): spacing of the collision vertices on the outer surface. The
        edge of a box is resolved to about this length.
      cellcount: trilinear background grid (cells along tool x, y, z). 4×4×2 = 10 mm cells
        in a 40 × 40 × 20 mm box; the pin field is as smooth as this grid.
        5×5×2 (young 4.5e4 for the same 4.3 N) is as fast and 0.2 px closer to the
        reference, but a 90° turn of the sensor turned its pin pattern by 60° instead
        of 90° (tests/world/test_dome.py), so 4×4×2 stays the default.
      pin_ghost_nodes: pin the grid nodes in the bounding box's corner columns (outside the
        dome's footprint). Unpinned, they have ~no stiffness and no Rayleigh damping, drift
        and kicked the pins by 0.1–0.3 mm seconds after lift-off (measured).
      viscosity (Pa·s): global MuJoCo fluid viscosity = a mass-like drag on the node
        bodies (the only mass-proportional damping a flex can get; joint damping on flex
        nodes is refused by the compiler); damps moves, doesn't change equilibria.
      solver_iterations, solver_tolerance: Newton solver limits (converges in 1–7
        iterations here).
      skin_spacing (m), skin_extent_deg (deg): the sub-grid skin layer (twin.world.dome.flex.skin): node
        spacing on the outer skin and half-angle of the cap it covers; 0 spacing = off
        (scenario `physics: {skin_spacing_mm: 0}`). At 1.5 mm the layer makes taps readable
        (docs/paper.md, "How the twin gets there") for ≈ 0.5 ms of physics per frame. It swings the
        pins at a contact's border up to 0.7 spacing off their neighbours' motion (measured
        on twin taps and slides); the tracker follows them (twin.sensing.tracker.PinTracker, step 5).
        55° holds a 7 mm press (a contact reaching the cap's outer ring raises PhysicsError).

    Stepping (used by twin.world.dome.flex.physics.SensorPhysics)
      timestep (s): physics step. Moves advance the sensor by speed × timestep per step.
        0.02 s: larger steps (0.03, 0.04 s) made the flower's thin convex pieces (1.1 mm
        slivers) throw the skin into 1–11 px oscillations that never settled (measured).
      quasi_static_settle: while settling (sensor at rest), zero the dome's velocities
        before every step, turning the implicit step into a damped Newton iteration
        towards equilibrium: the mass-scaled dome has no momentum to bounce with, so a
        frame settles in a few steps instead of ringing for 20–50 (the dome's real
        inertia, 17 g, is negligible at robot speeds). Moves keep the velocities: the
        skin stuck to a sliding object must keep moving with it, and resetting them every
        step made friction slip (the shear halved and depended on the timestep).
      jump_clear_moves: carry the objects over the stretches at a move's start and end
        along which no object comes near the dome (twin.world.dome.flex.clearance) instead
        of stepping them: there is nothing to touch, the skin is at rest (start) or springs
        back freely, and the settling after the move finishes that quasi-statically. The
        frames' time still runs at the move's speed. Exact at a clear start; at a clear end
        the settled frame differs from the stepped one by the settling tolerance.

    Settling, in camera pixels (1 px ≈ 75 µm of lateral pin motion: focal ≈ 451 px, pin
    tips 30–42 mm in front of the camera; what the camera cannot see does not matter)
      settle_px (px): a contact frame is settled when over the last `settle_steps` steps
        no pin's image moved more than this. The per-step band is not the distance to
        equilibrium (settling converges geometrically, so the rest of the way is a few
        bands): a frictionless slide ends 9 / 13 / 18 / 80 µm from the static press at
        the same pose at 0.025 / 0.05 / 0.1 / 0.2 px (tests/world/test_dome.py asks < 20 µm),
        and the sweep's settling error (RMS distance of a frame from its converged state)
        is 0.02 / 0.05 / 0.12 px at 0.025 / 0.05 / 0.1 px. 0.1 px: its 0.12 px is below
        the tracker's error on rendered frames and changes neither the pin error against
        the reference (2.14 px) nor the contour error, and it takes 15.8 instead of 18.2
        steps per contour frame (0.05 px; `twin bench physics`). The pin error cannot see
        the settle tolerance: ≈ 2 px of it is the grid's discretisation.
      free_settle_px (px): the same out of contact. Tighter: a no-contact frame is the
        tracker's reference and out of contact the motion decays cleanly to rest.
      settle_steps: the window of that criterion (steps).
      cycle_after, cycle_px: a frame still moving after `cycle_after` steps is accepted if
        its motion stays below `cycle_px`. One contact per tetrahedron means the contact
        point can hop between an element's vertices, so some configurations (the flank
        on an edge) never come to rest but cycle with a fixed amplitude of 0.02–0.1 px
        (measured); that is a settled frame for any camera.
      cycle_relaxation (–): a contact frame still moving beyond `cycle_px` after
        `cycle_after` steps is iterated with under-relaxed steps, the grid nodes moved by
        this fraction of each step (q ← q + ω·Δq), and its motion is judged as Δq (the
        full step). Zeroing the velocities makes each step a full Newton-like step, which
        on a flank contact can fall into a contact-switching limit cycle: the 5×5×2 grid
        at x = 64 mm, γ = −80° on the rectangle cycled with period 4 (3 / 2 / 30 / 7
        contacts, pins 3.5 px) until `max_settle_steps`; half steps settle it in 2–4
        more steps (measured). 1 = off. Frames that settle before `cycle_after` steps
        (every frame of the default's slide and contour probes) are unaffected.
      max_settle_steps: cap; not settled by then → PhysicsError.
      max_penetration (m), max_force (N), max_pin_excursion (m): per-step sanity bounds.
        Pin excursion: a 6 mm press plus ≈ 2–3 mm of stuck shear while being dragged off
        an edge reached 8.0 mm (measured), so the envelope is 12 mm. Penetration: MuJoCo's
        contact distance; with the 0.5 mm margin a healthy contact has dist > 0, and a real
        tunnelling/explosion goes far beyond 2 mm. Force: the net contact force (6 mm
        presses give ≈ 10 N).
    """

    #: the largest Poisson's ratio (–) the model takes (the grid's Lamé λ ∝ 1/(1 − 2ν): it locks at ν = 0.5)
    max_poisson: ClassVar[float] = 0.49

    young: float = 5.0e4
    poisson: float = 0.40
    membrane_young: float = 3.0e5
    damping: float = 0.01
    pin_ghost_nodes: bool = True
    viscosity: float = 3.0
    mass_scale: float = 100.0
    friction: float = 1.0
    solref: tuple[float, float] = (0.01, 1.0)
    solimp: tuple[float, float, float, float, float] = (0.99, 0.999, 0.0005, 0.5, 2.0)
    impratio: float = 30.0
    margin: float = 0.0005
    surface_spacing: float = 0.0025
    cellcount: tuple[int, int, int] = (4, 4, 2)
    solver_iterations: int = 100
    solver_tolerance: float = 1e-8
    skin_spacing: float = 0.0015
    skin_extent_deg: float = 55.0
    timestep: float = 0.02
    quasi_static_settle: bool = True
    jump_clear_moves: bool = False
    settle_px: float = 0.1
    free_settle_px: float = 0.005
    settle_steps: int = 1
    cycle_after: int = 40
    cycle_px: float = 0.25
    cycle_relaxation: float = 0.5
    max_settle_steps: int = 200
    max_penetration: float = 0.002
    max_force: float = 50.0
    max_pin_excursion: float = 0.012

    @property
    def mass(self) -> float:
        """Total simulated dome mass (kg)."""
        return DOME_REAL_MASS * self.mass_scale

    def with_(self, **changes) -> DomeParams:
        return replace(self, **changes)


#: The fidelity levels (scenario field `fidelity`); `twin bench physics` measures their
#: cost (twin.tools.bench.benchmark_physics). Every level runs the taps, the slides and full
#: contour traces of all six objects without PhysicsError (tests/world/test_physics_hard_cases.py
#: holds the hard cases). Against `reference`, the default's pins differ by ≈ 3 px RMS
#: (median over 31 edge frames; the coarser grid), far more than its settling tolerance.
FIDELITY_LEVELS: dict[str, DomeParams] = {
    # coarser: a 3×3×2 grid (10 free nodes instead of 26: ≈ 0.15 ms/step instead of 0.53
    # on 2026-11-27's host), 4 mm collision surface, 0.1 px settling; young recalibrated for
    # the stiffer grid (4.2 N at 4 mm). Pins are the smoothest and least accurate. The 4 mm
    # surface (3 mm until 2026-11-27; 328 flex vertices, not 472) makes a step ≈ 15 %
    # cheaper (0.145 instead of 0.170 ms) at the same pin error against the reference
    # (quick sweep: 2.84 px, 2.90 at 3 mm; the slide probe's lateral error 3.60 mm instead
    # of 3.09). Its time step stays 20 ms: at 25–40 ms (MuJoCo's contact time constant is
    # 2 steps) friction went so soft that a frictional slide no longer sheared the skin
    # (tests/world/test_effects.py).
    "fast": DomeParams(
        cellcount=(3, 3, 2),
        young=2.8e4,
        surface_spacing=0.004,
        settle_px=0.1,
        free_settle_px=0.01,
        cycle_after=20,
        cycle_px=0.3,
        jump_clear_moves=True,
    ),
    "default": DomeParams(),
    # the accuracy reference: a 6×6×3 grid (6.7 mm cells), 1.5 mm collision surface, 10 ms
    # steps (contact time constant 20 ms), settled to 0.02 px over 3 steps; young
    # recalibrated for the softer grid (4.3 N at 4 mm). (An 8×8×4 grid costs 8 ms per step.)
    "reference": DomeParams(
        cellcount=(6, 6, 3),
        young=6.5e4,
        surface_spacing=0.0015,
        timestep=0.01,
        settle_px=0.02,
        settle_steps=3,
        free_settle_px=0.001,
        max_settle_steps=1000,
        cycle_after=200,
        cycle_px=0.1,
    ),
}


@dataclass(frozen=True)
class TacTipHandles:
    """Ids of what ``add_tactip`` created, resolved against a compiled model by ``resolve``.

    Names are stable in the spec; ids (filled by ``resolve``) index the compiled mjModel.
    """

    prefix: str
    mount_name: str
    dome_body_name: str
    flex_name: str
    base_geom_name: str
    tool_in_mount: np.ndarray  # 4×4: tool frame in the mount body frame (m)
    pin_vertices: np.ndarray  # (127,) vertex indices within the flex, pin order
    mount_body: int = -1
    dome_body: int = -1
    flex: int = -1
    base_geom: int = -1
    vert_adr: int = -1  # first vertex of the flex in mjData.flexvert_xpos
    node_bodies: np.ndarray = field(default_factory=lambda: np.zeros(0, int))

    def resolve(self, model: mujoco.MjModel) -> TacTipHandles:
        """Fill in the ids for a compiled model (call once after compiling)."""
        mount = model.body(self.mount_name).id
        dome = model.body(self.dome_body_name).id
        flex = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX, self.flex_name)
        if flex < 0:
            raise PhysicsError(f"flex {self.flex_name!r} not in the model")
        nodes = model.flex_nodebodyid[model.flex_nodeadr[flex] : model.flex_nodeadr[flex] + model.flex_nodenum[flex]]
        return replace(
            self,
            mount_body=mount,
            dome_body=dome,
            flex=flex,
            base_geom=model.geom(self.base_geom_name).id,
            vert_adr=int(model.flex_vertadr[flex]),
            node_bodies=np.unique(nodes[nodes != dome]),
        )


def dome_mesh(
    geometry: TacTipGeometry, spacing: float, inset: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tetrahedral mesh of the solid dome, tool frame (m).

    Returns (points (N,3), tets (M,4), pin_vertices (127,)). The points are the 127 pin
    tips (first, in pin order), the outer hemisphere sampled in rings `spacing` apart (the
    collision surface, equator included) with its radius reduced by `inset` (m; the
    contact margin, see the module docstring), and a coarse inner shell; the tets are
    their Delaunay tetrahedralisation (the hemisphere is convex), slivers removed.
    """
    r = geometry.dome_outer_radius - inset
    zc = geometry.sphere_centre_z
    pins = geometry.pin_tip_points()
    outer = hemisphere_rings(r, zc, spacing)
    inner = hemisphere_rings(0.5 * r, zc, 2.5 * spacing)
    points = np.vstack([pins, outer, inner])
    tets = Delaunay(points, qhull_options="Qbb Qc Qz Q12").simplices
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    volume = np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)) / 6.0
    tets = tets[volume > 1e-3 * spacing**3]
    return points, tets.astype(int), np.arange(N_PINS)


def hemisphere_rings(radius: float, zc: float, spacing: float) -> np.ndarray:
    """Points on the upper hemisphere (apex at zc + radius, m) in rings `spacing` apart (m);
    the apex first, then ring by ring down to the equator."""
    points = [[0.0, 0.0, zc + radius]]
    n_rings = int(np.ceil(radius * np.pi / 2 / spacing))
    for i in range(1, n_rings + 1):
        polar = 0.5 * np.pi * i / n_rings
        n = max(6, int(round(2 * np.pi * radius * np.sin(polar) / spacing)))
        az = (np.arange(n) + 0.5 * (i % 2)) * 2 * np.pi / n
        s = radius * np.sin(polar)
        points.extend([s * np.cos(a), s * np.sin(a), zc + radius * np.cos(polar)] for a in az)
    return np.array(points)


def _fmt(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


#: Collision bits. MuJoCo collides a and b if (a.contype & b.conaffinity) or
#: (b.contype & a.conaffinity). Objects keep MuJoCo's default (1, 1); the flex (1, 0) and
#: the rigid base (1, 2) both collide with objects but never with each other: the flex's
#: equator tets lie on the base's top face, and their on/off contacts with the (static)
#: base threw 150 N force spikes into slides (measured). Parent/child filtering does not
#: apply to flex–geom pairs.
FLEX_CONTYPE, FLEX_CONAFFINITY = 1, 0
BASE_CONTYPE, BASE_CONAFFINITY = 1, 2


def tactip_mjcf(geometry: TacTipGeometry, params: DomeParams, friction: bool, name: str = "tactip_") -> str:
    """MJCF of one body ``{name}dome`` holding the rigid base and the flex dome.

    The body's frame is the tool frame (origin at the undeformed apex, +z out of the tip).
    Used by ``add_tactip`` (which builds it with an empty `name` and attaches it with the
    prefix ``{name}_``); exposed so a scene can also be written as XML — then paste the
    body under a mount body and apply ``configure_options``'s settings to ``<option>``.
    """
    points, tets, _ = dome_mesh(geometry, params.surface_spacing, params.margin)
    r = geometry.dome_outer_radius
    zc = geometry.sphere_centre_z
    cx, cy, cz = params.cellcount
    if friction:
        contact = f'condim="3" priority="0" friction="{params.friction} 0.005 0.0001" solmix="1000"'
    else:
        contact = 'condim="1" priority="1" friction="0 0 0"'
    return f"""<mujoco>
 <worldbody>
  <body name="{name}dome">
   <geom name="{name}base" type="cylinder" size="{r:.9g} {geometry.base_length / 2:.9g}"
     pos="0 0 {zc - geometry.base_length / 2:.9g}" rgba="0.15 0.15 0.15 1" mass="0.05"
     contype="{BASE_CONTYPE}" conaffinity="{BASE_CONAFFINITY}"/>
   <flexcomp name="{name}flex" type="direct" dim="3" dof="trilinear" cellcount="{cx} {cy} {cz}"
     mass="{params.mass:.9g}" radius="0" rgba="0.9 0.9 0.9 0.5"
     point="{_fmt(points)}" element="{" ".join(map(str, tets.ravel()))}">
    <elasticity young="{params.young:.9g}" poisson="{params.poisson:.9g}" damping="{params.damping:.9g}"/>
    <contact {contact} contype="{FLEX_CONTYPE}" conaffinity="{FLEX_CONAFFINITY}" solref="{_fmt(params.solref)}" solimp="{_fmt(params.solimp)}"
      margin="{params.margin:.9g}" selfcollide="none"/>
    <pin gridrange="0 0 0 {cx} {cy} 0"/>{_ghost_pins(params)}
   </flexcomp>
  </body>
 </worldbody>{membrane_mjcf(geometry, params, name)}
</mujoco>"""


def membrane_mjcf(geometry: TacTipGeometry, params: DomeParams, name: str) -> str:
    """``<deformable>`` block of the skin membrane (DomeParams.membrane_young), or "" if off.

    A stretch-only 2-D flex whose vertices are the grid's top node layer: the free nodes
    (bodies ``{name}flex_{ix}_{iy}_{cz}``, created by the flexcomp) and, where a node is
    pinned (ghost columns), a vertex fixed on the dome body. Triangulated on the grid;
    collision-free (the dome's collision surface is the 3-D flex's); Rayleigh damping as
    the gel's (1e-4 s instead let a slide at 3× speed shear 2× more, not 1.45×). Each grid cell is
    split along both diagonals at half the modulus: one diagonal alone made the membrane
    anisotropic (a slide along y dragged the pins sideways as much as along y).
    """
    if params.membrane_young <= 0:
        return ""
    cx, cy, cz = params.cellcount
    half = geometry.dome_outer_radius - params.margin  # the grid spans the collision surface's box
    top_z = geometry.sphere_centre_z + half
    pinned = _ghost_columns(params)
    columns = [(ix, iy) for ix in range(cx + 1) for iy in range(cy + 1)]  # vertex k = ix·(cy + 1) + iy
    clamped = [column in pinned for column in columns]
    bodies = [f"{name}dome" if c else f"{name}flex_{ix}_{iy}_{cz}" for (ix, iy), c in zip(columns, clamped)]
    offsets = [
        (-half + 2 * half * ix / cx, -half + 2 * half * iy / cy, top_z) if c else (0.0, 0.0, 0.0)
        for (ix, iy), c in zip(columns, clamped)
    ]
    triangles = []
    for ix in range(cx):
        for iy in range(cy):
            a, b, c, d = (i * (cy + 1) + j for i, j in ((ix, iy), (ix + 1, iy), (ix + 1, iy + 1), (ix, iy + 1)))
            triangles += [t for t in ((a, b, c), (a, c, d), (a, b, d), (b, c, d)) if not all(clamped[k] for k in t)]
    return f"""
 <deformable>
  <flex name="{name}membrane" dim="2" body="{" ".join(bodies)}" vertex="{_fmt(offsets)}"
    element="{_fmt(np.ravel(triangles).astype(int))}" radius="0">
   <contact contype="0" conaffinity="0"/>
   <elasticity young="{params.membrane_young / 2:.9g}" poisson="0.45" thickness="{geometry.skin_thickness:.9g}" elastic2d="stretch"
     damping="{params.damping:.9g}"/>
  </flex>
 </deformable>"""


def _ghost_columns(params: DomeParams) -> set[tuple[int, int]]:
    """(ix, iy) of the grid columns outside the dome's footprint (pinned, see _ghost_pins);
    the grid spans the dome's bounding box, so in units of its half-width the footprint is
    the unit disc."""
    if not params.pin_ghost_nodes:
        return set()
    cx, cy, _ = params.cellcount
    return {
        (ix, iy)
        for ix in range(cx + 1)
        for iy in range(cy + 1)
        if np.hypot(2 * ix / cx - 1, 2 * iy / cy - 1) > 1 + 1e-9
    }


def _ghost_pins(params: DomeParams) -> str:
    """Pin the grid nodes whose column lies outside the dome's footprint.

    The trilinear grid spans the dome's bounding box; nodes in the box's corner columns
    (farther than the dome radius from the axis) carry almost no material, so they have
    almost no stiffness and no Rayleigh damping: they drift, store momentum and later
    kick the pins (measured: 0.2 mm jumps 2 s after lift-off). Pinning them removes
    those spurious modes; they only touch the thin flank regions of their cells.
    """
    cx, cy, cz = params.cellcount
    ids = [(ix * (cy + 1) + iy) * (cz + 1) + iz for ix, iy in sorted(_ghost_columns(params)) for iz in range(1, cz + 1)]
    return f'\n    <pin id="{" ".join(map(str, ids))}"/>' if ids else ""


def configure_options(spec: mujoco.MjSpec, params: DomeParams) -> None:
    """Set the solver options the dome needs on the whole scene.

    impratio (frictional/normal impedance ratio, elliptic cones only) makes static
    friction "harder": MuJoCo's soft friction otherwise lets a sheared dome creep back,
    erasing the path dependence; impratio 30 cuts the creep ≈ 10× (DomeParams).
    """
    spec.option.timestep = params.timestep
    spec.option.impratio = params.impratio
    spec.option.iterations = params.solver_iterations
    spec.option.tolerance = params.solver_tolerance
    spec.option.viscosity = params.viscosity
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    # the dome's constraints couple all its nodes into one island, so island discovery is
    # pure overhead (≈ 3 % of a step, bit-identical results; measured)
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND


def add_tactip(
    spec: mujoco.MjSpec,
    parent: mujoco.MjsBody,
    geometry: TacTipGeometry,
    params: DomeParams,
    friction: bool,
    name: str = "tactip",
    tool_in_parent: np.ndarray | None = None,
) -> TacTipHandles:
    """Add the TacTip (rigid base + flex dome) under `parent`, the sensor mount.

    parent: the body carrying the sensor; ``spec.worldbody`` for SensorPhysics (a static
      dome keeps MuJoCo's fast 3×3 flex blocks; a moving parent costs ≈ 5× per step and a
      mocap parent gives no friction shear, see add_stimulus_carrier).
    tool_in_parent: 4×4 pose of the tool frame (TCP = undeformed apex) in the parent's
      frame (m); identity if the parent's frame *is* the tool frame.
    friction: False → frictionless contacts (condim 1, priority 1 on the flex).
    Also sets the scene options via ``configure_options`` and gravity compensation on
    the flex nodes (the mass-scaled dome must not sag). Call ``handles.resolve(model)``
    after compiling.
    """
    tool_in_parent = np.eye(4) if tool_in_parent is None else np.asarray(tool_in_parent, float)
    child = mujoco.MjSpec.from_string(tactip_mjcf(geometry, params, friction, name=""))
    for body in child.bodies:
        if body.name.startswith("flex"):
            body.gravcomp = 1.0  # the mass-scaled gel must not sag under gravity
    frame = parent.add_frame(pos=tool_in_parent[:3, 3], quat=matrix_to_quat_wxyz(tool_in_parent[:3, :3]))
    frame.attach_body(child.body("dome"), f"{name}_", "")
    configure_options(spec, params)
    _, _, pin_vertices = dome_mesh(geometry, params.surface_spacing, params.margin)
    return TacTipHandles(
        prefix=name,
        mount_name=parent.name,
        dome_body_name=f"{name}_dome",
        flex_name=f"{name}_flex",
        base_geom_name=f"{name}_base",
        tool_in_mount=tool_in_parent,
        pin_vertices=pin_vertices,
    )


def tool2world(model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles) -> np.ndarray:
    """4×4 pose of the tool frame in the world, from the mount body's current pose (m)."""
    mount2world = make_transform(data.xmat[handles.mount_body].reshape(3, 3), data.xpos[handles.mount_body])
    return mount2world @ handles.tool_in_mount


def pin_tips_tool(model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles) -> np.ndarray:
    """(127, 3) pin tip positions in the tool frame (m), pin order of twin.core.sensor.

    Reads mjData.flexvert_xpos, valid after mj_step / mj_forward / mj_kinematics.
    """
    world = data.flexvert_xpos[handles.vert_adr + handles.pin_vertices]
    return transform_points(invert_transform(tool2world(model, data, handles)), world)


def apply_contact_law(model: mujoco.MjModel, handles: TacTipHandles, params: DomeParams) -> None:
    """Make the dome's contact law hold for every contact with the dome, in the compiled model.

    MuJoCo takes condim, friction, solref and solimp of a contact from the side with the
    higher ``priority`` (twin.world.scene gives the object priority so that the contact μ is
    the object's). That would also hand the object's default solref/solimp (0.02 s,
    width 1 mm) to the *normal* contact law whenever friction is on, and the dome's
    otherwise — two different indentation laws for the same press. The normal law is a
    property of the soft side, so this writes ``params.solref`` / ``params.solimp`` into
    every geom that can collide with the flex (and into the flex), leaving their
    friction and condim alone. Idempotent; call after compiling (SensorPhysics does).
    """
    model.flex_solref[handles.flex] = params.solref
    model.flex_solimp[handles.flex] = params.solimp
    for g in flex_contact_geoms(model, handles):
        model.geom_solref[g] = params.solref
        model.geom_solimp[g] = params.solimp


def flex_contact_geoms(model: mujoco.MjModel, handles: TacTipHandles) -> np.ndarray:
    """Ids of the geoms that can collide with the dome (MuJoCo's contype/conaffinity rule),
    the TacTip's own rigid base excluded."""
    f = handles.flex
    ftype, faff = model.flex_contype[f], model.flex_conaffinity[f]
    hits = (model.geom_contype & faff) | (model.geom_conaffinity & ftype)
    hits[handles.base_geom] = 0
    return np.flatnonzero(hits)
