"""The sub-grid skin layer (twin.world.dome.flex.skin) on the edge scene (twin.world.dome.testbed.edge_scene: box top
face z = 0, straight edge along y at x = 0, box at x < 0; TacTip pointing down). No mocks."""

from __future__ import annotations

import numpy as np
import pytest

from twin.core.errors import PhysicsError
from twin.core.sensor import TacTipGeometry
from twin.world.dome.flex import FIDELITY_LEVELS
from twin.world.dome.flex.skin import SkinLayer
from twin.world.dome.testbed import edge_scene, sensor_down

DEFAULT = FIDELITY_LEVELS["default"]


def _skin_offsets(x_mm: float, depth_mm: float, gamma_deg: float = 0.0, params=DEFAULT) -> np.ndarray:
    """(127, 3) skin offsets (m) of a frictionless static press at (x, 0, depth, γ)."""
    _, _, _, physics = edge_scene(params, friction=False, start_tool2world=sensor_down(x_mm, 0, -1, gamma_deg))
    physics.move(sensor_down(x_mm, 0, depth_mm, gamma_deg), 15.0)
    physics.settle()
    return physics._skin_offsets()


def test_rays_see_the_object_not_the_dome():
    model, data, handles, physics = edge_scene(DEFAULT, start_tool2world=sensor_down(0, 0, -1))
    physics.settle()
    assert not np.any(physics.skin.penetration(model, data, physics._tool2scene, handles.dome_body) > 0)
    physics.move(sensor_down(-5, 0, 3), 15.0)
    physics.settle()
    delta = physics.skin.penetration(model, data, physics._tool2scene, handles.dome_body)
    assert delta.max() == pytest.approx(3e-3, abs=1e-5)  # the apex is 3 mm into the face
    on_object = physics.skin.nodes[delta > 0]
    # tool x = world x + 5 mm: the edge lies at tool x = 5 mm, the face at x < 5 mm
    assert on_object[:, 0].max() > 3e-3  # the contact reaches the edge …
    # … and stops there (a node just beyond x = 5 mm whose radius meets the face inside it counts)
    assert on_object[:, 0].max() < 5.5e-3


def test_tilt_is_local_and_zero_mean_at_an_edge():
    off = _skin_offsets(2.0, 4.0)
    size = np.linalg.norm(off, axis=1)
    assert size.max() > 0.5e-3  # pins at the contact's border swing by ≳ 0.5 mm (≈ 6 px)
    assert np.linalg.norm(off[:, :2].mean(axis=0)) < 0.15 * np.sqrt(np.mean(size**2))
    roots = TacTipGeometry().pin_tip_points()
    far = roots[:, 0] > 6e-3  # tool x = world x − 2 mm: the object is x < −2 mm, these pins lie 8 mm beyond its edge
    assert size[far].max() < 0.2 * size.max()


def test_deeper_press_tilts_more():
    assert np.abs(_skin_offsets(0.0, 4.0)).sum() > 1.3 * np.abs(_skin_offsets(0.0, 2.0)).sum()


def test_turning_the_sensor_turns_the_pattern():
    """An edge pressed at γ = 60° gives the γ = 0 pattern turned by 60° (the layer has no grid
    axes): compare the offsets as vector fields sampled at the same places."""
    a = _skin_offsets(1.0, 3.0, 0.0)
    b = _skin_offsets(1.0, 3.0, 60.0)
    roots = TacTipGeometry().pin_tip_points()[:, :2]
    turn = np.radians(60.0)
    # sensor_down flips world y into tool −y, so a γ turn of the sensor turns the world by −γ in the tool frame
    rot = np.array([[np.cos(turn), np.sin(turn)], [-np.sin(turn), np.cos(turn)]])
    # b's field sampled at rot·r should equal rot applied to a's field at r: nearest-pin lookup
    moved = roots @ rot.T
    nearest = np.argmin(np.linalg.norm(moved[:, None, :] - roots[None, :, :], axis=2), axis=1)
    expected = a[:, :2] @ rot.T
    err = np.sqrt(np.mean(np.sum((b[nearest, :2] - expected) ** 2, axis=1)))
    assert err < 0.35 * np.sqrt(np.mean(np.sum(a[:, :2] ** 2, axis=1)))


def test_contact_beyond_the_modelled_cap_raises():
    params = DEFAULT.with_(skin_extent_deg=20.0)  # a 20° cap holds ≈ 1.2 mm of press
    with pytest.raises(PhysicsError, match="rim of the skin layer"):
        _skin_offsets(-3.0, 3.0, params=params)


def test_active_set_matches_complementarity():
    layer = SkinLayer(TacTipGeometry(), 0.002, 50.0)
    z = layer.nodes[:, 2]
    delta = np.maximum(0.0, z - (z.max() - 3e-3))  # a flat 3 mm press, radial depth approximated by z
    p = layer.pressures(delta)
    w = layer.kernel @ p
    assert np.all(p >= 0)
    assert np.all(w >= delta - 1e-12)
    np.testing.assert_allclose(w[p > 0], delta[p > 0], atol=1e-12)


def test_a_guessed_active_set_reaches_the_same_pressures():
    """The LCP has one solution (K is symmetric positive definite): whatever nodes the
    guess starts from (none, all, the answer, its complement, a random half, a shifted
    contact's), the pressures are the cold start's, bit for bit, and complementary."""
    layer = SkinLayer(TacTipGeometry(), 0.002, 50.0)
    x, z = layer.nodes[:, 0], layer.nodes[:, 2]
    # an edge along y pressed 3 mm, its face x > 2 mm: the pressure is not a flat press's
    delta = np.where(x > 2e-3, np.maximum(0.0, z - (z.max() - 3e-3)), 0.0)
    cold = layer.pressures(delta)
    pressed = cold > 0
    assert 0 < pressed.sum() < (delta > 0).sum()  # some touching nodes carry no pressure
    shifted = layer.pressures(np.where(x > 3e-3, delta, 0.0)) > 0
    rng = np.random.default_rng(0)
    guesses = [np.zeros_like(pressed), np.ones_like(pressed), pressed, ~pressed, rng.random(len(x)) < 0.5, shifted]
    for guess in guesses:
        p = layer.pressures(delta, guess)
        np.testing.assert_array_equal(p, cold)
    w = layer.kernel @ cold
    assert np.all(w >= delta - 1e-12)
    np.testing.assert_allclose(w[pressed], delta[pressed], atol=1e-12)


def test_on_by_default_and_zero_spacing_is_off():
    assert edge_scene(DEFAULT)[3].skin is not None
    _, _, _, physics = edge_scene(DEFAULT.with_(skin_spacing=0.0))
    assert physics.skin is None
    assert not np.any(physics._skin_offsets())
