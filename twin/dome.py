"""The compliant TacTip dome: a MuJoCo flex with the 127 pin tips as vertices.

Model (DESIGN §5). The dome is a *solid* hemisphere of gel under the skin, meshed into
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

Pin tips move with the gel around them (they are interpolated vertices); what the
camera sees is ``pin_tips_tool`` — the vertex positions expressed in the tool frame.

Frames and units: README "Conventions". Tool frame: origin at the undeformed dome apex
(the TCP), +z along the sensor axis out of the tip. All lengths in m, forces in N.

Attaching: ``add_tactip(spec, spec.worldbody, geometry, params, friction)`` adds a
jointless body holding the rigid base and the flex; the physics scene is built in the
tool frame (dome still at the origin, stimuli on ``add_stimulus_carrier``'s body, moved
by twin.physics.SensorPhysics — see add_stimulus_carrier for why). ``add_tactip`` also
applies ``configure_options`` (discrete integrator, Newton, elliptic cone, impratio,
viscosity, timestep) to the whole spec.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import mujoco
import numpy as np
from scipy.spatial import Delaunay

from twin.errors import PhysicsError
from twin.poses import invert_transform, make_transform, transform_points
from twin.tactip import N_PINS, TacTipGeometry

#: Real mass of the dome's gel + skin (kg): a 20 mm-radius hemisphere of ≈1.0 g/cm³ gel.
DOME_REAL_MASS = 0.017


@dataclass(frozen=True)
class DomeParams:
    """Material, contact and numerical parameters of the dome (SI units).

    Material
      young (Pa): effective Young's modulus of the skin+gel solid. The real TacTip is an
        Agilus30/Tango-like rubber skin (E ≈ 0.5–1 MPa, 1.5 mm thick) over a very soft
        gel (E ≈ 10–50 kPa); the *effective* solid modulus of the composite is of order
        0.1 MPa. The coarse trilinear grid is stiffer than a continuum (few modes, mild
        volumetric locking), so the value here is calibrated to forces, not to a datasheet:
        the default gives ≈ 1.5 N for a 2 mm and ≈ 4 N for a 4 mm press centred on a
        straight edge (half the dome in contact), matching the "a few N at 4 mm" that the
        real sensor shows.
      poisson (–): gel is nearly incompressible, but ν → 0.5 locks a trilinear grid
        (it stiffens and stops bulging); 0.40 keeps the lateral bulge without locking.
      damping (s): Rayleigh stiffness-proportional damping β (damping matrix = β·K). It only
        shapes how frames settle (the twin records settled, quasi-static frames); large
        enough to kill oscillation within a few steps, small enough not to add a viscous
        drag that would look like extra shear during slides.
      mass_scale (–): the dome's mass is DOME_REAL_MASS × mass_scale. Quasi-static frames
        don't depend on inertia; a heavier dome makes the implicit step better conditioned
        in contact (DESIGN §5: ×100 was stable over the whole dt/E range).

    Contact (dome side; the object's geom brings its own friction)
      friction (–): sliding friction coefficient of the skin. MuJoCo takes the *max* of the
        two geoms' friction (equal priority), so the contact μ = max(skin, object). Rubber
        on 3D-printed plastic: μ ≈ 0.6–1.2. With ``add_tactip(..., friction=False)`` the
        flex gets condim=1 and contact priority 1, so contacts are frictionless (no
        friction rows are even built) whatever the object says.
      solref (s, –): contact time constant and damping ratio. Stiffer than the gel by far
        (the object is rigid); the time constant is clamped by MuJoCo to ≥ 2·timestep.
      solimp (–, –, m, –, –): impedance; width 0.5 mm so the impedance ramps to 0.99
        within a small penetration — penetration stays < 0.5 mm at 6 mm presses.

    Resolution
      surface_spacing (m): spacing of the collision vertices on the outer surface. The
        edge of a box is resolved to about this length.
      cellcount: trilinear background grid (cells along tool x, y, z). 4×4×2 = 10 mm cells
        in a 40 × 40 × 20 mm box (DESIGN §5); the pin field is as smooth as this grid.

      pin_ghost_nodes: pin the grid nodes in the bounding box's corner columns (outside the
        dome's footprint). Unpinned, they have ~no stiffness and no Rayleigh damping, drift
        and kicked the pins by 0.1–0.3 mm seconds after lift-off (measured).
      viscosity (Pa·s): global MuJoCo fluid viscosity = a mass-like drag on the node
        bodies (the only mass-proportional damping a flex can get; joint damping on flex
        nodes is refused by the compiler). 3 makes an out-of-contact dome return to
        rest to < 0.1 µm in ≈ 40 steps; it doesn't change equilibria.
      impratio (–): frictional/normal impedance ratio; 30 cuts soft-friction creep ≈ 10×
        (see configure_options).

    Stepping (used by twin.physics.SensorPhysics)
      timestep (s): physics step. The discrete integrator is implicit, so large steps are
        stable; each step moves the mount by speed × timestep.
      settle_speed (m/s): a frame is settled when every pin tip moves slower than this
        (in contact; the soft-friction creep floor is ≈ 2e-5 m/s, so 5e-5 m/s ≈ 1 µm per
        20 ms step) — free_settle_speed applies when nothing touches the dome…
      settle_steps: …for this many consecutive steps.
      max_settle_steps: cap; not settled by then → PhysicsError.
      max_penetration (m), max_force (N), max_pin_excursion (m): per-step sanity bounds.
        Pin excursion: a 6 mm press plus ≈ 2–3 mm of stuck shear while being dragged off
        an edge reached 8.0 mm (measured), so the envelope is 12 mm.
        Penetration is the tet-vs-geom depth MuJoCo reports; tetrahedra straddling a
        sharp box edge report up to ≈ 1.2 mm while sliding along it (measured), so the
        bound is 2 mm — a real tunnelling/explosion goes far beyond it.
    """

    young: float = 5.0e4
    poisson: float = 0.40
    damping: float = 0.01
    pin_ghost_nodes: bool = True
    viscosity: float = 3.0
    mass_scale: float = 100.0
    friction: float = 1.0
    solref: tuple[float, float] = (0.01, 1.0)
    solimp: tuple[float, float, float, float, float] = (0.95, 0.99, 0.0005, 0.5, 2.0)
    surface_spacing: float = 0.0025
    cellcount: tuple[int, int, int] = (4, 4, 2)
    impratio: float = 30.0
    timestep: float = 0.02
    settle_speed: float = 2.5e-4
    free_settle_speed: float = 5e-6
    settle_steps: int = 2
    max_settle_steps: int = 200
    max_penetration: float = 0.002
    max_force: float = 50.0
    max_pin_excursion: float = 0.012

    @property
    def mass(self) -> float:
        """Total simulated dome mass (kg)."""
        return DOME_REAL_MASS * self.mass_scale

    def with_(self, **changes) -> "DomeParams":
        return replace(self, **changes)


FIDELITY_LEVELS: dict[str, DomeParams] = {
    # a 3.5 mm collision mesh chattered on the edge (never settled), so "fast" keeps the
    # default mesh and only loosens the settling criterion
    "fast": DomeParams(settle_speed=5e-4, free_settle_speed=1e-5, settle_steps=1),
    "default": DomeParams(),
    "reference": DomeParams(
        surface_spacing=0.0015, timestep=0.005, settle_speed=3e-5, free_settle_speed=2e-6, settle_steps=3,
        max_settle_steps=2000,
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
    mocap: int = -1  # mocap id of the mount, -1 if the mount is not a mocap body

    def resolve(self, model: mujoco.MjModel) -> "TacTipHandles":
        """Fill in the ids for a compiled model (call once after compiling)."""
        mount = model.body(self.mount_name).id
        dome = model.body(self.dome_body_name).id
        flex = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX, self.flex_name)
        if flex < 0:
            raise PhysicsError(f"flex {self.flex_name!r} not in the model")
        nodes = model.flex_nodebodyid[model.flex_nodeadr[flex]: model.flex_nodeadr[flex] + model.flex_nodenum[flex]]
        return replace(
            self,
            mount_body=mount,
            dome_body=dome,
            flex=flex,
            base_geom=model.geom(self.base_geom_name).id,
            vert_adr=int(model.flex_vertadr[flex]),
            node_bodies=np.unique(nodes[nodes != dome]),
            mocap=int(model.body_mocapid[mount]),
        )


def dome_mesh(geometry: TacTipGeometry, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tetrahedral mesh of the solid dome, tool frame (m).

    Returns (points (N,3), tets (M,4), pin_vertices (127,)). The points are the 127 pin
    tips (first, in pin order), the outer hemisphere sampled in rings `spacing` apart (the
    collision surface, equator included), and a coarse inner shell; the tets are their
    Delaunay tetrahedralisation (the hemisphere is convex), slivers removed.
    """
    r = geometry.dome_outer_radius
    zc = geometry.sphere_centre_z
    pins = geometry.pin_tip_points()
    outer = _hemisphere_rings(r, zc, spacing)
    inner = _hemisphere_rings(0.5 * r, zc, 2.5 * spacing)
    points = np.vstack([pins, outer, inner])
    tets = Delaunay(points, qhull_options="Qbb Qc Qz Q12").simplices
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    volume = np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)) / 6.0
    tets = tets[volume > 1e-3 * spacing**3]
    return points, tets.astype(int), np.arange(N_PINS)


