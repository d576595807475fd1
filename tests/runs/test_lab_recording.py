"""Importing the lab's recording format (twin.runs.lab_recording) and the sheared-tap
protocol it maps to (twin.runs.protocols.sheared_tap_moves), on small sets the tests
make themselves in the lab's format."""

from __future__ import annotations

import csv
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from twin.core.errors import UserError
from twin.core.scenario import ShearedTapProtocol
from twin.runs.lab_recording import LabTargets, lab_pose_to_twin, lab_scenario, lab_to_twin_tap, read_lab_targets
from twin.runs.protocols import drawn_sheared_taps, sheared_tap_moves
from twin.runs.record import load_run
from twin.runs.runner import chunk_moves
from twin.tools.cli import main

TAP_MOVE = np.array([0.0, 0.0, -5.0, 0.0, 0.0, 0.0])  # the lab's tap_move (pbts-2d collect_edge2d)


def _collect(pose: np.ndarray, move: np.ndarray) -> dict[str, np.ndarray]:
    """The arm's poses of one target in the lab's collection code (pose_models_2d/lib/common.py, collect)."""
    return {"above": pose - move, "press": pose - move + TAP_MOVE, "frame": pose + TAP_MOVE, "lift": pose}


@pytest.mark.parametrize("object_side", [1, -1])
def test_the_twins_taps_go_where_the_lab_arm_goes(object_side: int) -> None:
    """Each lab target's press and frame poses, mapped as whole arm poses, are the twin's
    press and recorded moves of the tap the labels map to; the slide runs in contact."""
    rng = np.random.default_rng(3)
    poses = np.zeros((6, 6))
    poses[:, 1], poses[:, 2], poses[:, 5] = rng.uniform(-5, 5, 6), rng.uniform(-1, 1, 6), rng.uniform(-45, 45, 6)
    moves = np.zeros((6, 6))
    moves[:, 0], moves[:, 1], moves[:, 5] = rng.uniform(-5, 5, 6), rng.uniform(-5, 5, 6), rng.uniform(-5, 5, 6)
    scenario = lab_scenario(
        LabTargets([f"frame_{k}_0.png" for k in range(6)], poses, moves), (256, 256), 3.0, object_side, "lab", "<test>"
    )
    rest, *twin_moves = sheared_tap_moves(scenario.protocol)
    assert rest.record and rest.labels["no_contact"] and rest.pose.z < 0
    for k in range(6):
        arm = _collect(poses[k], moves[k])
        press, frame = twin_moves[4 * k + 1], twin_moves[4 * k + 2]
        assert frame.record and not press.record
        np.testing.assert_allclose(
            frame.pose.as_array(), lab_pose_to_twin(arm["frame"], scenario.protocol, object_side).as_array(), atol=1e-9
        )
        np.testing.assert_allclose(
            press.pose.as_array(), lab_pose_to_twin(arm["press"], scenario.protocol, object_side).as_array(), atol=1e-9
        )
        assert press.pose.z == frame.pose.z > 0  # pressed in, slid at that depth
        assert twin_moves[4 * k].pose.z < 0 and twin_moves[4 * k + 3].pose.z < 0  # approach and leave above it
    # each tap is one chunk (from a reset): the in-contact twist does not split it
    assert [len(c) for c in chunk_moves([rest, *twin_moves])] == [1] + [4] * 6


def test_the_lab_convention_in_numbers() -> None:
    """The DigiTac set's first target, mapped by hand (module docstring): the object on the
    lab's +y side, so + pose_2 is onto it (twin l < 0); z up, so + pose_3 is shallower."""
    tap = lab_to_twin_tap(np.array([0, 2.1, -0.6, 0, 0, -45.0]), np.array([-2.6, -0.03, 0, 0, 0, -4.3]), 1)
    assert tap == pytest.approx(
        {
            "lateral_mm": -2.1,
            "along_mm": 0.0,
            "theta_deg": 45.0,
            "depth_offset_mm": 0.6,
            "slide_along_mm": 2.6,
            "slide_lateral_mm": 0.03,
            "twist_deg": 4.3,
        }
    )


