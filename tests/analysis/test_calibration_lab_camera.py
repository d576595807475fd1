"""`twin calibrate` on a recording in the lab's format whose camera is not the twin's (the
DigiTac set's kind: a 256×256 frame, the pin grid turned on the image, a camera much nearer
the dome): the camera's start from the no-contact frame (settings `camera_from_rest`),
its distance fitted on the taps with the rest of it tied to that frame (`camera_tied_to_rest`),
the shipped settings for that camera, and runs held out of the fit. The "real" sensor is
the twin itself through such a camera, rendered, written in the lab's format and imported."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from tests.runs.test_lab_recording import _write_lab_set
from twin.analysis.calibration_fit.data import load_data
from twin.analysis.calibration_fit.settings import load_settings
from twin.core.calibration import load_calibration
from twin.core.resources import asset_path
from twin.core.scenario import load_scenario
from twin.tools.cli import main

REPO = Path(__file__).resolve().parents[2]
#: a camera like the DigiTac set's (docs/real-sensor.md): 256×256, 22 mm nearer the dome, turned 28°
LAB_CAMERA = {
    "width": 256,
    "height": 256,
    "focal_px": 80.0,
    "distortion": {"k1": -0.05},
    "offset_mm": [0.0, 0.0, 22.0],
    "rotation_deg": [0.0, 0.0, -28.0],
}
TAPS = [
    [
        {"lateral_mm": 2.0, "theta_deg": 20.0, "depth_offset_mm": 0.5, "slide_along_mm": 1.5, "twist_deg": 3.0},
        {"lateral_mm": -3.0, "theta_deg": -30.0, "slide_along_mm": -2.0, "slide_lateral_mm": 1.0},
        {"lateral_mm": 0.0, "theta_deg": 5.0, "depth_offset_mm": -0.5},
    ],
    [
        {"lateral_mm": 1.0, "theta_deg": -10.0, "slide_along_mm": 1.0},
        {"lateral_mm": -1.5, "theta_deg": 35.0, "depth_offset_mm": 0.3, "twist_deg": -2.0},
    ],
]


def _lab_set(root: Path, name: str, taps: list[dict]) -> Path:
    """The twin's sheared taps through LAB_CAMERA, 0.3 mm deeper than nominal, rendered, in
    the lab's format, imported as a run (as `twin import-lab` does a real recording)."""
    scenario = {
        "name": name,
        "object": {"name": "rectangle"},
        "fidelity": "fast",
        "sensor": {
            "camera": {"width": 256, "height": 256},
            "calibration": {"camera": LAB_CAMERA, "tcp_offset_mm": [0.0, 0.0, 0.3]},
        },
        "effects": ["contact", "friction", "render"],
        "protocol": {"kind": "sheared_taps", "depth_mm": 2.5, "taps": len(taps), "given": taps},
    }
    (root / f"{name}.yaml").write_text(yaml.safe_dump(scenario))
    assert (
        main(["run", str(root / f"{name}.yaml"), "--out", str(root / f"{name}_twin"), "--workers", "1", "--quiet"]) == 0
    )
    targets = _write_lab_set(root / f"{name}_twin", root / f"{name}_lab")
    out = root / f"{name}_imported"
    args = ["import-lab", str(root / f"{name}_lab"), "--targets", str(targets), "--out", str(out)]
    assert main([*args, "--depth-mm", "2.5", "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("lab_camera")
    twin = {
        "name": "fit_lab",
        "object": {"name": "rectangle"},
        "fidelity": "fast",
        "sensor": {"camera": {"width": 256, "height": 256}},
        "effects": ["contact", "friction"],
        "protocol": {"kind": "sheared_taps", "depth_mm": 2.5},
    }
    (root / "twin.yaml").write_text(yaml.safe_dump(twin))
    # the shipped settings for that camera, with only the depth offset fitted among the physics (quick)
    shipped = yaml.safe_load(asset_path("tactip", "calibration_settings_digitac_256.yaml").read_text())
    shipped["parameters"]["material.membrane_young_mpa"]["fit"] = False
    shipped["parameters"]["friction"]["fit"] = False
    # these sets' sensor is mounted straight, not turned as the DigiTac's
    shipped["parameters"]["tcp.roll_deg"]["default"] = 0.0
    shipped["optimiser"] = {"popsize": 5, "max_generations": 6, "patience": 2, "tol_bracket": 0.02}
    (root / "settings.yaml").write_text(yaml.safe_dump(shipped))
    return {
        "root": root,
        "fit": _lab_set(root, "fit", TAPS[0]),
        "held": _lab_set(root, "held", TAPS[1]),
        "settings": root / "settings.yaml",
    }


def _calibrate(lab: dict, out: Path, settings: Path, *extra: str) -> int:
    args = ["calibrate", str(lab["fit"]), "--scenario", str(lab["root"] / "twin.yaml"), "--out", str(out)]
    return main([*args, "--settings", str(settings), "--workers", "1", "--quiet", *extra])


def test_the_shipped_settings_fit_a_camera_unlike_the_twins(lab, tmp_path, capsys) -> None:
    out = tmp_path / "cal"
    assert _calibrate(lab, out, lab["settings"], "--held-out", str(lab["held"])) == 0
    printed = capsys.readouterr().out
    assert "camera.rz_deg from the no-contact frames" in printed and "held out (3 samples, not fitted)" in printed
    report = yaml.safe_load((out / "report.json").read_text())
    rest = report["camera_from_rest"]
    # the turn of the pin grid on the image and the rim's magnification, from the no-contact frame alone
    assert rest["values"]["camera.rz_deg"] == pytest.approx(-28.0, abs=1.0) and not rest["at_bound"]
    # the camera's distance, not a strong distortion, magnifies the rim (the distortion's prior)
    assert rest["values"]["camera.z_mm"] == pytest.approx(22.0, abs=3.0)
    assert rest["values"]["camera.focal_px"] == pytest.approx(80.0, rel=0.15)
    assert rest["rms_px"] < 0.5
    fitted = report["uncertainty"]["parameters"]
    assert fitted["tcp.z_mm"]["identifiable"] and fitted["tcp.z_mm"]["value"] == pytest.approx(0.3, abs=0.15)
    # that depth offset is from the depth the recording was imported at (--depth-mm), which the lab does not record
    assert report["nominal_depth_mm"] == {str(lab["fit"]): 2.5} and "taps press from 2.5 mm" in printed
    assert "press from 2.5 mm" in (out / "report.md").read_text()
    assert fitted["camera.rz_deg"]["value"] == pytest.approx(-28.0, abs=1.5)
    # the twin as it was misses the pins by tens of px; fitted, the taps are within a pixel, fitted or held out
    assert report["before"]["groups"]["contact"] > 20.0 and report["after"]["groups"]["contact"] < 1.0
    held = report["held_out"]
    assert held["samples"] == 3 and held["before"]["overall"] > 20.0 and held["after"]["groups"]["contact"] < 1.0
    cal = load_calibration(out / "calibration.yaml")
    assert cal.camera.rotation_deg[2] == pytest.approx(fitted["camera.rz_deg"]["value"])
    assert np.abs(cal.rest_pin_offsets_px).max() < 3.0  # the camera, not the rest layout, took the turn
    assert "from the no-contact frames" in (out / "report.md").read_text()
    # the residual plot draws the pins where the recording has them, in its 256×256 frame
    assert report["frame_px"] == [256, 256] and (out / "residuals.png").is_file()
    recorded_rest = np.asarray(yaml.safe_load((lab["fit"] / "samples.jsonl").read_text().splitlines()[0])["pins_px"])
    np.testing.assert_allclose(report["pin_positions_px"], recorded_rest)


def test_without_the_camera_start_the_rest_layout_takes_the_turn(lab, tmp_path) -> None:
    # the twin's own camera: the 28° turn and the rim's magnification go into the rest offsets
    # (up to the 50 px a calibration holds), which say nothing of how the pins move: the taps
    # fit several times worse than with the camera start (< 1 px above)
    settings = yaml.safe_load(lab["settings"].read_text())
    settings["camera_from_rest"] = []
    settings["parameters"]["camera.rz_deg"]["fit"] = False
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(settings))
    assert _calibrate(lab, tmp_path / "cal", tmp_path / "s.yaml") == 0
    report = yaml.safe_load((tmp_path / "cal" / "report.json").read_text())
    assert report["camera_from_rest"] is None and report["after"]["groups"]["contact"] > 2.0
    assert np.abs(load_calibration(tmp_path / "cal" / "calibration.yaml").rest_pin_offsets_px).max() > 30.0


def _tied(settings: dict) -> dict:
    """`settings` (the shipped DigiTac ones: the whole camera from the no-contact frame, the roll
    fitted again on the taps) with the distance fitted on the taps from there and the rest of
    the camera tied to that frame."""
    settings["camera_tied_to_rest"] = True
    settings["parameters"]["camera.z_mm"]["fit"] = True
    settings["parameters"]["camera.rz_deg"]["fit"] = False
    return settings


def _settings_without_distortion_prior(lab: dict, tied: bool) -> dict:
    """The lab settings with no prior on the distortion, which leaves the no-contact frame
    alone to choose among cameras that meet it alike; tied, the distance is fitted on the taps
    from the twin's 0 mm (not started from that frame)."""
    settings = yaml.safe_load(lab["settings"].read_text())
    for k in ("camera.k1", "camera.k2"):
        settings["parameters"][k]["prior_std"] = None
    if tied:
        _tied(settings)["camera_from_rest"].remove("camera.z_mm")
    return settings


def test_tied_to_the_rest_frame_the_taps_fit_the_cameras_distance(lab, tmp_path, capsys) -> None:
    reports = {}
    for tied in (False, True):
        (tmp_path / f"s{tied}.yaml").write_text(yaml.safe_dump(_settings_without_distortion_prior(lab, tied)))
        out = tmp_path / f"cal{tied}"
        assert _calibrate(lab, out, tmp_path / f"s{tied}.yaml", "--held-out", str(lab["held"])) == 0
        reports[tied] = json.loads((out / "report.json").read_text())
    free, tied = reports[False], reports[True]
    # the no-contact frame alone: a camera 22 mm nearer and one with a strong distortion meet it
    # alike, and without the prior it picks the wrong one, which the depth offset then makes up for
    assert abs(free["camera_from_rest"]["values"]["camera.z_mm"] - 22.0) > 10.0
    assert abs(free["uncertainty"]["parameters"]["tcp.z_mm"]["value"] - 0.3) > 0.3
    # tied, the taps' pin motion along the axis chooses the distance, and with it the lens
    fitted = tied["uncertainty"]["parameters"]
    assert fitted["camera.z_mm"]["identifiable"] and fitted["camera.z_mm"]["value"] == pytest.approx(22.0, abs=0.5)
    assert fitted["tcp.z_mm"]["value"] == pytest.approx(0.3, abs=0.05)
    at_fit = tied["camera_from_rest"]["at_fit"]
    assert at_fit["camera.focal_px"] == pytest.approx(80.0, rel=0.03)
    assert at_fit["camera.k1"] == pytest.approx(-0.05, abs=0.02) and at_fit["camera.rz_deg"] == pytest.approx(
        -28.0, abs=0.1
    )
    cal = load_calibration(tmp_path / "calTrue" / "calibration.yaml")
    assert cal.camera.focal_px == pytest.approx(at_fit["camera.focal_px"]) and cal.camera.offset_mm[2] == pytest.approx(
        fitted["camera.z_mm"]["value"]
    )
    # the taps and the held-out taps fit several times better than through the wrong camera
    assert tied["after"]["groups"]["contact"] < free["after"]["groups"]["contact"] / 3
    assert tied["held_out"]["after"]["groups"]["contact"] < free["held_out"]["after"]["groups"]["contact"] / 3
    assert "tied to them, at the fitted camera" in capsys.readouterr().out
    assert "tied: at the fitted camera" in (tmp_path / "calTrue" / "report.md").read_text()


@pytest.mark.parametrize("start", [[], ["camera.z_mm"]])
def test_a_tie_with_nothing_to_tie_exits_2_naming_the_field(lab, tmp_path, capsys, start) -> None:
    # the parameters tied are those of camera_from_rest not fitted: none, or only the fitted distance
    settings = _tied(yaml.safe_load(lab["settings"].read_text()))
    settings["camera_from_rest"] = start
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(settings))
    assert _calibrate(lab, tmp_path / "cal", tmp_path / "s.yaml") == 2
    err = capsys.readouterr().err.strip()
    assert "camera_tied_to_rest ties the camera_from_rest parameters that are not fitted" in err, err
    assert "s.yaml" in err and "Traceback" not in err, err


