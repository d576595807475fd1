"""The calibration file and the calibrated camera: the projection against OpenCV's
cv2.projectPoints (the reference implementation of the same model), the file's bounds and
errors, and what a scenario naming a calibration gets in the sim backend."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from twin.core.calibration import DOME_MATERIAL, Calibration, load_calibration, write_calibration
from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.core.sensor import CameraModel
from twin.runs.sim_env import SimEnvironment
from twin.runs.spec import dome_params
from twin.runs.training import cache_key, tap_scenario_like
from twin.world.dome.flex import DomeParams
from twin.world.dome.material import _TO_DOME, apply_dome_material, dome_material_of


def test_projection_matches_opencv() -> None:
    cam = CameraModel(
        focal_override_px=460.0,
        principal_point_px=(322.0, 241.0),
        distortion=(0.1, -0.05, 0.002, -0.001),
        offset_mm=(0.3, -0.2, 0.5),
        rotation_deg=(1.0, -2.0, 3.0),
    )
    points = cam.geometry.pin_tip_points()
    rot, t = cam._tool2camera
    expected, _ = cv2.projectPoints(points, cv2.Rodrigues(rot)[0], t, cam.intrinsics, np.array(cam.distortion))
    assert np.abs(expected[:, 0] - cam.project_tool_points(points)).max() < 1e-9
    # the nominal camera keeps its fast path and its pixels
    nominal = CameraModel()
    assert nominal == cam.nominal() and nominal.is_pinhole and not cam.is_pinhole
    placed = cam.place_at_pixels(points, cam.project_tool_points(points))
    assert np.abs(nominal.project_tool_points(placed) - cam.project_tool_points(points)).max() < 1e-9


def test_file_round_trip_and_rescale(tmp_path) -> None:
    cal = Calibration(
        camera={"focal_px": 460.0, "principal_point_px": [320.0, 240.0], "distortion": {"k1": 0.05}},
        rest_pin_offsets_px=[[0.5, -0.25]] * 127,
        dome_material={"young_kpa": 60.0},
        friction=0.6,
        tcp_offset_mm=[0.1, 0.0, 0.3],
    )
    again = load_calibration(write_calibration(cal, tmp_path / "c.yaml"))
    assert again == cal
    half = again.camera_model(CameraModel(320, 240))
    assert half.focal_px == pytest.approx(230.0) and half.intrinsics[0, 2] == pytest.approx(159.75)
    assert again.rest_offsets_px(320)[0] == pytest.approx([0.25, -0.125])


@pytest.mark.parametrize(
    "data, field",
    [
        ({"camera": {"focal_px": -3}}, "camera.focal_px"),
        ({"dome_material": {"youngs": 3.0}}, "dome_material"),
        ({"dome_material": {"poisson": 0.7}}, "dome_material"),
        ({"rest_pin_offsets_px": [[0, 0]] * 12}, "rest_pin_offsets_px"),
        ({"tcp_offset_mm": [0, 0, 99]}, "tcp_offset_mm.2"),
    ],
)
def test_bad_files_name_the_field(tmp_path, data, field) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(UserError, match=field.replace(".", r"\.")):
        load_calibration(path)


def test_material_names_map_onto_the_dome() -> None:
    assert set(_TO_DOME) == set(DOME_MATERIAL)
    params = apply_dome_material(DomeParams(), {"young_kpa": 70.0, "poisson": 0.3, "membrane_young_mpa": 0.5})
    assert (params.young, params.poisson, params.membrane_young) == (7e4, 0.3, 5e5)
    assert dome_material_of(params) == {"young_kpa": 70.0, "poisson": 0.3, "membrane_young_mpa": 0.5}


def test_a_fitted_adhesion_reaches_the_dome_it_simulates() -> None:
    """`material.adhesion_kpa`, fitted by `twin calibrate`, goes into the calibration's dome
    material and from there into the compliant dome's contact law (Pa); the scenario's own
    `physics.adhesion_kpa` is where it starts."""
    from twin.analysis.calibration_fit.settings import load_settings
    from twin.analysis.calibration_fit.space import Space

    scenario = scenario_from_dict(
        {"name": "adhesive", "object": {"name": "rectangle"}, "physics": {"adhesion_kpa": 4.0}}, "s.yaml"
    )
    space = Space(scenario, load_settings(None))
    assert space.defaults["material.adhesion_kpa"] == 4.0
    fitted = space.physics_scenario({"material.adhesion_kpa": 12.5})
    assert fitted.calibration().dome_material["adhesion_kpa"] == 12.5
    assert dome_params(fitted).adhesion == pytest.approx(12500.0)


def test_sim_backend_applies_the_calibration(tmp_path) -> None:
    base = {"name": "cal", "object": {"name": "rectangle"}, "effects": ["contact", "friction"]}
    offsets = np.random.default_rng(0).normal(0, 1.0, (127, 2)).round(3)
    cal = Calibration(
        camera={"focal_px": 470.0},
        rest_pin_offsets_px=offsets.tolist(),
        friction=0.4,
        dome_material={"young_kpa": 15.0},
        tcp_offset_mm=[0.0, 0.0, 0.5],
    )
    write_calibration(cal, tmp_path / "sensor.yaml")
    plain = SimEnvironment(scenario_from_dict(base, str(tmp_path / "s.yaml")))
    fitted = SimEnvironment(
        scenario_from_dict({**base, "sensor": {"calibration": "sensor.yaml"}}, str(tmp_path / "s.yaml"))
    )
    assert fitted.scene.dome_params.young == 1.5e4 and fitted.scene.stimulus.friction == 0.4
    expected = CameraModel(focal_override_px=470.0).project_tool_points(plain.physics.rest_pins) + offsets
    assert np.abs(fitted.rest_pins_px - expected).max() < 1e-9
    # the apex sits 0.5 mm below the commanded TCP: commanding 3.5 mm presses as deep as 4 mm without it
    for env, z in ((fitted, 3.5), (plain, 4.0)):
        env.reset()
        env.move_to(Pose(60.0, 0.0, -5.0, 0, 0, 0), 50.0)
        env.move_to(Pose(60.0, 0.0, z, 0, 0, 0))
    obs = fitted.observe()
    assert obs.pose.z == pytest.approx(3.5)  # the pose reported is the TCP's, as the robot reports it
    undo = plain.camera.project_tool_points(fitted.pins_tool)
    assert np.abs(undo - plain.observe().pins_px).max() < 1.0  # only the dome's material differs
    with pytest.raises(UserError, match="sensor.calibration"):
        scenario_from_dict({**base, "sensor": {"calibration": "missing.yaml"}}, str(tmp_path / "s.yaml")).camera_model()


def test_tap_model_cache_is_keyed_on_the_calibration_contents(tmp_path) -> None:
    # the cached tap model depends on what the calibration says, not where the file lies
    cal = Calibration(camera={"focal_px": 460.0}, friction=0.6, tcp_offset_mm=[0.0, 0.0, 0.3])
    base = {"name": "taps", "object": {"name": "rectangle"}, "protocol": {"kind": "taps"}}

    def key(folder: str, name: str, calibration: Calibration) -> str:
        write_calibration(calibration, tmp_path / folder / name)
        return cache_key(
            scenario_from_dict({**base, "sensor": {"calibration": name}}, str(tmp_path / folder / "s.yaml"))
        )

    same = key("a", "sensor.yaml", cal)
    assert key("b", "other.yaml", cal) == same  # another file, the same contents
    inline = scenario_from_dict({**base, "sensor": {"calibration": cal.model_dump()}}, str(tmp_path / "s.yaml"))
    assert cache_key(inline) == same  # or the same contents inline
    assert key("a", "sensor.yaml", cal.model_copy(update={"friction": 0.61})) != same  # the file edited in place
    assert cache_key(scenario_from_dict(base, str(tmp_path / "s.yaml"))) != same
    # a contour scenario's tap set carries its calibration, though it lies beside the contour scenario
    contour = scenario_from_dict(
        {**base, "sensor": {"calibration": "other.yaml"}, "protocol": {"kind": "contour"}},
        str(tmp_path / "b" / "contour.yaml"),
    )
    assert tap_scenario_like(contour).calibration() == cal


def test_a_contour_s_tap_model_is_trained_on_its_own_dome_model() -> None:
    """A contour scenario on the compliant dome gets taps simulated on the compliant dome,
    and a tap model cached apart from the flex dome's."""
    contour = scenario_from_dict(
        {"name": "c", "object": {"name": "rectangle"}, "dome": "compliant", "protocol": {"kind": "contour"}}
    )
    taps = tap_scenario_like(contour)
    assert taps.dome == "compliant" and taps.protocol.kind == "taps"
    assert cache_key(taps) != cache_key(tap_scenario_like(contour.with_changes(dome="flex")))


