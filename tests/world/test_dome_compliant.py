"""Hard cases of the compliant dome's contact problem (twin.world.dome.compliant) at every
fidelity level, and its failures: each case either runs physically or raises
PhysicsError naming the scenario, the increment, the pose and what failed.

Work frame: +z into the object; the rectangle's +x edge is the line x = 60.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from twin.core.errors import PhysicsError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment
from twin.world.dome.compliant import COMPLIANT_LEVELS, PLAIN_SOLID, CompliantPhysics
from twin.world.dome.compliant import contact as compliant_contact
from twin.world.dome.compliant import physics as compliant_physics

LEVELS = list(COMPLIANT_LEVELS)
#: the default level as the plain solid, without the skin (PLAIN_SOLID)
PLAIN = "default+plain_solid"
BODIES = {PLAIN: PLAIN_SOLID}
#: the very high friction per level: μ = 3 (rubber on a sticky surface), but μ = 2 at the
#: reference level, whose 1 mm nodes under the skin give the μ = 3 reversal several
#: solutions, so that it tests no solver there (docs/real-sensor.md,
#: "Rising friction for the solver, and increments with several solutions")
VERY_HIGH_FRICTION = {"fast": 3.0, "default": 3.0, "reference": 2.0}


def _env(
    level: str,
    obj: dict | None = None,
    material: dict | None = None,
    start: Pose = Pose(60, 0, -2, 0, 0, 0),
    effects: tuple[str, ...] = ("contact", "friction"),
    name: str = "compliant_case",
) -> SimEnvironment:
    spec = {
        "name": name,
        "object": obj or {"name": "rectangle"},
        "dome": "compliant",
        "fidelity": "default" if level in BODIES else level,
        "effects": list(effects),
        "physics": BODIES.get(level, {}),
    }
    if material is not None:
        spec["sensor"] = {"calibration": {"dome_material": material}}
    env = SimEnvironment(scenario_from_dict(spec), start_pose=start)
    env.reset()
    return env


def _slide_and_back(env: SimEnvironment, depth: float = 3.0, speed: float = 20.0) -> np.ndarray:
    """Press on the edge, slide 6 mm along it, reverse 12 mm, come back: the contact force
    (N, tool frame) at each of the 4 frames, (4, 3)."""
    forces = []
    for y in (0.0, 6.0, -6.0, 0.0):
        env.move_to(Pose(60, y, depth, 0, 0, 0), speed)
        forces.append(env.observe_frame().contact_force_tool)
    return np.array(forces)


@pytest.mark.parametrize(
    "level,friction",
    [(level, mu) for level in LEVELS for mu in (0.0, VERY_HIGH_FRICTION[level])],
)
def test_frictionless_and_very_high_friction(level, friction):
    """μ = 0: no tangential force at all; μ = 2–3: the skin sticks, the tangential force
    stays below μ·P and changes sign with the direction. The skin shell couples normal and
    tangential motion strongly: Newton stalls at some increments of this path, and the
    friction path and the alternation finish them (without them μ = 2 and 3 raised
    PhysicsError over a skin)."""
    env = _env(level, obj={"name": "rectangle", "friction": friction})
    forces = _slide_and_back(env)
    tangential, normal = np.linalg.norm(forces[:, :2], axis=1), np.abs(forces[:, 2])
    if friction == 0.0:
        assert tangential.max() < 1e-9
    else:
        assert tangential.max() > 0.2
        # Coulomb's bound on the totals, frame by frame, to the solver's tolerance: 0.1 µm
        # of slip or gap is r·0.1 µm of force at a node of stiffness r (N/m), up to 0.03 %
        # of μ·p over the stiff skin membrane
        assert np.all(tangential <= 1.01 * friction * normal)


def test_where_newton_stalls_it_follows_the_friction_up(monkeypatch):
    """The default dome (the DigiTac fit, its stiffness scaled to the 4.3 N press:
    docs/real-sensor.md, "The fitted dome's stiffness scale") on 1.0 mm nodes at μ = 3: pressing 3 mm onto the edge, Newton stalls from the warm start at every
    augmentation parameter (docs/measurements/finding-2026-12-05-shipped-scenarios,
    newton-stall.txt). Followed up from lower friction, Newton itself solves those
    increments, where the alternation took 51 s; the forces keep Coulomb's bound."""
    frictions, passes = [], []
    newton, alternation = compliant_contact._newton, compliant_contact.alternation_pass

    def newton_seen(matrix, offset, friction, *args):
        frictions.append(friction)
        return newton(matrix, offset, friction, *args)

    def alternation_seen(*args, **kwargs):
        passes.append(1)
        return alternation(*args, **kwargs)

    monkeypatch.setattr(compliant_contact, "_newton", newton_seen)
    monkeypatch.setattr(compliant_contact, "alternation_pass", alternation_seen)
    spec = {
        "name": "stall",
        "object": {"name": "rectangle", "friction": 3.0},
        "dome": "compliant",
        "physics": {"surface_spacing_mm": 1.0},
    }
    env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(60, 0, -2, 0, 0, 0))
    env.reset()
    env.move_to(Pose(60, 0, 3.0, 0, 0, 0), 20.0)
    assert any(0.0 < mu < 3.0 for mu in frictions)  # Newton stalled at μ and took the path
    assert passes == []  # and the path solved every increment
    force = env.observe_frame().contact_force_tool
    assert 2.0 < abs(force[2]) and np.linalg.norm(force[:2]) <= 1.01 * 3.0 * abs(force[2])