def _hemisphere_rings(radius: float, zc: float, spacing: float) -> np.ndarray:
    """Points on the upper hemisphere (apex at zc + radius) in rings `spacing` apart."""
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


def tactip_mjcf(geometry: TacTipGeometry, params: DomeParams, friction: bool, name: str = "tactip_") -> str:
    """MJCF of one body ``{name}dome`` holding the rigid base and the flex dome.

    The body's frame is the tool frame (origin at the undeformed apex, +z out of the tip).
    Used by ``add_tactip`` (which builds it with an empty `name` and attaches it with the
    prefix ``{name}_``); exposed so a scene can also be written as XML — then paste the
    body under a mount body and apply ``configure_options``'s settings to ``<option>``.
    """
    points, tets, _ = dome_mesh(geometry, params.surface_spacing)
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
     pos="0 0 {zc - geometry.base_length / 2:.9g}" rgba="0.15 0.15 0.15 1" mass="0.05"/>
   <flexcomp name="{name}flex" type="direct" dim="3" dof="trilinear" cellcount="{cx} {cy} {cz}"
     mass="{params.mass:.9g}" radius="0" rgba="0.9 0.9 0.9 0.5"
     point="{_fmt(points)}" element="{' '.join(map(str, tets.ravel()))}">
    <elasticity young="{params.young:.9g}" poisson="{params.poisson:.9g}" damping="{params.damping:.9g}"/>
    <contact {contact} solref="{_fmt(params.solref)}" solimp="{_fmt(params.solimp)}"
      selfcollide="none"/>
    <pin gridrange="0 0 0 {cx} {cy} 0"/>{_ghost_pins(geometry, params)}
   </flexcomp>
  </body>
 </worldbody>