def test_a_contour_s_tap_model_is_trained_on_its_own_physics() -> None:
    """A contour scenario's `physics` (a skin over the gel here) reaches its taps: they
    simulate the same dome, and the model is cached apart from the dome without it."""
    skin = {"membrane_young_mpa": 0.6, "gel_young_kpa": 34.1, "skin_bending": True}
    contour = scenario_from_dict(
        {
            "name": "c",
            "object": {"name": "rectangle"},
            "dome": "compliant",
            "physics": skin,
            "protocol": {"kind": "contour"},
        }
    )
    taps = tap_scenario_like(contour)
    assert dome_params(taps) == dome_params(contour) and dome_params(taps).skin_bending
    assert cache_key(taps) != cache_key(tap_scenario_like(contour.with_changes(physics={})))


def test_a_cached_tap_model_is_keyed_on_the_code_that_made_it(monkeypatch) -> None:
    """A source checkout whose dome, tracker or trainer changed gets a new tap model, not
    the cached model of the old code (the version alone does not change there)."""
    import twin.runs.training as training

    taps = tap_scenario_like(
        scenario_from_dict({"name": "c", "object": {"name": "rectangle"}, "protocol": {"kind": "contour"}})
    )
    before = cache_key(taps)
    assert len(training.model_code_digest()) == 16
    monkeypatch.setattr(training, "model_code_digest", lambda: "0" * 16)
    assert cache_key(taps) != before
