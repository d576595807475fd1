"""The sealed gel's influence matrices are computed once per surface and Poisson's ratio
and cached on disk at unit shear modulus (twin.world.dome.compliant.compliance.sealed_gel): what
that relies on, and that a cached dome is the computed one. And the compiled products
that each contact increment takes of them are the matrices' own."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from twin.core.sensor import TacTipGeometry
from twin.world.dome.compliant.compliance import (
    CapSurface,
    DomeCompliance,
    disc_averaged_kernel,
    half_space_columns,
    pin_tip_kernel,
    sealed_gel,
    self_compliance,
    skinned,
    sway_block,
)
from twin.world.dome.compliant.contact import UNKNOWN_SIGNS, unknowns_matrix

SURFACE = CapSurface(TacTipGeometry(), 0.0025, 65.0)  # the fast level's nodes: quick to compute


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TWIN_CACHE", str(tmp_path))
    return tmp_path / "compliance"


def test_elastic_columns_scale_as_one_over_the_shear_modulus():
    """Linear elasticity at a fixed ν: displacement ∝ 1/G (what lets one cached matrix
    serve every modulus)."""
    nodes = np.array([0, 40, 200])
    unit = half_space_columns(SURFACE, nodes, 0.45, 1.0)
    for g in (1.0e4, 3.3e5):
        for at_g, at_one in zip(half_space_columns(SURFACE, nodes, 0.45, g), unit):
            assert np.allclose(at_g * g, at_one, rtol=1e-12, atol=1e-12 * np.abs(at_one).max())


def test_held_at_the_cap_s_rim_the_cap_keeps_the_gel_s_volume():
    """ν = 0.5, sealed, the base holding the skin at the cap's rim (`held_deg` = the cap's
    extent: no free skin beyond it): no force changes the cap's volume, Σ A n·u = 0 for
    every column, but for the open half-space's asymmetry (the pressure mode is
    symmetrised; measured 0.12 % of the loss); the open half-space's columns lose volume."""
    n = SURFACE.count
    nodes, _ = sealed_gel(SURFACE, 0.5, held_deg=SURFACE.extent_deg)
    sealed = np.einsum("jbia,ia->jb", nodes, SURFACE.area * SURFACE.normals)
    open_nodes, _ = half_space_columns(SURFACE, np.arange(n), 0.5, 1.0)
    lost = np.einsum("jbia,ia->jb", open_nodes, SURFACE.area * SURFACE.normals)
    assert np.abs(sealed).max() < 0.005 * np.abs(lost).max()
    with pytest.raises(ValueError, match="between the cap's rim"):
        DomeCompliance(SURFACE, 5.3e4, 0.5, skin_held_deg=60.0)


