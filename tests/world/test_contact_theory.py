"""The compliant dome against closed-form contact mechanics (K. L. Johnson, *Contact
Mechanics*, 1985, §4.2 and §7.2), through the real pipeline: the dome pressed and slid on
the flat top of the rectangle (120 × 80 mm, centred on the work origin), contact found by
MuJoCo rays, forces from twin.world.dome.compliant.contact.

* Hertz: a rigid flat on the elastic sphere (R = 20 mm) is the same problem as a rigid
  sphere on an elastic half-space, F = 4/3 E* √R δ^3/2, a = √(R δ), E* = E / (1 − ν²).
  Hertz assumes a ≪ R: the twin's dome is a real sphere, so the check is at small δ. A
  flatter outer profile through the apex is Hertz with the profile's radius.
* Cattaneo–Mindlin: tangential load Q at constant P (ν = 0.5: normal and tangential
  decouple), stick radius c = a (1 − Q/μP)^1/3, tangential displacement and the unloading
  branch of the hysteresis loop (formulas in `_mindlin_*`); with the tip's sway, a spring
  in series.
* Without friction a slide ends where a static press ends; with friction it does not.
* Mesh refinement: the default spacing's pins against half the spacing, with an edge
  between the nodes; the force and pins as the edge moves within a node.
* The skin membrane on its sphere: Laplace's law for a uniform radial displacement, with
  a uniform skin and one that thickens towards its base (then with the meridional load of
  its varying stress resultant; its bending against quadrature of the local rigidity).
* The skin's bending (a thin shell): the energy of a Gaussian dimple against the plate's
  closed form, and rigid motions costing nothing.
* The skin's pretension: the energy of spherical harmonics against the Laplace–Beltrami
  eigenvalues on the sphere, T (l(l+1) − 2)/R² per unit area, and translations costing
  nothing.

Work frame: +z into the object, so a pose z = δ presses δ mm into the top face.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment
from twin.world.dome.compliant import COMPLIANT, COMPLIANT_LEVELS, PLAIN_SOLID
from twin.world.dome.compliant.physics import ADHESION_RAMP

#: the body of the closed-form checks: the plain solid (one 67 kPa solid, no skin) on 1.5 mm nodes
PLAIN = {**PLAIN_SOLID, "surface_spacing_mm": 1.5}
PARAMS = COMPLIANT.params("default", COMPLIANT.settings(**PLAIN), {}, "theory")
E, NU = PARAMS.young, PARAMS.poisson
E_STAR = E / (1.0 - NU**2)
G = E / (2.0 * (1.0 + NU))
R = 0.020  # m, dome radius (twin.core.sensor.TacTipGeometry)
MU = 0.7  # PLA, the rectangle's material (twin.world.stimuli.objects.MATERIALS)


def _env(
    effects: tuple[str, ...] = ("contact", "friction"),
    spacing_mm: float | None = None,
    x_mm: float = 0.0,
    enclosed: bool = True,
    skin: dict | None = None,
    edge_within_node: bool = False,
    body: dict = PLAIN,
) -> SimEnvironment:
    """The compliant dome over the rectangle, as `body` (scenario `physics` entries; the
    plain solid unless given, {} = the default dome); `enclosed` False: the open half-space
    that Hertz and Cattaneo–Mindlin describe (the sealed gel's volume balance is not
    theirs); `skin`: further `physics` entries over the body."""
    physics = {**body, "gel_enclosed": enclosed, "edge_within_node": edge_within_node, **(skin or {})}
    if spacing_mm is not None:
        physics["surface_spacing_mm"] = spacing_mm
    scenario = scenario_from_dict(
        {
            "name": "theory",
            "object": {"name": "rectangle"},
            "dome": "compliant",
            "effects": list(effects),
            "physics": physics,
        }
    )
    env = SimEnvironment(scenario, start_pose=Pose(x_mm, 0, -2, 0, 0, 0))
    env.reset()
    return env


def _contact(env: SimEnvironment) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per node on the flat (tool frame, normal +z): radius from the axis (m), pressure
    (Pa), tangential traction (Pa, x and y), and the node's area projected on the flat (m²)."""
    physics = env.physics
    surface = physics.surface
    area = surface.area * surface.normals[:, 2]
    radius = np.linalg.norm(surface.points[:, :2], axis=1)
    forces = physics.forces
    return radius, -forces[:, 2] / area, forces[:, :2] / area[:, None], area