@pytest.mark.parametrize("level", ["fast", "default"])
@pytest.mark.parametrize("poisson", [0.3, 0.499, 0.5])
def test_poisson_ratio_down_to_compressible_and_up_to_incompressible(level, poisson):
    """ν = 0.5 decouples normal and tangential problems; ν < 0.5 couples them (solved
    jointly). Nearly incompressible gel (0.499) is as stable as 0.5, and its pins are
    within 0.2 px of it (no locking: the influence model has no volume elements). At the
    fast and default levels: the reference level runs the same code on 1 mm nodes, where
    each ν's skinned influence matrices take the suite 25–30 s to compute."""
    env = _env(level, material={"poisson": poisson})
    _slide_and_back(env)
    pins = env.observe().pins_px
    assert np.isfinite(pins).all()
    if poisson == 0.499:
        reference = _env(level, material={"poisson": 0.5})
        _slide_and_back(reference)
        assert np.max(np.abs(pins - reference.observe().pins_px)) < 0.2


@pytest.mark.parametrize("level", LEVELS)
def test_fast_slides_and_reversals(level):
    """250 mm/s (the protocols' limit) gives the nominal speed's pins: quasi-static."""
    slow, fast = _env(level), _env(level)
    _slide_and_back(slow, speed=20.0)
    _slide_and_back(fast, speed=250.0)
    assert np.array_equal(slow.observe().pins_px, fast.observe().pins_px)


@pytest.mark.parametrize("level", LEVELS)
def test_grazing_contact(level):
    """A 50 µm touch: a handful of nodes, a tiny force, pins within a fraction of a pixel."""
    env = _env(level, start=Pose(0, 0, -1, 0, 0, 0))
    rest = env.observe().pins_px
    env.move_to(Pose(0, 0, 0.05, 0, 0, 0))
    frame = env.observe_frame()
    assert 0.0 < frame.contact_force < 0.05
    assert np.max(np.linalg.norm(env.observe().pins_px - rest, axis=1)) < 0.2


@pytest.mark.parametrize("level", LEVELS)
def test_contact_across_two_convex_pieces(level):
    """The flower is 36 convex collision pieces; 40 mm from its centre the contact spans
    its central piece and several of a petal's, and a slide there crosses their seams."""
    env = _env(level, obj={"name": "flower"}, start=Pose(40, -2, -2, 0, 0, 0))
    env.move_to(Pose(40, -2, 3, 0, 0, 0))
    env.move_to(Pose(40, 2, 3, 0, 0, 0))
    assert len(env.physics.touched_geoms()) >= 2
    assert 1.0 < env.observe_frame().contact_force < 20.0


