"""The silhouette renderer: exact sphere outlines against closed form, the GL renderer's
frame drawn the same way (its polygons lie inside the silhouettes), pins tracked alike."""

from __future__ import annotations

import numpy as np
import pytest

from tests.world.test_render import SCENARIO
from twin.core.scenario import load_scenario
from twin.core.sensor import CameraModel
from twin.runs.sim_env import SimEnvironment, first_pose
from twin.runs.spec import inside_renderer
from twin.sensing.tracker import PinTracker
from twin.world.render import PIN_GREY, SKIN_GREY, PinRenderer, pin_sphere_slices
from twin.world.silhouette import SilhouetteRenderer


def test_a_sphere_on_the_axis_is_the_closed_form_disc() -> None:
    """On the optical axis at depth z, a sphere of radius r is seen under the half-angle
    asin(r/z): a disc of radius f·r/√(z² − r²) about the principal point."""
    camera = CameraModel(width=160, height=120)
    renderer = SilhouetteRenderer(camera)
    depth = 0.012  # m from the camera
    pin = np.array([[0.0, 0.0, depth - camera.geometry.camera_to_apex]])
    frame = renderer.render(pin)[..., 0]
    r = camera.geometry.pin_radius
    radius_px = camera.focal_px * r / np.sqrt(depth**2 - r**2)
    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    cx, cy = camera.intrinsics[0, 2], camera.intrinsics[1, 2]
    disc = (u - cx) ** 2 + (v - cy) ** 2 <= radius_px**2
    assert disc.sum() > 20
    np.testing.assert_array_equal(frame == PIN_GREY, disc)


def test_an_off_axis_sphere_is_every_pixel_whose_ray_meets_it() -> None:
    """Off the axis the outline is an ellipse; a pixel is white exactly when its ray passes
    within r of the sphere's centre (distance from a point to a line, computed directly)."""
    camera = CameraModel(width=128, height=128)
    renderer = SilhouetteRenderer(camera)
    centre_camera = np.array([0.006, -0.004, 0.02])
    pin = centre_camera - np.array([0.0, 0.0, camera.geometry.camera_to_apex])
    frame = renderer.render(pin[None, :])[..., 0]
    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    k = camera.intrinsics
    rays = np.stack([(u - k[0, 2]) / k[0, 0], (v - k[1, 2]) / k[1, 1], np.ones_like(u, float)], axis=-1)
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    miss = np.linalg.norm(np.cross(rays, centre_camera), axis=-1)
    assert (miss <= camera.geometry.pin_radius).sum() > 10
    np.testing.assert_array_equal(frame == PIN_GREY, miss <= camera.geometry.pin_radius)


@pytest.mark.parametrize("shape", [(96, 96), (128, 128), (120, 160), (640, 480)])
def test_gl_pins_lie_inside_the_silhouettes_and_track_alike(shape: tuple[int, int]) -> None:
    """GL draws each sphere as a polygon inscribed in its outline: every GL pin pixel is a
    silhouette pin pixel, and the silhouettes add about what the polygons leave out; the skin is GL's grey
    inside the aperture and black beyond; all 127 pins are tracked, within 0.3 px of GL's."""
    camera = CameraModel(width=shape[0], height=shape[1])
    gl_renderer = PinRenderer(camera)
    rng = np.random.default_rng(3)
    pins = camera.geometry.pin_tip_points() + rng.normal(0.0, 1e-4, (127, 3))
    try:
        gl_frame = gl_renderer.render(pins)[..., 0]
    finally:
        gl_renderer.close()
    frame = SilhouetteRenderer(camera).render(pins)
    assert frame.shape == (shape[1], shape[0], 3)
    grey = frame[..., 0]
    assert not np.any((gl_frame == PIN_GREY) & (grey != PIN_GREY))
    slices = pin_sphere_slices(camera)
    polygon_share = slices * np.sin(2 * np.pi / slices) / (2 * np.pi)  # inscribed polygon / disc
    assert 1.0 < (grey == PIN_GREY).sum() / (gl_frame == PIN_GREY).sum() < 1.1 / polygon_share
    np.testing.assert_array_equal(np.unique(grey), np.unique(gl_frame))  # black, skin, pins
    assert SKIN_GREY in np.unique(gl_frame)
    gl_pins = PinTracker(gl_frame).track(np.repeat(gl_frame[..., None], 3, axis=2))
    tracked = PinTracker(frame).track(frame)
    assert gl_pins.found.all() and tracked.found.all()
    assert np.sqrt(np.mean(np.sum((tracked.pins_px - gl_pins.pins_px) ** 2, axis=1))) < 0.3