def _hertz_radius(radius: np.ndarray, pressure: np.ndarray) -> float:
    """Contact radius (m) from the pressure field: Hertz's p² = p0² (1 − r²/a²) is linear
    in r², fitted on the nodes carrying more than 30 % of the peak (the patch's border
    cells are only partly in contact)."""
    inside = pressure > 0.3 * pressure.max()
    slope, intercept = np.polyfit(radius[inside] ** 2, pressure[inside] ** 2, 1)
    return math.sqrt(-intercept / slope)


@pytest.mark.parametrize("depth_mm", [0.25, 0.5, 1.0])
def test_hertz_force_and_contact_radius(depth_mm):
    """Within 5 % of Hertz. Measured: force +0.3 / −0.1 / −0.7 % and contact radius −4.4 /
    −2.1 / −1.1 % at 0.25 / 0.5 / 1 mm (the radius resolves to about a node: a = 2.2 mm
    spans three 1.5 mm nodes at 0.25 mm); at 3 mm, beyond Hertz's a ≪ R, force −2.5 %."""
    env = _env(("contact",), enclosed=False)
    env.move_to(Pose(0, 0, depth_mm, 0, 0, 0))
    frame = env.observe_frame()
    delta = depth_mm * 1e-3
    force = 4.0 / 3.0 * E_STAR * math.sqrt(R) * delta**1.5
    assert frame.contact_force == pytest.approx(force, rel=0.05)
    radius, pressure, _, _ = _contact(env)
    assert _hertz_radius(radius, pressure) == pytest.approx(math.sqrt(R * delta), rel=0.05)
    # the pressure field's resultant is the force (nothing outside the patch)
    assert np.sum(pressure[pressure > 0] * _contact(env)[3][pressure > 0]) == pytest.approx(
        frame.contact_force, rel=0.01
    )


@pytest.mark.parametrize(("apex_radius_mm", "spacing_mm"), [(30.0, None), (40.0, None), (30.0, 1.8)])
def test_a_flatter_apex_profile_is_hertz_with_its_radius(apex_radius_mm, spacing_mm):
    """The profile the object meets (physics.apex_radius_mm) enters through the gap alone,
    as in Hertz theory: a flat pressed 0.5 mm gives Hertz's force and contact radius with
    the profile's radius, not the dome's (1.22 / 1.41 times the dome's force). Measured at
    30 / 40 mm: force −0.2 / −0.3 %, contact radius −1.3 / −1.0 % (the dome's own: −0.1 %,
    −2.1 %). The 30 mm profile's patch is √(30 / 20) times as wide as the dome's own, so
    nodes 1.8 mm apart span it as 1.5 mm span the dome's: force −0.2 %, radius −2.0 %."""
    env = _env(("contact",), enclosed=False, skin={"apex_radius_mm": apex_radius_mm}, spacing_mm=spacing_mm)
    env.move_to(Pose(0, 0, 0.5, 0, 0, 0))
    frame = env.observe_frame()
    delta, radius_of_profile = 0.5e-3, apex_radius_mm * 1e-3
    force = 4.0 / 3.0 * E_STAR * math.sqrt(radius_of_profile) * delta**1.5
    assert frame.contact_force == pytest.approx(force, rel=0.05)
    radius, pressure, _, _ = _contact(env)
    assert _hertz_radius(radius, pressure) == pytest.approx(math.sqrt(radius_of_profile * delta), rel=0.05)


def _mindlin_loading(q: np.ndarray, p: float, a: float) -> np.ndarray:
    """Tangential displacement (m) at Q rising from 0 (Johnson eq. 7.42 with 7.39)."""
    scale = 3.0 * MU * p * (2.0 - NU) / (16.0 * G * a)
    return scale * (1.0 - (1.0 - q / (MU * p)) ** (2.0 / 3.0))


def _mindlin_unloading(q: np.ndarray, q_star: float, p: float, a: float) -> np.ndarray:
    """Tangential displacement (m) at Q falling from Q* (Johnson eq. 7.49)."""
    scale = 3.0 * MU * p * (2.0 - NU) / (16.0 * G * a)
    return scale * (
        2.0 * (1.0 - (q_star - q) / (2.0 * MU * p)) ** (2.0 / 3.0) - (1.0 - q_star / (MU * p)) ** (2.0 / 3.0) - 1.0
    )