def test_a_solve_that_does_not_converge_raises_naming_the_case(monkeypatch):
    monkeypatch.setitem(COMPLIANT_LEVELS, "default", COMPLIANT_LEVELS["default"].with_(max_iterations=1))
    env = _env("default", name="starved_solver")
    with pytest.raises(PhysicsError) as info:
        env.move_to(Pose(60, 0, 3, 0, 0, 0))
    message = str(info.value)
    assert re.search(
        r"\[starved_solver\] increment \d+ \(t = [\d.]+ s\) at pose x=60\.000 y=0\.000 z=[-\d.]+ mm", message
    )
    assert "did not converge" in message


def test_no_contact_effect_solves_nothing():
    """Without `contact` the object has no collision pieces: no ray hits, no problem solved."""
    env = _env("default", effects=())
    env.move_to(Pose(60, 0, 4, 0, 0, 0))
    physics: CompliantPhysics = env.physics
    assert physics.iterations == 0 and physics.solve_seconds == 0.0
    assert env.observe_frame().contact_force == 0.0


def test_a_calibrated_material_maps_only_onto_parameters_the_model_has():
    """Both models take the modulus in kPa and a skin membrane in MPa; the flex grid locks
    at ν = 0.5, refused by name; the compliant dome takes ν = 0.5 and where its skin is
    held (deg), its tip's sway (mm/N), its pins' lever (mm), its skin's adhesion (kPa) and its friction across an edge's round, which the flex grid refuses
    by name. The default dome's material is the fitted one (docs/dome/compliant.md)."""
    from twin.core.errors import UserError
    from twin.world.dome.flex import FIDELITY_LEVELS
    from twin.world.dome.material import apply_dome_material, dome_material_of

    compliant = COMPLIANT_LEVELS["default"]
    assert dome_material_of(compliant) == pytest.approx(
        {
            "young_kpa": 18.78,
            "poisson": 0.5,
            "membrane_young_mpa": 0.2347,
            "skin_held_deg": 75.0,
            "skin_bending_mpa": 0.4068,
            "skin_tension_n_m": 0.0,
            "skin_thickening": 1.0,
            "pin_lever_mm": 1.55,
            "apex_radius_mm": 30.0,
            "tip_sway_mm_per_n": 0.1342,
            "adhesion_kpa": 0.0,
            "edge_friction_ratio": 1.0,
        },
        rel=1e-12,
    )
    assert apply_dome_material(compliant, {"young_kpa": 50.0, "poisson": 0.5}).young == pytest.approx(5e4)
    assert apply_dome_material(compliant, {"membrane_young_mpa": 0.3}).membrane_young == pytest.approx(3e5)
    assert apply_dome_material(compliant, {"skin_held_deg": 70.0}).skin_held_deg == 70.0
    assert apply_dome_material(compliant, {"tip_sway_mm_per_n": 0.3}).tip_sway == pytest.approx(3e-4)
    assert apply_dome_material(compliant, {"skin_tension_n_m": 50.0}).skin_tension == 50.0
    assert apply_dome_material(compliant, {"skin_thickening": 2.0}).skin_thickening == 2.0
    assert apply_dome_material(compliant, {"pin_lever_mm": 3.0}).pin_lever == pytest.approx(3e-3)
    assert apply_dome_material(compliant, {"apex_radius_mm": 30.0}).apex_radius == pytest.approx(0.03)
    assert apply_dome_material(compliant, {"adhesion_kpa": 7.5}).adhesion == pytest.approx(7500.0)
    assert apply_dome_material(compliant, {"edge_friction_ratio": 2.0}).edge_friction == 2.0
    with pytest.raises(UserError, match="edge_friction_ratio"):  # the flex grid's friction is MuJoCo's own
        apply_dome_material(FIDELITY_LEVELS["default"], {"edge_friction_ratio": 2.0})
    with pytest.raises(UserError, match="adhesion_kpa"):  # the flex grid's contact is MuJoCo's own
        apply_dome_material(FIDELITY_LEVELS["default"], {"adhesion_kpa": 7.5})
    with pytest.raises(UserError, match="apex_radius_mm"):  # the flex grid's skin is its own MuJoCo mesh
        apply_dome_material(FIDELITY_LEVELS["default"], {"apex_radius_mm": 30.0})
    with pytest.raises(UserError, match="tip_sway_mm_per_n"):  # the flex grid's tip is its own MuJoCo body
        apply_dome_material(FIDELITY_LEVELS["default"], {"tip_sway_mm_per_n": 0.3})
    with pytest.raises(UserError, match="unknown_kpa"):
        apply_dome_material(compliant, {"unknown_kpa": 0.3})
    with pytest.raises(UserError, match="skin_held_deg"):  # the flex grid has no skin that a base holds
        apply_dome_material(FIDELITY_LEVELS["default"], {"skin_held_deg": 70.0})
    with pytest.raises(UserError, match="pin_lever_mm"):  # the flex grid's pins follow its own skin mesh
        apply_dome_material(FIDELITY_LEVELS["default"], {"pin_lever_mm": 3.0})
    with pytest.raises(UserError, match="poisson"):
        apply_dome_material(FIDELITY_LEVELS["default"], {"poisson": 0.5})