def test_drawn_taps_are_seeded_and_within_their_ranges() -> None:
    p = ShearedTapProtocol(taps=40, seed=7, lateral_range_mm=[-4, 2], slide_mm=3, twist_deg=2)
    taps = drawn_sheared_taps(p)
    assert taps == drawn_sheared_taps(p) and taps != drawn_sheared_taps(p.model_copy(update={"seed": 8}))
    lateral = np.array([t.lateral_mm for t in taps])
    assert len(taps) == 40 and lateral.min() >= -4 and lateral.max() <= 2 and np.ptp(lateral) > 3
    assert max(abs(t.slide_along_mm) for t in taps) <= 3 and max(abs(t.twist_deg) for t in taps) <= 2
    assert np.all(np.diff([t.theta_deg for t in taps]) >= 0)  # ordered by θ, as the lab orders its targets


def _twin_to_lab(tap: dict, object_side: int = 1) -> tuple[list[float], list[float]]:
    """The inverse of the module docstring's table (pose, move), written out for the test."""
    s = -object_side
    pose = [s * tap["along_mm"], s * tap["lateral_mm"], -tap["depth_offset_mm"], 0.0, 0.0, -tap["theta_deg"]]
    move = [s * tap["slide_along_mm"], s * tap["slide_lateral_mm"], 0.0, 0.0, 0.0, -tap["twist_deg"]]
    return pose, move


def _write_lab_set(run_dir: Path, folder: Path, extra_rows: list[tuple[str, np.ndarray | None]] = ()) -> Path:
    """The twin's run `run_dir` written in the lab's format: grey frames, init_0.png and a
    targets CSV in the lab's columns (+ `extra_rows`: a frame name and its image or None)."""
    run = load_run(run_dir)
    folder.mkdir()
    cv2.imwrite(str(folder / "init_0.png"), cv2.cvtColor(run.frame(0), cv2.COLOR_RGB2GRAY))  # the no-contact frame
    columns = [
        "image_name",
        "data_name",
        "obj_id",
        "pose_id",
        *(f"pose_{k}" for k in range(1, 7)),
        *(f"move_{k}" for k in range(1, 7)),
    ]
    rows = []
    given = run.meta["scenario"]["protocol"]["given"]
    for k in range(len(run.samples) - 1):
        name = f"frame_{k}_0.png"
        cv2.imwrite(str(folder / name), cv2.cvtColor(run.frame(k + 1), cv2.COLOR_RGB2GRAY))
        rows.append([name, f"frame_{k}", 1, k + 1, *sum(_twin_to_lab(given[k]), [])])
    for name, image in extra_rows:
        if image is not None:
            cv2.imwrite(str(folder / name), image)
        rows.append([name, name[:-6], 1, len(rows) + 1, *sum(_twin_to_lab(given[0]), [])])
    with open(folder / "targets.csv", "w", newline="") as fh:
        csv.writer(fh).writerows([columns, *rows])
    return folder / "targets.csv"


@pytest.fixture(scope="module")
def twin_sheared_run(tmp_path_factory) -> Path:
    """Three sheared taps on the twin (fast dome), rendered, after its no-contact frame."""
    tmp = tmp_path_factory.mktemp("sheared")
    taps = [
        {
            "lateral_mm": 2.0,
            "theta_deg": 20.0,
            "depth_offset_mm": 0.5,
            "slide_along_mm": 1.5,
            "slide_lateral_mm": -1.0,
            "twist_deg": 3.0,
        },
        {"lateral_mm": -3.0, "theta_deg": -30.0, "slide_along_mm": -2.0, "twist_deg": -2.0},
        {"lateral_mm": 0.0, "theta_deg": 5.0, "depth_offset_mm": -0.5},
    ]
    scenario = {
        "name": "sheared",
        "object": {"name": "rectangle"},
        "fidelity": "fast",
        "effects": ["contact", "friction", "render"],
        "protocol": {"kind": "sheared_taps", "depth_mm": 2.5, "taps": 3, "given": taps},
    }
    path = tmp / "sheared.yaml"
    path.write_text(yaml.safe_dump(scenario))
    assert main(["run", str(path), "--out", str(tmp / "run"), "--workers", "1", "--quiet"]) == 0
    return tmp / "run"


def _import_lab(lab: Path, targets: Path, out: Path) -> int:
    """`twin import-lab` of the lab-format set in `lab` into `out` (nominal depth 2.5 mm)."""
    return main(["import-lab", str(lab), "--targets", str(targets), "--out", str(out), "--depth-mm", "2.5", "--quiet"])