</mujoco>"""


def _ghost_pins(geometry: TacTipGeometry, params: DomeParams) -> str:
    """Pin the grid nodes whose column lies outside the dome's footprint.

    The trilinear grid spans the dome's bounding box; nodes in the box's corner columns
    (farther than the dome radius from the axis) carry almost no material, so they have
    almost no stiffness and no Rayleigh damping: they drift, store momentum and later
    kick the pins (measured: 0.2 mm jumps 2 s after lift-off). Pinning them removes
    those spurious modes; they only touch the thin flank regions of their cells.
    """
    if not params.pin_ghost_nodes:
        return ""
    cx, cy, cz = params.cellcount
    r = geometry.dome_outer_radius
    ids = []
    for ix in range(cx + 1):
        for iy in range(cy + 1):
            x = -r + 2 * r * ix / cx
            y = -r + 2 * r * iy / cy
            if np.hypot(x, y) > r * (1 + 1e-9):
                ids.extend((ix * (cy + 1) + iy) * (cz + 1) + iz for iz in range(1, cz + 1))
    return f'\n    <pin id="{" ".join(map(str, ids))}"/>' if ids else ""


def configure_options(spec: mujoco.MjSpec, params: DomeParams) -> None:
    """Set the solver options the dome needs on the whole scene (DESIGN §5).

    impratio (frictional/normal impedance ratio, elliptic cones only) makes static
    friction "harder": MuJoCo's soft friction otherwise lets a sheared dome creep back
    at ≈ 0.3 mm/s, erasing the path dependence; impratio 30 cuts the creep ≈ 10×.
    """
    spec.option.timestep = params.timestep
    spec.option.impratio = params.impratio
    spec.option.viscosity = params.viscosity
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC


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
            for joint in body.joints:
                pass
    frame = parent.add_frame(pos=tool_in_parent[:3, 3], quat=_quat(tool_in_parent[:3, :3]))
    frame.attach_body(child.body("dome"), f"{name}_", "")
    configure_options(spec, params)
    _, _, pin_vertices = dome_mesh(geometry, params.surface_spacing)
    return TacTipHandles(
        prefix=name,
        mount_name=parent.name,
        dome_body_name=f"{name}_dome",
        flex_name=f"{name}_flex",
        base_geom_name=f"{name}_base",
        tool_in_mount=tool_in_parent,
        pin_vertices=pin_vertices,
    )


def _quat(rotation: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rotation, dtype=float).ravel())
    return q


def tool2world(model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles) -> np.ndarray:
    """4×4 pose of the tool frame in the world, from the mount body's current pose (m)."""
    mount2world = make_transform(data.xmat[handles.mount_body].reshape(3, 3), data.xpos[handles.mount_body])
    return mount2world @ handles.tool_in_mount