def test_the_increment_length_is_a_scenario_knob():
    """`physics: {increment_mm}` sets the largest tool motion per contact increment: a 3 mm
    slide takes 3 increments at 1 mm and 6 at the default 0.5 mm (a flex scenario refuses it)."""
    from twin.core.errors import UserError
    from twin.runs.spec import dome_params

    spec = {
        "name": "increments",
        "object": {"name": "rectangle"},
        "dome": "compliant",
        "effects": ["contact", "friction"],
    }
    assert dome_params(scenario_from_dict({**spec, "physics": {"increment_mm": 1.0}})).step_length == pytest.approx(
        1e-3
    )
    for physics, increments in (({"increment_mm": 1.0}, 3), ({}, 6)):
        env = SimEnvironment(scenario_from_dict({**spec, "physics": physics}), start_pose=Pose(60, 0, -2, 0, 0, 0))
        env.reset()
        env.move_to(Pose(58, 0, 3, 0, 0, 0))
        before = env.physics.steps
        env.move_to(Pose(58, 3, 3, 0, 0, 0))
        assert env.physics.steps - before == increments
    with pytest.raises(UserError, match="increment_mm"):
        dome_params(scenario_from_dict({**spec, "dome": "flex", "physics": {"increment_mm": 1.0}}))


def test_skin_bending_takes_the_membrane_from_the_calibration():
    """`skin_bending` needs the skin membrane. A calibration's dome material may supply it,
    which the scenario alone cannot see; where neither does, building the dome refuses,
    naming the field."""
    from twin.core.errors import UserError
    from twin.runs.spec import dome_params

    shell = {
        "name": "shell_calibrated",
        "object": {"name": "rectangle"},
        "dome": "compliant",
        "physics": {**PLAIN_SOLID, "skin_bending": True},
    }
    params = dome_params(
        scenario_from_dict({**shell, "sensor": {"calibration": {"dome_material": {"membrane_young_mpa": 0.6}}}})
    )
    assert params.skin_bending and params.membrane_young == pytest.approx(6e5)
    without = scenario_from_dict({**shell, "sensor": {"calibration": {"dome_material": {"young_kpa": 20.0}}}})
    with pytest.raises(UserError, match=r"physics\.skin_bending.*membrane_young_mpa"):
        dome_params(without)