def test_import_round_trips_the_twins_own_taps(twin_sheared_run: Path, tmp_path: Path, capsys) -> None:
    """The twin's sheared taps written in the lab's format and imported give back the
    twin's targets, labels and tracked pins; a blank frame is recorded flagged and a
    missing one without pins, both counted."""
    blank = np.zeros((480, 640), np.uint8)
    targets = _write_lab_set(twin_sheared_run, tmp_path / "lab", [("frame_3_0.png", blank), ("frame_4_0.png", None)])
    out = tmp_path / "imported"
    assert _import_lab(tmp_path / "lab", targets, out) == 0
    printed = capsys.readouterr().out
    assert "imported 6 frames" in printed and "4 with every pin tracked" in printed
    assert "1 with pins not found" in printed and "1 missing or unreadable" in printed
    twin, lab = load_run(twin_sheared_run), load_run(out)
    assert lab.meta["backend"] == "hardware" and lab.meta["import"]["incomplete"] == [4]
    assert lab.meta["import"]["unreadable"] == [5] and lab.samples[5]["pins_px"] is None
    assert not all(lab.samples[4]["found"]) and lab.samples[4]["pins_px"] is not None
    np.testing.assert_allclose(lab.targets[:4], twin.targets, atol=1e-5)
    for key in ("lateral_mm", "theta_deg", "depth_mm", "slide_along_mm", "slide_lateral_mm", "twist_deg"):
        np.testing.assert_allclose(lab.label(key)[:4], twin.label(key), atol=1e-5)
    np.testing.assert_allclose(lab.pins_px[:4], twin.pins_px, atol=0.05)
    np.testing.assert_allclose(lab.rest_pins_px, twin.rest_pins_px, atol=0.05)
    assert np.ptp(twin.pins_px[1:, :, 0] - twin.rest_pins_px[:, 0]) > 1.0  # the taps moved the pins
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the frame without pins has no pin difference, not a NaN mean
        assert main(["compare", str(out), str(out), "--out", str(tmp_path / "cmp")]) == 0


def test_an_imported_edge_radius_is_the_one_a_fit_must_model(twin_sheared_run: Path, tmp_path: Path) -> None:
    """`--edge-radius-mm` records the lab object's rounded edge in the run's scenario:
    `twin calibrate` reads the run with a twin whose rectangle is rounded alike and refuses
    a sharp one, naming the field; a negative radius is refused at the command line."""
    from twin.analysis.calibration_fit.data import load_data
    from twin.analysis.calibration_fit.settings import load_settings
    from twin.core.scenario import scenario_from_dict

    targets = _write_lab_set(twin_sheared_run, tmp_path / "lab")
    argv = ["import-lab", str(tmp_path / "lab"), "--targets", str(targets), "--depth-mm", "2.5", "--quiet"]
    assert main([*argv, "--edge-radius-mm", "1.5", "--out", str(tmp_path / "imp")]) == 0
    imported = load_run(tmp_path / "imp")
    assert imported.meta["scenario"]["object"]["edge_radius_mm"] == 1.5
    assert imported.meta["import"]["edge_radius_mm"] == 1.5
    twin = {
        "name": "fit",
        "object": {"name": "rectangle", "edge_radius_mm": 1.5},
        "sensor": {"camera": {"width": 640, "height": 480}},
        "protocol": {"kind": "sheared_taps", "depth_mm": 2.5},
    }
    weights = load_settings(None).weights
    data = load_data([tmp_path / "imp"], scenario_from_dict(twin, "fit.yaml"), weights)
    np.testing.assert_allclose(data.pins, imported.pins_px)
    with pytest.raises(UserError, match="scenario field 'object'"):
        load_data(
            [tmp_path / "imp"], scenario_from_dict({**twin, "object": {"name": "rectangle"}}, "sharp.yaml"), weights
        )
    assert main([*argv, "--edge-radius-mm", "-1", "--out", str(tmp_path / "bad")]) == 2
    assert not (tmp_path / "bad").exists()