def _invert(displacement_of_q, displacement: float, lo: float, hi: float) -> float:
    """Q (N) with displacement_of_q(Q) = displacement, by bisection (monotonic)."""
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if (displacement_of_q(np.array(mid)) - displacement) * (displacement_of_q(np.array(lo)) - displacement) > 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def test_cattaneo_mindlin_stick_zone_and_hysteresis():
    """A 1 mm press (P ≈ 0.75 N, a ≈ 4.5 mm), then the sensor moved along +x in 0.05 mm
    steps to 0.8 of full slip and back: Q and the stick radius follow the closed forms
    within 10 % (of Q* for the force, of a for the radius), unloading included (measured:
    force within 0.2 % of Q*, stick radius within 1.7 % of a). The mesh is refined to
    0.75 mm here so that the stick zone spans enough nodes to be measured.
    """
    env = _env(spacing_mm=0.75, enclosed=False)
    env.move_to(Pose(0, 0, 1.0, 0, 0, 0))
    radius, pressure, _, area = _contact(env)
    p_total = env.observe_frame().contact_force
    a = _hertz_radius(radius, pressure)
    full_slip = 3.0 * MU * p_total * (2.0 - NU) / (16.0 * G * a)  # displacement at Q = μP (m)
    q_star = 0.8 * MU * p_total
    d_star = float(_mindlin_loading(np.array(q_star), p_total, a))
    steps = np.linspace(0.0, d_star, 13)[1:]
    loading, unloading = [], []
    for d in steps:
        env.move_to(Pose(d * 1e3, 0, 1.0, 0, 0, 0))
        frame = env.observe_frame()
        radius, pressure, traction, area = _contact(env)
        q = -frame.contact_force_tool[0]  # the object drags the skin along −x
        stuck = (pressure > 0) & (np.linalg.norm(traction, axis=1) < MU * pressure * (1 - 1e-6))
        stick_radius = math.sqrt(np.sum(area[stuck]) / math.pi)
        loading.append((d, q, stick_radius))
    for d in steps[::-1][1:]:
        env.move_to(Pose(d * 1e3, 0, 1.0, 0, 0, 0))
        unloading.append((d, -env.observe_frame().contact_force_tool[0]))
    for d, q, stick_radius in loading:
        expected = _invert(lambda x: _mindlin_loading(x, p_total, a), d, 0.0, MU * p_total)
        assert q == pytest.approx(expected, abs=0.1 * q_star), (d, q, expected)
        if expected < 0.7 * MU * p_total:  # a stick zone a few nodes wide at least
            assert stick_radius == pytest.approx(a * (1 - expected / (MU * p_total)) ** (1 / 3), abs=0.1 * a)
    for d, q in unloading:
        # unloading from Q* at d*: δ(Q) = d* − (loading curve of (Q* − Q)/2) · 2 (Johnson 7.49)
        expected = _invert(lambda x: _mindlin_unloading(x, q_star, p_total, a), d, -q_star, q_star)
        assert q == pytest.approx(expected, abs=0.1 * q_star), (d, q, expected)
    # hysteresis: at the same displacement the unloading force is lower than the loading one
    middle = len(steps) // 2
    assert unloading[len(unloading) - middle][1] < loading[middle - 1][1] - 0.1 * q_star
    assert d_star < full_slip


def test_the_tip_sway_is_a_spring_in_series_with_mindlin():
    """The tip's sway s (m/N) moves the whole tip by s·Q under a tangential load Q, in
    series with the contact: the tool displacement is Mindlin's plus s·Q (Johnson eq. 7.42),
    Q within 2 % of Q*; in full slip (Q = μP) every pin sits s·Q further along than
    without the sway, within 0.5 % of s·Q. With s = 2 mm/N the sway takes about half the
    tool's motion. Measured: Q within 0.08 % of Q*, the pins within 0.014 % of s·Q (0.74 mm)."""
    sway = 2e-3  # m/N
    env = _env(spacing_mm=0.75, enclosed=False, skin={"tip_sway_mm_per_n": sway * 1e3})
    plain = _env(spacing_mm=0.75, enclosed=False)
    env.move_to(Pose(0, 0, 1.0, 0, 0, 0))
    radius, pressure, _, _ = _contact(env)
    p_total = env.observe_frame().contact_force
    a = _hertz_radius(radius, pressure)
    q_star = 0.8 * MU * p_total
    d_star = float(_mindlin_loading(np.array(q_star), p_total, a)) + sway * q_star
    for d in np.linspace(0.0, d_star, 7)[1:]:
        env.move_to(Pose(d * 1e3, 0, 1.0, 0, 0, 0))
        q = -env.observe_frame().contact_force_tool[0]
        expected = _invert(lambda x: _mindlin_loading(x, p_total, a) + sway * x, d, 0.0, MU * p_total)
        assert q == pytest.approx(expected, abs=0.02 * q_star), (d, q, expected)
    for e in (env, plain):
        e.move_to(Pose(0, 0, 1.0, 0, 0, 0))
        e.move_to(Pose(4.0, 0, 1.0, 0, 0, 0))
    q = env.physics.contact_force_tool()[:2]
    assert np.linalg.norm(q) == pytest.approx(MU * p_total, rel=0.02)
    shift = env.physics.converged_pins()[:, :2] - plain.physics.converged_pins()[:, :2]
    assert np.abs(shift - sway * q).max() <= 0.005 * sway * np.linalg.norm(q), (shift.mean(axis=0), sway * q)