@pytest.mark.parametrize("held_deg", [90.0, 65.0])
def test_a_skin_without_stiffness_leaves_the_sealed_gel(held_deg):
    """A skinned dome models skin and gel to the equator without condensing the band
    (`skinned`); with a skin of no stiffness it is the sealed gel, whose band enters
    condensed (`sealed_gel`): the nodes' matrix (symmetrised, as the skinned one is) and
    the pins' to round-off, with the base holding the skin at the equator or at the
    cap's rim."""
    cap = 3 * SURFACE.count
    nodes, pins = skinned(SURFACE, 0.5, 1.0, 0.0, held_deg=held_deg)
    gel_nodes, gel_pins = sealed_gel(SURFACE, 0.5, held_deg)
    gel_nodes = gel_nodes.reshape(cap, cap)
    expected = 0.5 * (gel_nodes + gel_nodes.T)
    assert np.allclose(nodes.reshape(cap, cap), expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    assert np.allclose(pins, gel_pins, rtol=0, atol=1e-12 * np.abs(gel_pins).max())


def test_the_free_skin_to_the_equator_is_sealed_with_the_cap():
    """With the skin free to the equator (the base holding it there, the default), the
    cap's matrices are those of sealing cap and band as one surface, built here directly
    from the half-space kernel over all their nodes; that whole surface keeps its volume
    under every force, while the cap alone now gives some of it to the band."""
    band_points, band_frames = SURFACE.band_to(90.0)
    points = np.concatenate([SURFACE.points, band_points])
    frames = np.concatenate([SURFACE.frames, band_frames])
    count, radius = len(points), np.sqrt(SURFACE.area / np.pi)
    whole = disc_averaged_kernel(points, points, frames, radius, 0.5, 1.0)  # [point, a, source, b]
    whole[np.arange(count), :, np.arange(count), :] = self_compliance(frames[:, 0], SURFACE.area, 0.5, 1.0)
    whole = whole.reshape(3 * count, 3 * count)
    pins = pin_tip_kernel(SURFACE, points, frames, radius, 0.5, 1.0).reshape(-1, 3 * count)
    pressure = (SURFACE.area * frames[:, 0]).ravel()
    h = 0.5 * (whole @ pressure + whole.T @ pressure)
    sealed = whole - np.outer(h, h) / (pressure @ h)
    sealed_pins = pins - np.outer(pins @ pressure, h) / (pressure @ h)

    cap = 3 * SURFACE.count
    nodes, cap_pins = sealed_gel(SURFACE, 0.5)
    expected = sealed[:cap, :cap]
    assert np.allclose(nodes.reshape(cap, cap).T, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    expected_pins = sealed_pins[:, :cap]
    assert np.allclose(cap_pins.reshape(cap, -1).T, expected_pins, rtol=0, atol=1e-9 * np.abs(expected_pins).max())

    open_loss = np.abs(whole[:, :cap].T @ pressure).max()
    assert np.abs(sealed[:, :cap].T @ pressure).max() < 0.005 * open_loss  # the whole free skin keeps it
    assert np.abs(sealed[:cap, :cap].T @ pressure[:cap]).max() > 0.05 * open_loss  # the cap alone does not


def test_a_cached_dome_is_the_computed_one_at_any_modulus(cache):
    rows = np.arange(0, SURFACE.count, 5)
    computed = DomeCompliance(SURFACE, 5.3e4, 0.5)
    computed.precompute()
    (entry,) = cache.glob("*.npz")
    loaded = DomeCompliance(SURFACE, 5.3e4, 0.5)
    assert np.array_equal(loaded.block(rows, rows), computed.block(rows, rows))
    forces = np.random.default_rng(0).normal(size=(len(rows), 3))
    assert np.array_equal(loaded.pin_displacement(rows, forces), computed.pin_displacement(rows, forces))
    softer = DomeCompliance(SURFACE, 2.0e4, 0.5)
    reference = computed.block(rows, rows) * 5.3e4
    assert np.allclose(softer.block(rows, rows) * 2.0e4, reference, rtol=1e-12, atol=1e-12 * np.abs(reference).max())
    assert list(cache.glob("*.npz")) == [entry]  # the same entry served both moduli
    DomeCompliance(SURFACE, 5.3e4, 0.45).precompute()
    assert len(list(cache.glob("*.npz"))) == 2  # another ν is another entry


def test_the_compiled_products_are_the_matrix_products():
    """`local_block` is `block` turned into each node's frame; `surface_displacement` and
    `pin_displacement` are the columns' sums weighted by the forces."""
    dome = DomeCompliance(SURFACE, 5.3e4, 0.5, enclosed=False)
    nodes = np.array([3, 17, 18, 40, 41, 90, 200])
    frames = Rotation.random(len(nodes), random_state=2).as_matrix()
    block = dome.block(nodes, nodes).reshape(len(nodes), 3, len(nodes), 3)
    turned = np.einsum("iak,ikjl,jbl->iajb", frames, block, frames).reshape(3 * len(nodes), -1)
    assert np.allclose(dome.local_block(nodes, frames), turned, rtol=0.0, atol=1e-12 * np.abs(turned).max())
    # the tip's sway and the solver's signs, as sway_block and unknowns_matrix state them
    sway = 2e-4
    signed = unknowns_matrix(turned + sway_block(frames, sway))
    local = dome.local_block(nodes, frames, sway, UNKNOWN_SIGNS)
    assert np.allclose(local, signed, rtol=0.0, atol=1e-12 * np.abs(signed).max())
    # from an earlier block: other nodes (one gone, one new) and two of the kept ones turned
    later = np.array([3, 18, 40, 41, 77, 90, 200])
    later_frames = frames[[0, 2, 3, 4, 0, 5, 6]].copy()
    later_frames[[1, 5]] = Rotation.random(2, random_state=4).as_matrix()
    fresh = dome.local_block(later, later_frames, sway, UNKNOWN_SIGNS)
    assert np.array_equal(dome.local_block(later, later_frames, sway, UNKNOWN_SIGNS, (nodes, frames, local)), fresh)
    forces = np.random.default_rng(3).normal(size=(len(nodes), 3))
    everywhere = np.arange(SURFACE.count)
    expected = (dome.block(everywhere, nodes) @ forces.ravel()).reshape(-1, 3)
    assert np.allclose(
        dome.surface_displacement(nodes, forces), expected, rtol=0.0, atol=1e-12 * np.abs(expected).max()
    )
    pins = sum(np.einsum("a,aib->ib", forces[k], dome._pins[node]) for k, node in enumerate(nodes))
    assert np.allclose(dome.pin_displacement(nodes, forces), pins, rtol=0.0, atol=1e-12 * np.abs(pins).max())


@pytest.mark.parametrize("membrane_young", [0.0, 6e5])
def test_the_pin_lever_scales_the_tips_swing_about_their_bases(cache, membrane_young):
    """A pin's tip moves with its base plus the lever L times the skin's turn
    (post_tips): linear in L, so a 4 mm lever swings the tips twice as far from where a
    0 mm lever (the bases) puts them as the pins' own 2 mm length, which is the default."""
    nodes, forces = np.array([0, 3, 11]), np.array([[0.0, 0.0, -0.5], [0.1, 0.0, -0.3], [0.0, -0.1, -0.4]])

    def tips(lever: float | None) -> np.ndarray:
        return DomeCompliance(
            SURFACE, 5.3e4, 0.5, enclosed=False, membrane_young=membrane_young, pin_lever=lever
        ).pin_displacement(nodes, forces)

    bases, default = tips(0.0), tips(None)
    swing = default - bases
    assert np.abs(swing).max() > 0.05 * np.abs(bases).max()
    assert np.allclose(tips(TacTipGeometry().pin_length), default, rtol=0, atol=1e-12)
    assert np.allclose(tips(0.004) - bases, 2.0 * swing, rtol=0, atol=1e-6 * np.abs(swing).max())
    with pytest.raises(ValueError, match="pin_lever"):
        DomeCompliance(SURFACE, 5.3e4, 0.5, pin_lever=-0.001)


@pytest.mark.parametrize("lever", [0.002, 0.004])
def test_tips_in_the_gel_move_as_a_point_force_moves_the_half_space_there(cache, lever):
    """With `pins_in_gel` a tip moves with the open half-space's gel `lever` below the
    skin. For an incompressible half-space (ν = 0.5) a point force F on its surface moves
    the point d away by (F/ρ + d (d·F)/ρ³) / 4πG (Boussinesq and Cerruti, Johnson eqs. 3.20
    and 3.21, ρ = |d|). The force on a 1 mm node is spread over its 0.53 mm disc, 3.5–5.5
    mm from the tip under the apex (the 1.5 mm skin and the lever), which takes about
    (a/ρ)² ≈ 1–2 % off: within 2 % of the point force's, where a tip 0.5 mm off that depth
    is 9–14 % off. The posts' tips do not follow it (they turn with the skin)."""
    surface = CapSurface(TacTipGeometry(), 0.001, 65.0)
    g = TacTipGeometry()
    young, shear = 5.3e4, 5.3e4 / 3.0
    node = int(np.argmin(surface.polar))
    bases = g.pin_base_points()
    pin = int(np.argmin(np.hypot(bases[:, 0], bases[:, 1])))
    centre = np.array([0.0, 0.0, g.sphere_centre_z])
    tip = bases[pin] + lever * (centre - bases[pin]) / g.skin_inner_radius
    d = tip - surface.points[node]
    rho = np.linalg.norm(d)
    normal, meridian = surface.frames[node, 0], surface.frames[node, 1]
    for force in (-normal, meridian, 0.6 * meridian - 0.8 * normal):
        expected = (force / rho + d * (d @ force) / rho**3) / (4.0 * np.pi * shear)
        in_gel = DomeCompliance(surface, young, 0.5, enclosed=False, pin_lever=lever, pins_in_gel=True)
        moved = in_gel.pin_displacement(np.array([node]), force[None])[pin]
        assert np.linalg.norm(moved - expected) < 0.02 * np.linalg.norm(expected)
        posts = DomeCompliance(surface, young, 0.5, enclosed=False, pin_lever=lever)
        off = np.linalg.norm(posts.pin_displacement(np.array([node]), force[None])[pin] - expected)
        assert off > 0.1 * np.linalg.norm(expected)


def test_pretension_stiffens_the_skin_and_needs_the_membrane(cache):
    """The skin's pretension (tension_stiffness) only adds stiffness where the skin is
    held: a press on the apex sinks less the more the skin is stretched, and a pretension
    without the membrane that carries it is refused."""
    nodes, forces = np.array([0]), np.array([[0.0, 0.0, -0.5]])
    sink = [
        -DomeCompliance(
            SURFACE, 1.33e4, 0.5, membrane_young=6e5, skin_held_deg=65.0, skin_tension=t
        ).surface_displacement(nodes, forces)[0, 2]
        for t in (0.0, 50.0, 200.0)
    ]
    assert sink[0] > sink[1] > sink[2] > 0
    with pytest.raises(ValueError, match="skin_tension"):
        DomeCompliance(SURFACE, 5.3e4, 0.5, skin_tension=10.0)


def test_a_skin_thickening_to_its_base_stiffens_the_rim_more_than_the_apex(cache):
    """A skin three times as thick at its base as at the apex (`skin_thickness`) resists a
    press near the cap's rim (55° from the apex) far more than a uniform one, and a press
    on the apex, where it is as thick as before, less so (the shell's sink: 0.25 and 0.76 of
    the uniform skin's); a thickening without the membrane is refused."""
    rim = int(np.argmin(np.abs(SURFACE.polar - np.radians(55.0))))

    def sink(node: int, thickening: float) -> float:
        dome = DomeCompliance(SURFACE, 1.33e4, 0.5, membrane_young=6e5, skin_bending=True, skin_thickening=thickening)
        force = -0.5 * SURFACE.normals[node]
        return -float(dome.surface_displacement(np.array([node]), force[None])[node] @ SURFACE.normals[node])

    apex, edge = sink(0, 3.0) / sink(0, 1.0), sink(rim, 3.0) / sink(rim, 1.0)
    assert edge < apex < 1.0
    with pytest.raises(ValueError, match="skin_thickening"):
        DomeCompliance(SURFACE, 5.3e4, 0.5, skin_thickening=2.0)


def test_a_bending_modulus_of_its_own_stiffens_only_the_shell_s_bending(cache):
    """The shell's bending modulus (`bending_young`) defaults to the membrane's: the same
    matrices. A stiffer one resists a press on the apex more, and never more than the
    whole skin made that stiff (membrane and bending); without the shell it is refused."""
    nodes, forces = np.array([0]), np.array([[0.0, 0.0, -0.5]])

    def sink(membrane: float, bending: float | None) -> float:
        dome = DomeCompliance(SURFACE, 1.33e4, 0.5, membrane_young=membrane, skin_bending=True, bending_young=bending)
        return -float(dome.surface_displacement(nodes, forces)[0, 2])

    assert sink(6e5, 6e5) == pytest.approx(sink(6e5, None), rel=1e-12)
    assert sink(6e5, None) > sink(6e5, 4e6) > sink(4e6, None) > 0
    with pytest.raises(ValueError, match="bending_young"):
        DomeCompliance(SURFACE, 5.3e4, 0.5, membrane_young=6e5, bending_young=4e6)