def test_the_renderers_camera_frame_projects_as_the_camera_does() -> None:
    """The frame both renderers draw in (CameraModel.in_nominal_camera) and the one
    projection of the twin (project_tool_points) state the same nominal camera: a pinhole
    at that frame's origin, looking down +z, sees each pin where the projection puts it."""
    camera = CameraModel(320, 240)
    pins = camera.geometry.pin_tip_points()
    in_camera = camera.in_nominal_camera(pins)
    k = camera.intrinsics
    pinhole = np.column_stack(
        [k[0, 0] * in_camera[:, 0] / in_camera[:, 2] + k[0, 2], k[1, 1] * in_camera[:, 1] / in_camera[:, 2] + k[1, 2]]
    )
    np.testing.assert_allclose(pinhole, camera.project_tool_points(pins), atol=1e-9)
    assert np.all(in_camera[:, 2] > 0.02)  # every pin well in front of the camera


def test_bad_pins_are_refused_by_name() -> None:
    camera = CameraModel(width=128, height=128)
    renderer = SilhouetteRenderer(camera)
    pins = camera.geometry.pin_tip_points()
    with pytest.raises(ValueError, match="finite"):
        renderer.render(np.where(np.arange(127)[:, None] == 5, np.nan, pins))
    behind = pins.copy()
    behind[0, 2] = -camera.geometry.camera_to_apex  # the apex pin in the camera's plane
    with pytest.raises(ValueError, match="camera's plane"):
        renderer.render(behind)


def test_noise_is_seeded_and_needs_a_generator() -> None:
    camera = CameraModel(width=128, height=128)
    renderer = SilhouetteRenderer(camera)
    pins = camera.geometry.pin_tip_points()
    a = renderer.render(pins, 2.0, np.random.default_rng(5))
    b = renderer.render(pins, 2.0, np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)
    assert np.any(a != renderer.render(pins))
    with pytest.raises(ValueError, match="seeded"):
        renderer.render(pins, 2.0)


def _scenario(effects: list[str] | None = None, **camera_fields):
    base = load_scenario(SCENARIO)
    camera = base.sensor.camera.model_copy(update=camera_fields)
    update = {"sensor": base.sensor.model_copy(update={"camera": camera})}
    if effects is not None:
        update["effects"] = effects
    return base.model_copy(update=update)


@pytest.mark.parametrize(
    "effects, camera_fields, expected",
    [
        (["contact", "friction", "render"], {}, "silhouette"),
        (["contact", "friction", "render", "camera_noise"], {}, "silhouette"),
        (["contact", "friction", "render", "lighting"], {}, "gl"),
        (["contact", "friction", "render"], {"msaa": 4}, "gl"),
        (["contact", "friction", "render"], {"renderer": "gl"}, "gl"),
    ],
)
def test_auto_draws_with_gl_only_what_needs_gl(effects, camera_fields, expected) -> None:
    """`renderer: auto` (the default) is the silhouette renderer unless the scenario asks
    for shading (lighting) or anti-aliasing; `gl` is kept when asked for."""
    assert inside_renderer(_scenario(effects, **camera_fields)) == expected


def test_a_scenario_renders_with_it() -> None:
    """The default renderer behind the environment: the no-contact frame at 128×128 (no
    GL drawn: SKIN_GREY inside the aperture, black beyond) tracks all 127 pins within
    0.5 px of the true ones."""
    scenario = _scenario(width=128, height=128)
    with SimEnvironment(scenario) as env:
        assert isinstance(env._renderer, SilhouetteRenderer)
        env.move_to(first_pose(scenario))
        obs = env.observe()
    result = PinTracker(obs.frame).track(obs.frame)
    assert result.found.sum() == 127
    assert np.sqrt(np.mean(np.sum((result.pins_px - obs.truth["pins_px"]) ** 2, axis=1))) < 0.5