def test_pretension_lever_and_bending_modulus_are_scenario_settings_in_their_units():
    """`physics: {skin_tension_n_m, pin_lever_mm, skin_bending_mpa, pins_in_gel,
    skin_thickening, apex_radius_mm}` set the skin's pretension (N/m), the pins' lever
    (mm → m), the shell's bending modulus (MPa → Pa), whether the tips move with the gel
    (default: posts), how much thicker the skin is at its base (–) and the apex profile's
    radius (mm → m);
    over the plain solid, a pretension without the skin membrane or a bending modulus
    without the shell is refused, naming the field, and a value out of bounds names its field too."""
    from twin.core.errors import UserError
    from twin.runs.spec import dome_params

    spec = {"name": "tensioned", "object": {"name": "rectangle"}, "dome": "compliant", "physics": PLAIN_SOLID}
    params = dome_params(
        scenario_from_dict(
            {
                **spec,
                "physics": {**PLAIN_SOLID, "membrane_young_mpa": 0.6, "skin_tension_n_m": 50.0, "pin_lever_mm": 4.0},
            }
        )
    )
    assert params.skin_tension == 50.0 and params.pin_lever == pytest.approx(4e-3) and not params.pins_in_gel
    assert params.material[-5:] == (50.0, pytest.approx(4e-3), None, False, 1.0)
    in_gel = dome_params(
        scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "pin_lever_mm": 3.0, "pins_in_gel": True}})
    )
    assert in_gel.pins_in_gel and in_gel.material[-2] is True
    thick = dome_params(
        scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "membrane_young_mpa": 0.6, "skin_thickening": 2.5}})
    )
    assert thick.skin_thickening == 2.5 and thick.material[-1] == 2.5
    with pytest.raises(UserError, match="skin_thickening"):
        dome_params(
            scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "membrane_young_mpa": 0.6, "skin_thickening": 9.0}})
        )
    with pytest.raises(UserError, match=r"skin_thickening = 2 \(in `physics`.*membrane_young_mpa"):
        dome_params(scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "skin_thickening": 2.0}}))
    with pytest.raises(UserError, match=r"skin_tension_n_m = 50 \(in `physics`.*membrane_young_mpa"):
        dome_params(scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "skin_tension_n_m": 50.0}}))
    # a calibration's dome material may set the pretension (twin calibrate fits it), and is refused alike
    calibrated = {"sensor": {"calibration": {"dome_material": {"membrane_young_mpa": 0.6, "skin_tension_n_m": 30.0}}}}
    assert dome_params(scenario_from_dict({**spec, **calibrated})).skin_tension == 30.0
    alone = {"sensor": {"calibration": {"dome_material": {"skin_tension_n_m": 30.0}}}}
    with pytest.raises(UserError, match=r"skin_tension_n_m = 30 \(in `physics` or the calibration"):
        dome_params(scenario_from_dict({**spec, **alone}))
    shell = {**PLAIN_SOLID, "membrane_young_mpa": 0.6, "skin_bending": True, "skin_bending_mpa": 4.0}
    assert dome_params(scenario_from_dict({**spec, "physics": shell})).bending_young == pytest.approx(4e6)
    with pytest.raises(UserError, match=r"physics\.skin_bending_mpa.*skin_bending: true"):
        dome_params(
            scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "membrane_young_mpa": 0.6, "skin_bending_mpa": 4.0}})
        )
    with pytest.raises(UserError, match="pin_lever_mm"):
        dome_params(scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "pin_lever_mm": 9.0}}))
    # the apex profile's radius in mm, the dome's own 20 mm at least
    assert (
        dome_params(scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "apex_radius_mm": 30.0}})).apex_radius
        == 0.03
    )
    with pytest.raises(UserError, match="apex_radius_mm"):
        dome_params(scenario_from_dict({**spec, "physics": {**PLAIN_SOLID, "apex_radius_mm": 15.0}}))


@pytest.mark.parametrize("level", ["default", PLAIN])
def test_each_body_takes_the_same_edge_press_force(level):
    """A 4 mm press centred on a straight edge takes 4.3 N, as the flex model
    (assets/tactip/README.md): the default dome, whose fitted stiffnesses were scaled to it
    (docs/real-sensor.md, "The fitted dome's stiffness scale"), and the plain solid
    (E = 67 kPa) whose modulus was calibrated to it."""
    env = _env(level)
    env.move_to(Pose(60, 0, 4.0, 0, 0, 0), 20.0)
    assert np.linalg.norm(env.observe_frame().contact_force_tool) == pytest.approx(4.3, rel=0.02)