def test_a_tied_parameter_at_its_bound_is_flagged(lab, tmp_path, capsys) -> None:
    # the lab camera's k1 is -0.05: held to k1 >= 0, the lens that meets the no-contact frame ends at that bound
    settings = _tied(yaml.safe_load(lab["settings"].read_text()))
    settings["parameters"]["camera.k1"]["lower"] = 0.0
    settings["parameters"]["camera.k1"]["prior_std"] = None
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(settings))
    assert _calibrate(lab, tmp_path / "cal", tmp_path / "s.yaml") == 0
    report = json.loads((tmp_path / "cal" / "report.json").read_text())
    assert report["camera_from_rest"]["at_fit"]["camera.k1"] == pytest.approx(0.0, abs=1e-9)
    assert report["camera_from_rest"]["at_fit_at_bound"] == ["camera.k1"]
    assert capsys.readouterr().out.count("AT A BOUND") == 1  # k1's line, not the others'
    assert "the cameras that meet the no-contact frames end there" in (tmp_path / "cal" / "report.md").read_text()


def test_a_bound_beyond_what_a_calibration_holds_exits_2_naming_it(lab, tmp_path, capsys) -> None:
    # a calibration file holds the camera within 30 mm of the twin's: found before the search, not on reaching it
    settings = yaml.safe_load(lab["settings"].read_text())
    settings["parameters"]["camera.z_mm"]["upper"] = 35.0
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(settings))
    assert _calibrate(lab, tmp_path / "cal", tmp_path / "s.yaml") == 2
    err = capsys.readouterr().err.strip()
    assert "'parameters.camera.z_mm'" in err and "35" in err and "Traceback" not in err, err