def pin_tips_tool(model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles) -> np.ndarray:
    """(127, 3) pin tip positions in the tool frame (m), pin order of twin.tactip.

    Reads mjData.flexvert_xpos, valid after mj_step / mj_forward / mj_kinematics.
    """
    world = data.flexvert_xpos[handles.vert_adr + handles.pin_vertices]
    return transform_points(invert_transform(tool2world(model, data, handles)), world)


#: Mass (kg) and rotational inertia (kg·m²) of the kinematic stimulus carrier. It is driven
#: by prescribing its velocity every step (twin.physics), so it must be heavy enough that
#: the contact forces (≤ tens of N) don't deflect it measurably within one step.
CARRIER_MASS = 1.0e4
CARRIER_INERTIA = 25.0


def add_stimulus_carrier(spec: mujoco.MjSpec, name: str = "stimulus") -> mujoco.MjsBody:
    """Add the body that carries every stimulus geom: free joint, heavy, gravity-compensated.

    The physics scene is built in the *tool frame*: the TacTip sits still at the world
    origin (``add_tactip(spec, spec.worldbody, ...)``), and the stimuli move around it —
    twin.physics.SensorPhysics prescribes this body's velocity each step so that its pose
    in the tool frame is inv(tool2world) · stimulus2world along the commanded path
    ("arm dynamics off": the sensor follows the commanded pose exactly). Add the stimulus
    geoms to the returned body with their poses in the lab world frame (the body's frame
    *is* the world frame when the tool frame coincides with it).

    Why this way round (measured with MuJoCo 4.0, 2 cores):
      * a mocap sensor mount has a pose but no velocity; the dome's node bodies are its
        children, so a move teleports the whole dome and contacts never see the slip —
        friction then produced no shear at all (mean pin shift 2 nm over a 4 mm slide);
      * a free-jointed, velocity-driven sensor mount shears correctly but makes the flex
        nodes "articulated attachments", whose stiffness MuJoCo must pull back through the
        attachment Jacobians: 2.3 ms per step instead of ≈ 0.45 ms with a static dome.
    Quasi-static contact mechanics are frame-invariant (gravity is compensated on the
    dome and the carrier), so moving the world around a still sensor gives the same pins.
    """
    body = spec.worldbody.add_body(name=name, gravcomp=1.0)
    body.add_freejoint(name=f"{name}_free")
    body.explicitinertial = True
    body.mass = CARRIER_MASS
    body.inertia = [CARRIER_INERTIA] * 3
    return body