def test_scaling_every_stiffness_scales_the_forces_and_moves_no_pin():
    """Linear elasticity, Signorini's gap and Coulomb's cone are homogeneous in the force:
    every modulus (gel, membrane, bending, pretension) × k and the sway's compliance / k
    give k times every contact force along a frictional path and the same pins. So taps
    without forces (the DigiTac set) fix a dome's stiffness ratios, not their scale
    (docs/real-sensor.md, "The fitted dome's stiffness scale")."""
    skin = {
        "gel_young_kpa": 40.0,
        "membrane_young_mpa": 0.5,
        "skin_bending": True,
        "skin_bending_mpa": 0.8,
        "skin_tension_n_m": 20.0,
        "skin_held_deg": 75.0,
        "pin_lever_mm": 1.55,
        "tip_sway_mm_per_n": 0.06,
    }
    k = 0.4
    softer = skin | {key: skin[key] * k for key in ("gel_young_kpa", "membrane_young_mpa", "skin_bending_mpa")}
    softer |= {"skin_tension_n_m": skin["skin_tension_n_m"] * k, "tip_sway_mm_per_n": skin["tip_sway_mm_per_n"] / k}
    spec = {"name": "scale", "object": {"name": "rectangle"}, "dome": "compliant", "fidelity": "fast"}
    readings = []
    for physics in (skin, softer):
        env = SimEnvironment(scenario_from_dict(spec | {"physics": physics}), start_pose=Pose(60, 0, -2, 0, 0, 0))
        env.reset()
        path = []
        for pose in (Pose(60, 0, 3, 0, 0, 0), Pose(60, 3, 3, 0, 0, 0), Pose(59, 5, 2, 0, 0, 8)):
            env.move_to(pose, 20.0)
            frame = env.observe_frame()
            path.append((frame.contact_force_tool.copy(), frame.pins_tool.copy()))
        readings.append(path)
    for (force, pins), (force_k, pins_k) in zip(*readings, strict=True):
        assert np.linalg.norm(force[:2]) > 0.1  # the path shears the skin
        np.testing.assert_allclose(force_k, k * force, rtol=1e-6, atol=1e-9)
        assert np.abs(pins_k - pins).max() < 1e-9  # m: within the solver's tolerance (0.1 µm) and far below it


@pytest.mark.parametrize("body", ["default", "plain_solid"])
@pytest.mark.parametrize("obj", ["rectangle", "spiral"])
def test_the_clearance_bound_is_never_longer_than_a_ray(obj, body):
    """The dome skips the rays where its contact profile is certainly clear of the object:
    that bound (each piece's bounding box against the sphere through the apex that holds the
    profile) may never exceed the shortest gap along a ray to the object (nor 0 where the
    object is in the profile), at random poses
    and turns around the object, one piece or 94, for the default's flatter apex profile and
    the plain solid's sphere."""
    physics: CompliantPhysics = _env("default" if body == "default" else PLAIN, obj={"name": obj}).physics
    rng = np.random.default_rng(7)
    radius, hits = physics.geometry.dome_outer_radius, 0
    lift = physics._lift if body == "default" else 0.0  # the default's flatter apex profile (30 mm)
    assert (physics._lift is None) == (body == "plain_solid")
    for _ in range(200):
        pose = physics._commanded.copy()
        pose[:3, 3] += rng.uniform(-0.03, 0.03, 3) * [1.0, 1.0, 0.2]
        pose[:3, :3] = pose[:3, :3] @ Rotation.from_rotvec(rng.normal(0.0, 0.3, 3)).as_matrix()
        gaps, frames = physics._contact_geometry(physics._object_pose(pose))
        physics._cast_rays(np.arange(physics.surface.count), gaps, frames)  # every ray, the far ones too
        hit = (physics._ray_dist >= 0.0) & physics._collidable[physics._ray_geom]
        if hit.any():
            hits += 1
            along_ray = physics._ray_dist - radius - lift  # each node's gap along its ray
            # a gap below 0 (the object in the profile) only needs a bound below 0: the rays are skipped above 0
            assert physics._clearance() <= max(along_ray[hit].min(), 0.0) + 1e-12
    assert hits > 100
    if obj == "rectangle":  # 2 mm above its flat top: the bound is close to the truth there
        physics._contact_geometry(physics._object_pose(physics._commanded))
        assert 0.0015 < physics._clearance() <= 0.002 + 1e-9