def test_adhesion_adds_its_shear_strength_over_the_hertz_contact():
    """In full slip the tangential force is μP plus the adhesive shear strength τ over the
    contact, each point's share built up by its pressure (twin.world.dome.compliant.
    contact.friction_bound): Q = μP + ∫ τ (1 − e^(−p(r)/p_c)) dA over Hertz's pressure
    p(r) = p0 √(1 − r²/a²), p0 = 3P / 2πa², a = √(Rδ) (quadrature of the closed form).
    A 1 mm press slid 4 mm (past full slip, which this Q reaches at ≈ 2.4 mm): Q within 3 %
    of it, and ≥ 1.5 × the μP it has without. Measured: −0.12 % at τ = 10 kPa."""
    tau = 1e4  # Pa
    env = _env(spacing_mm=0.75, enclosed=False, skin={"adhesion_kpa": tau * 1e-3})
    env.move_to(Pose(0, 0, 1.0, 0, 0, 0))
    p_total = env.observe_frame().contact_force
    env.move_to(Pose(4.0, 0, 1.0, 0, 0, 0))
    q = np.linalg.norm(env.physics.contact_force_tool()[:2])
    a = math.sqrt(R * 1e-3)
    p0 = 3.0 * p_total / (2.0 * math.pi * a**2)
    r = np.linspace(0.0, a, 20001)
    built = 1.0 - np.exp(-p0 * np.sqrt(np.maximum(1.0 - (r / a) ** 2, 0.0)) / ADHESION_RAMP)
    adhesive = tau * np.trapezoid(built * 2.0 * math.pi * r, r)
    assert q == pytest.approx(MU * p_total + adhesive, rel=0.03), (q, MU * p_total, adhesive)
    assert q > 1.5 * MU * p_total


def test_frictionless_slide_ends_where_a_press_ends():
    """Without friction the state has no memory: slide 6 mm along the edge after pressing,
    or press there directly, and the pins agree; with friction they do not (path dependence)."""

    def pins(effects: tuple[str, ...], slide: bool) -> np.ndarray:
        env = _env(effects, x_mm=60.0)
        if slide:
            env.move_to(Pose(60, -6, 3, 0, 0, 0))
        else:
            env.move_to(Pose(60, 0, -2, 0, 0, 0))
        env.move_to(Pose(60, 0, 3, 0, 0, 0))
        return env.observe().pins_px

    frictionless = np.abs(pins(("contact",), True) - pins(("contact",), False)).max()
    frictional = np.abs(pins(("contact", "friction"), True) - pins(("contact", "friction"), False)).max()
    assert frictionless < 0.01  # px
    assert frictional > 2.0  # px: the slide's shear is held by static friction


def _assert_refined(
    poses: tuple[Pose, ...], x_mm: float, edge_within_node: bool, rms_px: float, worst_px: float
) -> None:
    """The pins along `poses` on 1.5 mm nodes lie within `rms_px` RMS and `worst_px` at worst
    of those on 0.75 mm nodes, frame by frame (the sensor starting above x = `x_mm`)."""

    def frames(spacing_mm: float) -> list[np.ndarray]:
        env = _env(spacing_mm=spacing_mm, x_mm=x_mm, edge_within_node=edge_within_node)
        out = []
        for pose in poses:
            env.move_to(pose)
            out.append(env.observe().pins_px)
        return out

    for coarse, fine in zip(frames(1.5), frames(0.75)):
        distance = np.linalg.norm(coarse - fine, axis=1)
        assert np.sqrt(np.mean(distance**2)) < rms_px
        assert distance.max() < worst_px