def test_replay_takes_an_imported_runs_taps_in_order(twin_sheared_run: Path, tmp_path: Path, capsys) -> None:
    """`twin run --taps-from` replays an imported recording's taps: the same targets, in
    order (all, the first N, or every K-th); a scenario without a fitted camera is told that
    its pixels are not the recording's, and one pressing from another depth than the
    import's by how much."""
    targets = _write_lab_set(twin_sheared_run, tmp_path / "lab")
    assert _import_lab(tmp_path / "lab", targets, tmp_path / "imp") == 0
    scenario = {
        "name": "replay",
        "object": {"name": "rectangle"},
        "fidelity": "fast",
        "effects": ["contact"],
        "protocol": {"kind": "sheared_taps", "depth_mm": 2.5},
    }
    (tmp_path / "replay.yaml").write_text(yaml.safe_dump(scenario))
    assert (
        main(
            [
                "run",
                str(tmp_path / "replay.yaml"),
                "--taps-from",
                str(tmp_path / "imp"),
                "--first-taps",
                "2",
                "--out",
                str(tmp_path / "replay"),
                "--workers",
                "1",
                "--quiet",
            ]
        )
        == 0
    )
    np.testing.assert_allclose(load_run(tmp_path / "replay").targets, load_run(tmp_path / "imp").targets[:3], atol=1e-5)
    err = capsys.readouterr().err
    assert "has no fitted camera" in err and "deeper than the recording" not in err

    # --without-slides: the same frames' poses, reached without the slide and twist
    # (through a fitted camera, which the note then leaves out)
    still = tmp_path / "still"
    fitted = {"width": 640, "height": 480, "focal_px": 420.0}
    scenario["sensor"] = {"camera": {"width": 640, "height": 480}, "calibration": {"camera": fitted}}
    (tmp_path / "fitted.yaml").write_text(yaml.safe_dump(scenario))
    argv = ["run", str(tmp_path / "fitted.yaml"), "--taps-from", str(tmp_path / "imp"), "--first-taps", "2"]
    assert main([*argv, "--without-slides", "--out", str(still), "--workers", "1", "--quiet"]) == 0
    assert "has no fitted camera" not in capsys.readouterr().err
    replay, imported = load_run(still), load_run(tmp_path / "imp")
    np.testing.assert_allclose(replay.targets, imported.targets[:3], atol=1e-5)
    for key in ("lateral_mm", "theta_deg", "depth_mm"):
        np.testing.assert_allclose(replay.label(key)[1:], imported.label(key)[1:3], atol=1e-5)
    assert np.abs(imported.label("slide_along_mm")[1:3]).max() > 0.1  # the recording's taps do slide
    for key in ("slide_along_mm", "slide_lateral_mm", "twist_deg"):
        assert np.all(replay.label(key)[1:] == 0.0), key
    assert main(["run", str(tmp_path / "replay.yaml"), "--without-slides", "--out", str(tmp_path / "x")]) == 2

    # --every-nth-tap 2: taps 0 and 2 of the recording's three, after its no-contact sample
    spread = tmp_path / "every2"
    argv = ["run", str(tmp_path / "replay.yaml"), "--taps-from", str(tmp_path / "imp"), "--every-nth-tap", "2"]
    assert main([*argv, "--out", str(spread), "--workers", "1", "--quiet"]) == 0
    assert len(imported.samples) == 4
    every2 = load_run(spread)
    np.testing.assert_allclose(every2.targets, imported.targets[[0, 1, 3]], atol=1e-5)
    np.testing.assert_allclose(every2.label("theta_deg")[1:], imported.label("theta_deg")[[1, 3]], atol=1e-5)
    assert main(["run", str(tmp_path / "replay.yaml"), "--every-nth-tap", "2", "--out", str(tmp_path / "y")]) == 2

    # a scenario that presses from another depth than the import's is told by how much
    scenario["protocol"]["depth_mm"] = 3.0
    (tmp_path / "deeper.yaml").write_text(yaml.safe_dump(scenario))
    argv = ["run", str(tmp_path / "deeper.yaml"), "--taps-from", str(tmp_path / "imp"), "--first-taps", "1"]
    assert main([*argv, "--out", str(tmp_path / "deeper"), "--workers", "1", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "protocol.depth_mm = 3 mm" in err and "from 2.5 mm" in err and "+0.5 mm deeper" in err
    deeper = load_run(tmp_path / "deeper")
    np.testing.assert_allclose(deeper.targets[1, 2] - imported.targets[1, 2], 0.5, atol=1e-5)


def test_bad_targets_name_the_file_row_and_column(tmp_path: Path, capsys) -> None:
    path = tmp_path / "targets.csv"
    path.write_text("image_name,pose_1,pose_2\nframe_0_0.png,0,1\n")
    with pytest.raises(UserError, match="move_1"):
        read_lab_targets(path)
    header = (
        "image_name," + ",".join(f"pose_{k}" for k in range(1, 7)) + "," + ",".join(f"move_{k}" for k in range(1, 7))
    )
    path.write_text(header + "\nframe_0_0.png,0,x,0,0,0,0,0,0,0,0,0,0\n")
    with pytest.raises(UserError, match="row 2, column pose_2 = 'x'"):
        read_lab_targets(path)
    assert main(["import-lab", str(tmp_path), "--targets", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "pose_2" in capsys.readouterr().err
