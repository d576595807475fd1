"""The hardware backend end to end: the same runner, tracker, perception and controller
as in sim, driving the virtual IRB120 controller over its socket protocol on loopback
(through the lab's own client, cri), with the camera fed from a real video file through
cv2.VideoCapture. Also: a camera that runs dry stops the run safely and keeps the records."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from hardware.env import HardwareEnvironment
from hardware.protocol import Command
from hardware.virtual_controller import KinematicArm, VirtualRobotServer
from twin.analysis.comparison import compare_runs
from twin.core.errors import HardwareError, LostPinsError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.record import load_run
from twin.runs.run import run_scenario
from twin.runs.sim_env import SimEnvironment
from twin.runs.training import train_from_run
from twin.world.kinematics import Irb120Kinematics

POSES = [[0, 0, -5, 0, 0, 0], [60, 0, 2, 0, 0, 0], [62, 0, 3, 0, 0, 40], [58, 5, 4, 0, 0, -60]]


ONE_CHUNK = [[60, 0, 2, 0, 0, 0], [62, 0, 3, 0, 0, 0], [58, 5, 4, 0, 0, 0]]  # one orientation: no reset between


def _rendered_frames(poses: list[list[float]]) -> list[np.ndarray]:
    """RGB frames the sim renders at rest and then at each pose in turn (fast, no friction)."""
    scenario = scenario_from_dict(
        {"name": "video", "object": {"name": "rectangle"}, "fidelity": "fast", "effects": ["contact", "render"]}
    )
    with SimEnvironment(scenario) as env:
        return [env.reset().frame] + [env.step(Pose.from_array(p)).frame for p in poses]


def _write_video(path: Path, frames: list[np.ndarray]) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (640, 480))
    for frame in frames:
        writer.write(frame[..., ::-1])
    writer.release()
    return path


@pytest.fixture(scope="module")
def filmed(tmp_path_factory) -> tuple[Path, list[np.ndarray]]:
    """A real MJPG video of rendered TacTip frames as the camera films the render run of
    POSES[1:], and each press's projected pins (px). The runner starts every chunk (one per
    sensor orientation) with a reset that films the no-contact start pose, its tracker's
    reference; so does the sim backend, which renders each press after a reset (fast, no
    friction)."""
    path = tmp_path_factory.mktemp("video") / "tactip.avi"
    scenario = scenario_from_dict(
        {"name": "video", "object": {"name": "rectangle"}, "fidelity": "fast", "effects": ["contact", "render"]}
    )
    frames, pins = [], []
    with SimEnvironment(scenario) as env:
        for pose in POSES[1:]:
            frames.append(env.reset().frame)
            press = env.step(Pose.from_array(pose))
            frames.append(press.frame)
            pins.append(press.truth["pins_px"])
    return _write_video(path, frames), pins


@pytest.fixture(scope="module")
def video(filmed) -> Path:
    return filmed[0]


@pytest.fixture
def server():
    with VirtualRobotServer("127.0.0.1", 0, KinematicArm(Irb120Kinematics())) as srv:
        yield srv


def _config(tmp_path: Path, port: int, video: Path) -> Path:
    config = {
        "robot": {
            "host": "127.0.0.1",
            "port": port,
            "client": "cri",
            "linear_speed_mm_s": 40,
            "work_frame_mm_deg": [400, 0, 10, 180, 0, 0],
            "start_pose_mm_deg": [0, 0, -5, 0, 0, 0],
        },
        "camera": {"source": str(video), "warmup": 0},
        "safety": {"x_mm": [-100, 100], "y_mm": [-100, 100], "z_mm": [-60, 6]},
    }
    path = tmp_path / "rig.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_runner_records_a_hardware_run(tmp_path, server, filmed) -> None:
    video, truth = filmed
    scenario = scenario_from_dict(
        {
            "name": "hw_render",
            "backend": "hardware",
            "object": {"name": "rectangle"},
            "hardware_config": str(_config(tmp_path, server.port, video)),
            "protocol": {"kind": "render", "poses": POSES[1:]},
        }
    )
    run = load_run(run_scenario(scenario, tmp_path / "run", progress=False))
    assert run.meta["backend"] == "hardware" and run.meta["status"] == "completed"
    assert len(run.samples) == 3
    for sample, target, pins in zip(run.samples, POSES[1:], truth):
        assert np.allclose(sample["pose"][:3], target[:3], atol=0.01)  # measured by the controller
        assert sample["truth"] == {} and sample["frame"] is not None
        assert sum(sample["found"]) == 127  # tracked from MJPG video frames
        # the frame filmed at this pose, tracked from its chunk's no-contact reference
        assert np.sqrt(np.mean(np.sum((np.asarray(sample["pins_px"]) - pins) ** 2, axis=1))) < 1.0
    assert run.frame(0).shape == (480, 640, 3)


def test_a_calibrated_tcp_reaches_the_robot_as_its_tool(tmp_path, server, video) -> None:
    """The calibration's apex offset (mm, tool frame) and the sensor's roll on its mount
    (deg about the tool's z) are the robot's tool: the configured TCP (0, 0, 101) moved by
    (1, -2, 0.5) and turned 90 deg is, on the wire, (1, -2, 101.5) with the quaternion
    (cos 45 deg, 0, 0, sin 45 deg) (w, x, y, z)."""
    scenario = scenario_from_dict(
        {
            "name": "hw_calibrated",
            "backend": "hardware",
            "object": {"name": "rectangle"},
            "hardware_config": str(_config(tmp_path, server.port, video)),
            "sensor": {"calibration": {"tcp_offset_mm": [1.0, -2.0, 0.5], "tcp_roll_deg": 90.0}},
        }
    )
    with HardwareEnvironment.from_scenario(scenario) as env:
        env.reset()
        half = np.sqrt(0.5)
        assert server.tool == pytest.approx((1.0, -2.0, 101.5, half, 0.0, 0.0, half), abs=1e-4)
        target = Pose(2.0, 1.0, -3.0, 0.0, 0.0, 30.0)
        assert np.allclose(env.step(target).pose.as_array(), target.as_array(), atol=0.01)


@pytest.fixture(scope="module")
def tap_model_file(tmp_path_factory) -> Path:
    """A PCA+GP model trained on a small sim tap set (6 orientations) of the same sensor."""
    tmp = tmp_path_factory.mktemp("taps")
    taps = scenario_from_dict(
        {
            "name": "small_taps",
            "object": {"name": "rectangle"},
            "fidelity": "fast",
            "effects": ["contact"],
            "protocol": {"kind": "taps", "orientations_deg": [-120, -60, 0, 60, 120, 180]},
        }
    )
    model = train_from_run(load_run(run_scenario(taps, tmp / "taps", workers=1, progress=False)))
    return model.save(tmp / "model.npz")


def test_same_contour_controller_runs_on_hardware(tmp_path, server, video, tap_model_file) -> None:
    model_path = tap_model_file
    scenario = scenario_from_dict(
        {
            "name": "hw_contour",
            "backend": "hardware",
            "object": {"name": "rectangle"},
            "hardware_config": str(_config(tmp_path, server.port, video)),
            "effects": ["contact", "friction", "render"],
            "protocol": {"kind": "contour", "max_steps": 3, "model": str(model_path)},
        }
    )
    run = load_run(run_scenario(scenario, tmp_path / "contour", progress=False))
    assert run.meta["status"] == "completed" and len(run.samples) == 3
    assert (tmp_path / "contour" / "metrics.json").exists() and (tmp_path / "contour" / "contour.png").exists()
    # reset + approach + descend + 2 controller steps + lift, all sent to the controller
    assert server.count(Command.MOVE_LINEAR) >= 6


def test_camera_running_dry_stops_safely_and_keeps_records(tmp_path, server, video) -> None:
    poses = [[60, 0, 2, 0, 0, 0]] * 40  # more observations than the video has frames
    scenario = scenario_from_dict(
        {
            "name": "hw_dry",
            "backend": "hardware",
            "object": {"name": "rectangle"},
            "hardware_config": str(_config(tmp_path, server.port, video)),
            "protocol": {"kind": "render", "poses": poses},
        }
    )
    with pytest.raises(HardwareError, match="end of video"):
        run_scenario(scenario, tmp_path / "dry", progress=False)
    run = load_run(tmp_path / "dry")
    assert run.meta["status"] == "failed" and "end of video" in run.meta["error"]
    assert 0 < len(run.samples) < 40


def test_lost_pins_stop_the_run_and_keep_records(tmp_path, server, video) -> None:
    """A frame where the skin is covered (half the pins gone) stops the run safely."""
    rest, first, second, third = _rendered_frames(ONE_CHUNK)
    covered = third.copy()
    covered[:, : covered.shape[1] // 2] = 0
    bad_video = _write_video(tmp_path / "covered.avi", [rest, first, second, covered, covered])
    scenario = scenario_from_dict(
        {
            "name": "hw_lost",
            "backend": "hardware",
            "object": {"name": "rectangle"},
            "hardware_config": str(_config(tmp_path, server.port, bad_video)),
            "protocol": {"kind": "render", "poses": ONE_CHUNK},
        }
    )
    with pytest.raises(LostPinsError, match=r"lost \d+/127 pins"):
        run_scenario(scenario, tmp_path / "lost", progress=False)
    run = load_run(tmp_path / "lost")
    assert run.meta["status"] == "failed" and "LostPinsError" in run.meta["error"]
    assert len(run.samples) == 2


def test_compare_sim_and_hardware_runs(tmp_path, server, video) -> None:
    """sim-to-real: the same scenario on both backends, paired by target pose."""
    base = {
        "name": "s2r",
        "object": {"name": "rectangle"},
        "fidelity": "fast",
        "effects": ["contact", "render"],
        "protocol": {"kind": "render", "poses": ONE_CHUNK},
    }
    replay = _write_video(tmp_path / "replay.avi", _rendered_frames(ONE_CHUNK))
    sim = run_scenario(scenario_from_dict(base), tmp_path / "sim", workers=1, progress=False)
    real = run_scenario(
        scenario_from_dict(
            {**base, "backend": "hardware", "hardware_config": str(_config(tmp_path, server.port, replay))}
        ),
        tmp_path / "real",
        progress=False,
    )
    result = compare_runs(sim, real, tmp_path / "cmp")
    assert result["backend_a"] == "sim" and result["backend_b"] == "hardware" and result["n_pairs"] == 3
    # the "real" camera replays frames rendered by the same sim: close, not equal (MJPG)
    assert result["pin_rms_difference_px"] < 1.0 and result["ssim"]["mean"] > 0.8