@pytest.mark.slow
@pytest.mark.parametrize("edge_mm", [-0.5, 0.0, 0.75, 1.0])
def test_mesh_refinement_of_the_pins(edge_mm):
    """The default spacing (1.5 mm) against half of it (0.75 mm) on a press and a slide
    along the straight edge, with the edge at several places between the nodes (`edge_mm`:
    the sensor's centre that far off the object): pins within 0.25 px RMS and 1.5 px at
    worst. The edge is placed within a node (twin.world.dome.compliant.cut_nodes). Measured at
    these four placements: RMS 0.11–0.15 px, worst pin 0.45–1.12 px; at whole nodes RMS
    0.24–0.36 px, worst 1.37–2.91 px: the test fails at every placement (at 0 mm by the
    slide's 0.26 px RMS). Over edges at
    −1.5 … +1.5 mm against 0.5 mm nodes: RMS 0.12–0.20 px, worst 0.52–1.24 px (at whole
    nodes 0.11–0.45 and 0.71–2.92 px; docs/dome/compliant.md,
    "Where the edge falls between nodes")."""

    x = 60.0 + edge_mm
    poses = (Pose(x, 0, 3, 0, 0, 0), Pose(x, 3, 3, 0, 0, 0))
    _assert_refined(poses, x, edge_within_node=True, rms_px=0.25, worst_px=1.5)


@pytest.mark.slow
def test_mesh_refinement_of_the_pins_at_whole_nodes():
    """The default (contact at whole nodes), 1.5 mm against 0.75 mm nodes, on a press and a
    slide across the straight edge through the centre: pins within 0.4 px RMS and 2 px at
    worst. Measured with the sealed gel: RMS 0.25 / 0.29 / 0.28 px, worst pin 1.43 / 1.63 /
    1.39 px, the pins beside the edge line, which whole nodes place to within half a
    spacing; with the edge elsewhere between the nodes the worst pin is up to 2.9 px
    (docs/dome/compliant.md, "Where the edge falls between nodes")."""

    poses = (Pose(60, 0, 3, 0, 0, 0), Pose(60, 4, 3, 0, 0, 0), Pose(57, 4, 3, 0, 0, 0))
    _assert_refined(poses, 60.0, edge_within_node=False, rms_px=0.4, worst_px=2.0)


def test_an_edge_moving_between_nodes_moves_the_force_and_the_pins_smoothly():
    """A 3 mm press with the straight edge 1 mm onto the sensor … 1.5 mm off it, in steps of
    0.1 mm (frictionless: each press on its own). As the edge leaves, the force falls at
    every step, and no pin's path bends by more than 1.5 px from one step to the next (the
    second difference). Placed within nodes: the force falls by 0.01–0.06 N a step, the
    worst bend 1.1 px. At whole nodes the force stood still at 3 of the 25 steps and the
    pins jumped, bends of up to 4.7 px."""
    forces, pins = [], []
    for x in np.round(np.arange(59.0, 61.51, 0.1), 3):
        env = _env(("contact",), x_mm=float(x), edge_within_node=True)
        env.move_to(Pose(float(x), 0, 3, 0, 0, 0))
        forces.append(env.observe_frame().contact_force)
        pins.append(env.observe().pins_px)
    assert np.all(np.diff(forces) < -0.005), np.round(forces, 3)
    bend = np.linalg.norm(np.diff(np.array(pins), n=2, axis=0), axis=2)
    assert bend.max() < 1.5, bend.max(axis=1).round(2)


@pytest.mark.parametrize("depth_mm", [2.0, 4.0])
def test_sealed_gel_widens_the_contact(depth_mm):
    """The sealed dome (the default): what a flat press pushes in bulges out elsewhere, on
    the cap and on the free skin beyond it to the equator (that the two together keep the
    gel's volume under every force is tests/world/test_compliance_cache.py's). So the
    contact radius lies between the two closed-form limits of a sphere pressed δ into a
    flat: Hertz's √(Rδ) (the open half-space, whose surface sinks in around the press and
    loses what it takes in) and the geometric overlap √(2Rδ − δ²) (no sink-in at all).
    Measured: the outermost loaded node at 6.9 / 9.9 mm (the open half-space 6.3 / 8.7)
    against Hertz 6.3 / 8.9 and the overlap 8.7 / 12.0 mm; with the gel's pressure on the
    cap alone it was 7.4 / 10.9 mm, which is no limit of the real dome (that cap's extent
    is the model's, not the sensor's)."""
    radii = {}
    for enclosed in (False, True):
        env = _env(("contact",), x_mm=0.0, enclosed=enclosed)
        env.move_to(Pose(0, 0, depth_mm, 0, 0, 0))
        physics = env.physics
        surface = physics.surface
        loaded = np.any(physics.forces != 0.0, axis=1)
        radii[enclosed] = float(np.max(np.linalg.norm(surface.points[loaded, :2], axis=1)))
        if not enclosed:
            volume = surface.area * np.einsum("ij,ij->", surface.normals, physics.displacement)
            pressed_in = surface.area * np.sum(np.abs(physics.displacement @ np.array([0.0, 0.0, 1.0]))[loaded])
            assert volume < -0.5 * pressed_in  # the half-space loses what it takes in
    delta = depth_mm * 1e-3
    hertz, overlap = math.sqrt(R * delta), math.sqrt(2 * R * delta - delta**2)
    spacing = PARAMS.spacing
    assert radii[False] == pytest.approx(hertz, abs=spacing)
    assert max(hertz, radii[False]) < radii[True] < overlap