@pytest.mark.parametrize(
    ("entry", "named"),
    [
        (["camera.focal_px", "tcp.z_mm"], "camera_from_rest"),  # not a camera parameter
        (["camera.fokal_px"], "camera.fokal_px"),
    ],
)
def test_a_bad_camera_start_exits_2_naming_the_field(lab, tmp_path, capsys, entry, named) -> None:
    (tmp_path / "s.yaml").write_text(yaml.safe_dump({"camera_from_rest": entry}))
    assert _calibrate(lab, tmp_path / "cal", tmp_path / "s.yaml") == 2
    err = capsys.readouterr().err.strip()
    assert named in err and "s.yaml" in err and "Traceback" not in err, err


def test_the_camera_start_needs_a_no_contact_frame(lab, tmp_path, capsys) -> None:
    taps_only = tmp_path / "taps_only"
    shutil.copytree(lab["fit"], taps_only)
    rows = (taps_only / "samples.jsonl").read_text().splitlines()
    (taps_only / "samples.jsonl").write_text("\n".join(rows[1:]) + "\n")  # the no-contact frame dropped
    args = ["calibrate", str(taps_only), "--scenario", str(lab["root"] / "twin.yaml"), "--out", str(tmp_path / "cal")]
    assert main([*args, "--settings", str(lab["settings"]), "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "'camera_from_rest' needs no-contact frames" in err and len(err.splitlines()) == 1, err


def test_a_pin_the_tracker_did_not_find_is_not_fitted(lab, tmp_path) -> None:
    # the recorded pin holds the tracker's guess; flagged in 'found', the fit leaves it out
    flagged = tmp_path / "flagged"
    shutil.copytree(lab["fit"], flagged)
    rows = [json.loads(line) for line in (flagged / "samples.jsonl").read_text().splitlines()]
    rows[2]["found"] = [k != 40 for k in range(127)]
    (flagged / "samples.jsonl").write_text("\n".join(json.dumps(r) for r in rows) + "\n")
    scenario = load_scenario(lab["root"] / "twin.yaml")
    settings = load_settings(lab["settings"])
    pins = load_data([flagged], scenario, settings.weights).pins
    assert np.isnan(pins[2, 40]).all() and np.isfinite(np.delete(pins[2], 40, axis=0)).all()
    assert np.isfinite(load_data([lab["fit"]], scenario, settings.weights).pins[2]).all()


def test_a_candidate_the_physics_cannot_simulate_is_ranked_last(lab, tmp_path, capsys) -> None:
    # depth offsets up to 12 mm: the deep candidates press past the contact force limit and
    # fail their physics checks; the search goes on without them (it ended the calibration)
    settings = yaml.safe_load(lab["settings"].read_text())
    settings["parameters"]["tcp.z_mm"] = {"fit": True, "lower": -2.0, "upper": 12.0}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(settings))
    assert _calibrate(lab, tmp_path / "cal", tmp_path / "s.yaml") == 0
    assert "candidates failed their physics checks" in capsys.readouterr().out
    report = yaml.safe_load((tmp_path / "cal" / "report.json").read_text())
    failed = report["failed_simulations"]
    assert (
        failed
        and all(f["values"]["tcp.z_mm"] > 2.0 for f in failed)
        and re.search(r"(step|increment) \d+", failed[0]["error"])
    )
    assert report["uncertainty"]["parameters"]["tcp.z_mm"]["value"] == pytest.approx(0.3, abs=0.3)
    history = [json.loads(line) for line in (tmp_path / "cal" / "history.jsonl").read_text().splitlines()]
    assert sum(row.get("failed", False) for row in history) == len(failed)
    assert "could not be simulated" in (tmp_path / "cal" / "report.md").read_text()