def test_increments_out_of_reach_cast_no_rays_and_change_nothing():
    """Taps with lifts and traverses between them: the increments the clearance bound
    skips leave every frame's pins and forces bit for bit as solving them does."""

    def taps(skip: bool) -> tuple[np.ndarray, CompliantPhysics]:
        env = _env("default")
        if not skip:
            env.physics._out_of_reach = lambda tool2world: False
        frames = []
        for theta, lateral in ((0, 6), (40, 0), (100, -6)):
            env.move_to(Pose(60 + lateral, 0, -2, 0, 0, theta), 50.0)
            for pose in (
                Pose(60 + lateral, 0, 3, 0, 0, theta),
                Pose(60 + lateral, 6, 3, 0, 0, theta),
                Pose(60 + lateral, 6, -2, 0, 0, theta),
            ):
                env.move_to(pose, 20.0)
                frame = env.observe_frame()
                frames.append(np.concatenate([frame.pins_tool.ravel(), frame.contact_force_tool]))
        return np.array(frames), env.physics

    skipped, physics = taps(True)
    solved, reference = taps(False)
    assert physics.steps == reference.steps and reference.skipped == 0 and physics.skipped > 0.2 * physics.steps
    assert np.array_equal(skipped, solved)


def _pressed_across_a_rounded_edge(physics: dict) -> tuple[np.ndarray, CompliantPhysics]:
    """Frames (pins and force, tool frame) of presses and slides onto, along and off the
    rectangle's edge rounded 1 mm (a mesh of 268 faces), with scenario `physics`."""
    spec = {
        "name": "rays_case",
        "object": {"name": "rectangle", "edge_radius_mm": 1.0},
        "dome": "compliant",
        "effects": ["contact", "friction"],
        "physics": physics,
    }
    env = SimEnvironment(scenario_from_dict(spec), start_pose=Pose(60, 0, -2, 0, 0, 0))
    env.reset()
    frames = []
    for theta, lateral in ((0, 4), (60, -3)):
        env.move_to(Pose(60 + lateral, 0, -1, 0, 0, theta), 50.0)
        for pose in (
            Pose(60 + lateral, 0, 4, 0, 0, theta),
            Pose(60 + lateral, 5, 4, 0, 0, theta),
            Pose(60 + lateral - 3, 5, 3, 0, 0, theta),
            Pose(60 + lateral - 3, 5, -1, 0, 0, theta),
        ):
            env.move_to(pose, 20.0)
            frame = env.observe_frame()
            frames.append(np.concatenate([frame.pins_tool.ravel(), frame.contact_force_tool]))
            if len(frames) == 1:
                env.physics.pressed = env.physics._commanded.copy()
    return np.array(frames), env.physics


@pytest.mark.parametrize("physics", [{}, {"apex_radius_mm": 30, "edge_within_node": True, "pin_lever_mm": 1.55}])
def test_the_rays_left_out_change_nothing(monkeypatch, physics):
    """The dome casts only the rays that can meet the object's bounding box near enough to
    matter: presses and slides across a rounded edge give every frame's pins and forces bit
    for bit as casting every ray does (a slack of 1 m), the flatter apex and edges placed
    within nodes too, while leaving out over a quarter of the rays that face the object's box at a
    pressed frame (the ones the 1 m slack casts)."""
    culled, physics_culled = _pressed_across_a_rounded_edge(physics)
    monkeypatch.setattr(compliant_physics, "CAST_SLACK", 1.0)
    every, physics_every = _pressed_across_a_rounded_edge(physics)
    assert physics_every.steps == physics_culled.steps
    assert np.array_equal(culled, every)
    cast = []
    for physics in (physics_culled, physics_every):  # at the first press (4 mm, 4 mm off the edge)
        physics._contact_geometry(physics._object_pose(physics.pressed))
        cast.append(physics._cast.sum())
    assert 0 < cast[0] < 0.75 * cast[1]


def test_a_node_the_solve_moves_past_its_ray_length_is_cast():
    """Where the solve moves a node whose ray was left out farther than that ray's length
    could rule out, its ray is cast, and its gap and contact frame are those of casting
    every ray: the check against penetration sees it as any other node."""
    env = _env("default", obj={"name": "rectangle", "edge_radius_mm": 1.0})
    env.move_to(Pose(62, 0, 3, 0, 0, 0), 20.0)
    physics: CompliantPhysics = env.physics
    gaps, frames = physics._contact_geometry(physics._object_pose(physics._commanded))
    every_gap, every_frame = gaps.copy(), frames.copy()
    physics._cast_rays(np.arange(physics.surface.count), every_gap, every_frame)
    physics._contact_geometry(physics._object_pose(physics._commanded))  # as it was: the far rays left out
    left_out = np.flatnonzero(~physics._cast)
    seen = left_out[np.isfinite(every_gap[left_out])]
    near, other = seen[np.argmin(every_gap[seen])], seen[np.argmax(every_gap[seen])]
    beyond = physics._cast_length[near] - physics.geometry.dome_outer_radius
    assert every_gap[near] > beyond  # left out rightly: its gap is beyond its ray's length
    displacement = np.zeros((physics.surface.count, 3))
    displacement[other] = [0.0, 0.0, 0.5 * beyond]  # not far enough: stays out
    displacement[near] = [0.0, 0.0, 1.01 * beyond]
    physics._uncast_reached(displacement, gaps, frames)
    assert physics._cast[near] and not physics._cast[other] and np.isinf(gaps[other])
    assert gaps[near] == every_gap[near]
    assert np.array_equal(frames[near], every_frame[near])