def test_skin_membrane_obeys_laplace_law():
    """A spherical membrane moved outwards by w is stretched by w/R both ways, which takes
    a pressure p = 2 E t w / ((1 − ν) R²) (Laplace's law): the nodal forces of the skin's
    stiffness, per node area, within 1 % on average away from the base (the skin to the
    equator; measured −0.3 %, spread 1.2 %). A rigid rotation about the sphere's centre
    stretches nothing but the springs that hold the skin at the equator."""
    from twin.core.sensor import TacTipGeometry
    from twin.world.dome.compliant.compliance import CapSurface, membrane_stiffness

    surface = CapSurface(TacTipGeometry(), PARAMS.spacing, PARAMS.extent_deg)
    skin = surface.skin_to(90.0)
    young, poisson, thickness = 6e5, 0.5, surface.geometry.skin_thickness
    stiffness = membrane_stiffness(skin, young, poisson, thickness)
    w = 1e-5
    forces = (stiffness @ (w * skin.normals).ravel()).reshape(-1, 3)
    pressure = 2 * young * thickness * w / ((1 - poisson) * R * R)
    inner = skin.polar < math.radians(80.0)
    normal = np.einsum("ij,ij->i", forces, skin.normals)[inner] / surface.area
    assert np.mean(normal) == pytest.approx(pressure, rel=0.01)
    assert np.std(normal) < 0.02 * pressure
    tangential = forces[inner] - (normal * surface.area)[:, None] * skin.normals[inner]
    assert np.abs(tangential).max() < 0.02 * pressure * surface.area
    spin = np.cross([0.3, -0.2, 0.5], skin.points - [0.0, 0.0, surface.geometry.sphere_centre_z]) * 1e-3
    assert np.abs((stiffness @ spin.ravel()).reshape(-1, 3)[~skin.held]).max() < 1e-9 * pressure * surface.area


def test_a_thickening_skin_obeys_laplace_law_with_its_local_thickness():
    """A skin whose thickness t(θ) grows from t₀ at the apex to 3 t₀ at the equator, moved
    outwards by w, is still stretched by w/R both ways, so its stress resultant is
    N(θ) = E t(θ) w / ((1 − ν) R): the normal load per area is Laplace's 2N/R with the
    local thickness, and the resultant's gradient along the meridian takes a load
    −N′(θ)/R per area there (the membrane's meridional equilibrium,
    dN_θ/dθ + (N_θ − N_φ) cot θ + R p_θ = 0 with N_θ = N_φ). Away from the base: normal
    within 1 % on average (measured −0.2 %, spread 1.2 %), meridional within 3 % on average
    (+0.3 %; the difference quotient of a lattice scatters 8 %), azimuthal under a quarter
    of the meridional (17 %). Uniform thickness would miss the normal load by up to 3×."""
    from twin.core.sensor import TacTipGeometry
    from twin.world.dome.compliant.compliance import CapSurface, membrane_stiffness, skin_thickness

    surface = CapSurface(TacTipGeometry(), PARAMS.spacing, PARAMS.extent_deg)
    skin = surface.skin_to(90.0)
    young, poisson, apex, thickening, w = 6e5, 0.5, surface.geometry.skin_thickness, 3.0, 1e-5
    thickness = skin_thickness(skin, apex, thickening)
    forces = (membrane_stiffness(skin, young, poisson, thickness) @ (w * skin.normals).ravel()).reshape(-1, 3)
    per_area = np.einsum("ia,ija->ij", forces, skin.frames) / surface.area  # normal, meridional, azimuthal
    inner = skin.polar < math.radians(80.0)
    laplace = 2 * young * thickness * w / ((1 - poisson) * R * R)
    normal = per_area[inner, 0] / laplace[inner]
    assert np.mean(normal) == pytest.approx(1.0, abs=0.01)
    assert np.std(normal) < 0.02
    gradient = -young * w * apex * (thickening - 1) / (math.pi / 2) / ((1 - poisson) * R * R)
    assert np.mean(per_area[inner, 1]) / gradient == pytest.approx(1.0, abs=0.03)
    assert np.abs(per_area[inner, 2]).max() < 0.25 * abs(gradient)


@pytest.mark.parametrize("centre_deg", [0.0, 45.0, 60.0])
def test_a_thickening_shell_bends_with_its_local_rigidity(centre_deg):
    """The shell's rigidity D = E t³ / 12(1 − ν²) follows the local thickness t(θ) (t₀ at
    the apex, 3 t₀ at the equator): a Gaussian dimple (s = 4 mm) centred `centre_deg` from
    the apex costs ½ ∫ D(θ) ((Δ + 2/R²) w)² dA, i.e. its uniform-skin energy times the
    dimple's mean of (t/t₀)³ weighted by ((Δ + 2/R²) w)², which quadrature over the
    dimple gives (1.85 at the apex, 8.37 at 45°, 13.1 at 60°). Within 2.5 % (measured
    −0.1 to +1.3 %)."""
    from twin.core.sensor import TacTipGeometry
    from twin.world.dome.compliant.compliance import CapSurface, bending_stiffness, skin_thickness

    young, poisson, apex, thickening, c, s = 6e5, 0.5, 0.0015, 3.0, 1e-4, 0.004
    skin = CapSurface(TacTipGeometry(), PARAMS.spacing, PARAMS.extent_deg).skin_to(90.0)
    centre = math.radians(centre_deg)
    d = np.linspace(0.0, 6 * s, 600)[:, None]  # geodesic distance and bearing about the dimple's centre
    bearing = np.linspace(0.0, 2 * math.pi, 181)[None, :-1]
    w = c * np.exp(-(d**2) / (2 * s * s))
    density = (w * (d**2 / s**4 - 2 / s**2) + 2 * w / R**2) ** 2 * np.sin(d / R) * np.ones_like(bearing)
    polar = np.arccos(np.cos(centre) * np.cos(d / R) + np.sin(centre) * np.sin(d / R) * np.cos(bearing))
    theory = float(np.sum((1 + (thickening - 1) * polar / (math.pi / 2)) ** 3 * density) / np.sum(density))
    along = R * np.arccos(np.clip(skin.normals @ [math.sin(centre), 0.0, math.cos(centre)], -1.0, 1.0))
    dimple = (c * np.exp(-(along**2) / (2 * s * s))[:, None] * skin.normals).ravel()
    uniform = dimple @ bending_stiffness(skin, young, poisson, apex) @ dimple
    thickened = dimple @ bending_stiffness(skin, young, poisson, skin_thickness(skin, apex, thickening)) @ dimple
    assert thickened / uniform == pytest.approx(theory, rel=0.025)


def test_skin_bending_energy_of_a_dimple_matches_plate_theory():
    """A shallow Gaussian dimple w = c exp(−d²/2s²) (d: arc length from the apex) bends the
    skin with energy ½ D ∫ ((Δ + 2/R²) w)² dA = π D c² (1/s² − 2/R² + 2 s²/R⁴) for s ≪ R
    (the plate's ∫ (Δw)² = 2π c²/s², with the sphere's 2/R² terms; D = E t³ / 12(1 − ν²)).
    The cotangent discretisation is within 5 % of it at the default spacing (measured
    4.2 % low, s = 4 mm, on the skin to the equator) and converges: within 2 % at 1 mm
    (1.5 %). A rigid translation
    of the same size costs less than 0.1 % of it, a rotation nothing."""
    from twin.core.sensor import TacTipGeometry
    from twin.world.dome.compliant.compliance import CapSurface, bending_stiffness

    young, poisson, thickness, c, s = 6e5, 0.5, 0.0015, 1e-4, 0.004
    rigidity = young * thickness**3 / (12 * (1 - poisson**2))
    theory = math.pi * rigidity * c * c * (1 / s**2 - 2 / R**2 + 2 * s**2 / R**4)
    for spacing, tolerance in ((PARAMS.spacing, 0.05), (0.001, 0.02)):
        skin = CapSurface(TacTipGeometry(), spacing, PARAMS.extent_deg).skin_to(90.0)
        stiffness = bending_stiffness(skin, young, poisson, thickness)

        def energy(u: np.ndarray, stiffness: np.ndarray = stiffness) -> float:
            return 0.5 * float(u.ravel() @ stiffness @ u.ravel())

        dimple = c * np.exp(-((R * skin.polar) ** 2) / (2 * s * s))[:, None] * skin.normals
        assert energy(dimple) == pytest.approx(theory, rel=tolerance)
        for axis in np.eye(3):
            assert energy(np.tile(c * axis, (len(skin.points), 1))) < 1e-3 * theory
        spin = np.cross([0.3, -0.2, 0.5], skin.points - [0.0, 0.0, TacTipGeometry().sphere_centre_z]) * 1e-3
        assert energy(spin) < 1e-9 * theory