def test_the_lattice_interpolates_linearly_within_its_triangles():
    """CapSurface.interpolation, which moves a cut node's force to its part's centroid:
    at points up to a disc's radius from random nodes, the weights are ≥ 0, sum to 1 and
    reproduce the point's own map coordinates (linear precision); at a node, all of it on
    that node."""
    from twin.core.sensor import TacTipGeometry
    from twin.world.dome.compliant.compliance import CapSurface, azimuthal_map

    surface = CapSurface(TacTipGeometry(), 0.0015, 65.0)
    rng = np.random.default_rng(0)
    nodes = rng.choice(np.flatnonzero(~surface.rim), 200, replace=False)
    radius = np.sqrt(surface.area / np.pi)
    offset = rng.uniform(-1, 1, (200, 2)) * radius / np.sqrt(2)
    points = surface.points[nodes] + np.einsum("nk,nkj->nj", offset, surface.tangents[nodes])
    directions = points - [0.0, 0.0, surface.geometry.sphere_centre_z]
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    corners, weights = surface.interpolation(directions, nodes)
    assert weights.min() >= -1e-9 and np.allclose(weights.sum(axis=1), 1.0)
    mapped = np.einsum("nk,nkj->nj", weights, azimuthal_map(surface.normals)[corners])
    assert np.abs(mapped - azimuthal_map(directions)).max() < 1e-12
    at_nodes, on_node = surface.interpolation(surface.normals[nodes], nodes)
    assert np.allclose(np.einsum("nk,nk->n", on_node, at_nodes == nodes[:, None]), 1.0)


@pytest.mark.parametrize("offset", [-0.6, -0.3, 0.0, 0.3, 0.6])
def test_a_straight_boundary_covers_a_disc_as_its_segment_does(offset):
    """twin.world.dome.compliant.cut_nodes on a disc whose samples see a flat face on one
    side of a straight line `offset` radii from the centre: the covered share is the
    circular segment's area fraction to within the samples' resolution (0.1: a row of up to
    three of the 19 samples on the line; measured 0.00–0.09), the centroid lies on the
    face's side of the line, and the gap and normal are the face's."""
    from twin.world.dome.compliant.cut_nodes import DISC_SAMPLES, cut_nodes

    radius, depth = 1e-3, 2e-4  # m; the face stands `depth` into the dome everywhere
    xy = DISC_SAMPLES[:, :2] * radius
    directions = np.column_stack([xy, np.ones(len(xy))])  # near-vertical rays through the disc
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    on_face = xy[:, 0] < offset * radius
    along = np.where(on_face, -depth / directions[:, 2], 1.0)
    normals = np.tile([0.0, 0.0, -1.0], (len(xy), 1))  # as a ray cast gives it
    cut = cut_nodes(
        np.array([7]),
        directions[None],
        on_face[None],
        along[None],
        normals[None],
        np.zeros((1, len(xy)), int),
        None,
        1e-3,
    )
    d = offset  # the segment x < d·r of the unit disc
    fraction = (np.arccos(-d) + d * np.sqrt(1 - d * d)) / np.pi
    assert cut.nodes.tolist() == [7]
    assert cut.covered[0] == pytest.approx(fraction, abs=0.1)
    assert cut.centroids[0, 0] / cut.centroids[0, 2] < offset * radius
    assert cut.gaps[0] == pytest.approx(-depth, rel=1e-9)
    assert cut.normals[0] == pytest.approx([0.0, 0.0, 1.0])