def test_skin_pretension_costs_the_laplace_beltrami_eigenvalues():
    """A skin stretched by T (N/m) over the gel whose pressure 2T/R holds it stores
    ½ T ∫ (|∇w|² − 2w²/R²) dA for a normal displacement w. A spherical harmonic
    w = P_l^m(cos θ) cos mφ is an eigenfunction of the sphere's Laplace–Beltrami operator,
    −Δw = l(l+1)/R² w, and with l + m odd it vanishes at the equator, where the base holds
    the skin: its energy is ½ T (l(l+1) − 2)/R² ∫ w² dA exactly. The cotangent
    discretisation gives it within 4 % for l = 2…9 at the default spacing (measured 2.6–3.9 %
    low) and converges, within 2.5 % at 1 mm (1.2–2.1 %). Rigid translations (l = 1) cost
    under 2 % of the lowest deforming mode's (l = 2) per unit ∫ w² (measured 0.5–1.0 %)."""
    from scipy.special import lpmv

    from twin.core.sensor import TacTipGeometry
    from twin.world.dome.compliant.compliance import CapSurface, tension_stiffness

    tension = 50.0
    for spacing, tolerance in ((PARAMS.spacing, 0.04), (0.001, 0.025)):
        surface = CapSurface(TacTipGeometry(), spacing, PARAMS.extent_deg)
        skin = surface.skin_to(90.0)
        stiffness = tension_stiffness(skin, tension)
        azimuth = np.arctan2(skin.normals[:, 1], skin.normals[:, 0])

        def per_area(w: np.ndarray, stiffness: np.ndarray = stiffness, skin=skin, area=surface.area) -> float:
            """wᵀKw / ∫ w² dA (N/m³) for normal displacements w at the nodes (each carries `area`)."""
            u = (w[:, None] * skin.normals).ravel()
            return float(u @ stiffness @ u) / (area * float(w @ w))

        for degree, order in ((2, 1), (3, 0), (4, 1), (5, 0), (6, 3), (7, 0), (9, 0)):
            w = lpmv(order, degree, np.cos(skin.polar)) * np.cos(order * azimuth)
            theory = tension * (degree * (degree + 1) - 2) / R**2
            assert per_area(w) == pytest.approx(theory, rel=tolerance)
        for axis in np.eye(3):
            assert abs(per_area(skin.normals @ axis)) < 0.02 * tension * 4 / R**2


#: where the cap that can take contact ends instead of 65°, below the default's 75° hold (deg)
CAP_END_DEG = 70.0


@pytest.mark.parametrize("body", ["plain_solid", "default"])
def test_the_pins_do_not_depend_on_where_the_cap_ends(monkeypatch, body):
    """The cap that can take contact ends at a numerical choice (65°); the skin and the
    gel's pressure go on beyond it, down to where the base holds the skin, so moving the
    cap's end to 70° moves no pin on the refinement test's press and slides, on the plain
    solid and on the default dome (its skin held at 75°). Measured: 0.0001 px RMS,
    0.0003 px at worst on the solid; 0.005–0.013 px RMS, 0.04 px at worst on the default. (With the
    pressure on the cap alone the pins moved 0.78–1.67 px RMS, 3.7 px at worst; with the
    skins ending at the cap's rim, held there by springs, 1.5–2.8 px RMS, 4.2–7.5 px at
    worst.)"""

    def frames() -> list[np.ndarray]:
        env = _env(x_mm=60.0, body=PLAIN if body == "plain_solid" else {})
        out = []
        for pose in (Pose(60, 0, 3, 0, 0, 0), Pose(60, 4, 3, 0, 0, 0), Pose(57, 4, 3, 0, 0, 0)):
            env.move_to(pose)
            out.append(env.observe().pins_px)
        return out

    at_65 = frames()
    monkeypatch.setitem(COMPLIANT_LEVELS, "default", COMPLIANT_LEVELS["default"].with_(extent_deg=CAP_END_DEG))
    for short, long in zip(at_65, frames()):
        assert np.linalg.norm(short - long, axis=1).max() < 0.1
