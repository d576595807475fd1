"""The virtual controller speaks the RAPID server protocol: the lab's cri client and our
RobotDriver drive it over real loopback sockets (ephemeral ports, no mocks)."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from hardware.config import hardware_config_from_dict
from hardware.env import HardwareEnvironment
from hardware.protocol import (
    Command,
    ProtocolError,
    decode_reply_values,
    decode_request,
    encode_reply,
    encode_request,
    pose_to_wire,
    wire_to_matrix,
    wire_to_pose,
)
from hardware.robot import RobotCommandRefused, RobotDriver
from hardware.virtual_controller import KinematicArm, VirtualRobotServer
from twin.core.errors import HardwareError, SafetyError, UserError
from twin.core.poses import Pose, angle_between_rotations_deg, quat_wxyz_to_matrix
from twin.world.kinematics import Irb120Kinematics

TCP = Pose(0, 0, 101.0, 0, 0, 0)
WORK = Pose(400, 0, 50, 180, 0, 0)
POS_TOL_MM = 0.01
ANG_TOL_DEG = 0.01


@pytest.fixture(scope="module")
def kinematics() -> Irb120Kinematics:
    return Irb120Kinematics()


@pytest.fixture
def server(kinematics):
    with VirtualRobotServer("127.0.0.1", 0, KinematicArm(kinematics)) as srv:
        yield srv


def assert_pose_close(a: Pose, b: Pose) -> None:
    assert np.linalg.norm(a.as_array()[:3] - b.as_array()[:3]) <= POS_TOL_MM, (a, b)
    assert angle_between_rotations_deg(a.rotation, b.rotation) <= ANG_TOL_DEG, (a, b)


# ---------------------------------------------------------------------------- codec
def test_codec_round_trips_every_command():
    cases = {
        Command.GET_INFO: (),
        Command.MOVE_JOINTS: tuple(range(6)),
        Command.MOVE_LINEAR: (1, 2, 3, 1, 0, 0, 0),
        Command.MOVE_CIRCULAR: tuple(range(14)),
        Command.SET_TOOL: (0, 0, 89.5, 1, 0, 0, 0),
        Command.SET_WORK_OBJECT: (400, 0, 50, 0, 1, 0, 0),
        Command.SET_SPEED: (20, 10),
        Command.SET_ZONE: (1, 0.5, 0.5, 0.25),
        Command.GET_JOINTS: (),
        Command.GET_POSE: (),
        Command.CLOSE: (),
    }
    for command, args in cases.items():
        data = encode_request(command, *args)
        assert data[:2] == int(command).to_bytes(2, "big")
        assert decode_request(data) == (command, tuple(float(a) for a in args))
    # exact bytes: big-endian code, big-endian float32
    assert encode_request(Command.SET_SPEED, 20, 10) == b"\x00\x06" + bytes.fromhex("41a00000") + bytes.fromhex(
        "41200000"
    )
    assert encode_reply(Command.GET_JOINTS, True, (1, 2, 3, 4, 5, 6))[:2] == b"\x00\x01"
    assert decode_reply_values(Command.GET_POSE, encode_reply(Command.GET_POSE, True, (1, 2, 3, 1, 0, 0, 0))[2:]) == (
        1,
        2,
        3,
        1,
        0,
        0,
        0,
    )
    assert encode_reply(Command.MOVE_LINEAR, False) == b"\x00\x00"
    with pytest.raises(ProtocolError, match="unknown command code 42"):
        decode_request(b"\x00\x2a")
    with pytest.raises(ProtocolError):
        encode_request(Command.MOVE_LINEAR, 1, 2, 3)


def test_pose_wire_round_trip():
    for pose in [Pose(10, -5, 3, 5, -3, 30), Pose(0, 0, 0, 180, 0, 0), Pose(1, 2, 3, -20, 15, -160)]:
        wire = pose_to_wire(pose)
        assert wire[3] >= 0
        assert_pose_close(wire_to_pose(wire), pose)
        assert np.allclose(wire_to_matrix(wire), pose.to_matrix())


# ---------------------------------------------------------------------------- cri's client
def test_cri_controller_drives_the_virtual_robot(server, kinematics):
    from cri.abb.abb_client import ABBClient
    from cri.controller import ABBController  # (cri.abb.abb_controller alone is a circular import)

    ctrl = ABBController(ip="127.0.0.1", port=server.port)
    try:
        assert "virtual IRB120" in ctrl.info
        ctrl.tcp = (0, 0, 101.0, 1, 0, 0, 0)
        ctrl.linear_speed = 30
        ctrl.angular_speed = 15
        ctrl.blend_radius = 0
        assert server.tool == pytest.approx((0, 0, 101.0, 1, 0, 0, 0), abs=1e-4)
        assert server.speed == pytest.approx((30, 15))
        assert server.zone.point_motion

        target = (400.0, 20.0, 180.0, 0.0, 0.0, 1.0, 0.0)  # base frame, tool pointing down
        ctrl.move_linear(target)
        pose = np.asarray(ctrl.pose)
        assert np.linalg.norm(pose[:3] - target[:3]) <= POS_TOL_MM
        assert (
            angle_between_rotations_deg(quat_wxyz_to_matrix(pose[3:]), quat_wxyz_to_matrix(np.array(target[3:])))
            <= ANG_TOL_DEG
        )
        expected = kinematics.forward(np.radians(ctrl.joint_angles)) @ TCP.to_matrix()
        assert np.allclose(expected[:3, 3] * 1e3, target[:3], atol=POS_TOL_MM)

        joints = [10.0, 20.0, 10.0, 0.0, 50.0, 20.0]
        ctrl.move_joints(joints)
        assert np.allclose(ctrl.joint_angles, joints, atol=ANG_TOL_DEG)
    finally:
        ctrl.close()

    # the client itself also sets the work object (the controller class hides it)
    client = ABBClient("127.0.0.1", server.port)
    try:
        client.set_tcp((0, 0, 101.0, 1, 0, 0, 0))
        client.set_work_object(pose_to_wire(WORK))
        client.set_speed(40, 20)
        target = pose_to_wire(Pose(10, -5, -20, 5, -3, 30))
        client.move_linear(target)
        assert_pose_close(wire_to_pose(client.get_pose()), Pose(10, -5, -20, 5, -3, 30))
        with pytest.raises(ABBClient.CommandFailed):  # unreachable: the protocol's ERROR reply
            client.move_linear((2000, 0, 0, 1, 0, 0, 0))
        assert "MOVE_LINEAR" in server.last_error
    finally:
        client.close()


# ---------------------------------------------------------------------------- our driver
@pytest.mark.parametrize("client", ["cri", "native"])
def test_robot_driver_drives_the_virtual_robot(server, client):
    with RobotDriver("127.0.0.1", server.port, client=client) as robot:
        robot.configure(TCP, WORK, 25.0, 12.0)
        assert server.tool == pytest.approx(pose_to_wire(TCP), abs=1e-4)
        assert server.work_object == pytest.approx(pose_to_wire(WORK), abs=1e-4)
        assert server.speed == pytest.approx((25.0, 12.0)) and server.zone.point_motion
        for pose in [Pose(0, 0, -10), Pose(10, -5, -20, 5, -3, 30), Pose(-30, 40, 2, -10, 8, -160)]:
            robot.move_linear(pose)
            assert_pose_close(robot.get_pose(), pose)
        t_before = server.backend.time_s
        robot.move_linear(Pose(-30, 40 + 25.0, 2, -10, 8, -160))  # 25 mm at 25 mm/s
        assert server.backend.time_s - t_before == pytest.approx(1.0, rel=1e-3)
        joints = np.array([5.0, 30.0, 20.0, -10.0, 40.0, 15.0])
        robot.move_joints(joints)
        assert np.allclose(robot.get_joints(), joints, atol=ANG_TOL_DEG)
        with pytest.raises(RobotCommandRefused, match=rf"127.0.0.1:{server.port} refused MOVE_LINEAR"):
            robot.move_linear(Pose(0, 0, -900))
        assert np.allclose(robot.get_joints(), joints, atol=ANG_TOL_DEG), "a refused move does not move"
    deadline = time.monotonic() + 1.0
    while server.count(Command.CLOSE) == 0 and time.monotonic() < deadline:
        time.sleep(0.01)  # the goodbye has no reply: give the server a moment to read it
    assert server.count(Command.CLOSE) == 1


def test_no_server_at_the_address():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nobody listens here once closed
    t0 = time.monotonic()
    with pytest.raises(HardwareError, match=rf"cannot connect to the robot at 127.0.0.1:{port}"):
        RobotDriver("127.0.0.1", port, client="native", connect_timeout_s=1.0)
    assert time.monotonic() - t0 < 1.5


@pytest.mark.parametrize("client", ["cri", "native"])
def test_server_killed_mid_move_raises_within_the_timeout(kinematics, client):
    srv = VirtualRobotServer("127.0.0.1", 0, KinematicArm(kinematics)).start()
    robot = RobotDriver("127.0.0.1", srv.port, client=client, reply_timeout_s=2.0)
    try:
        robot.configure(TCP, WORK, 10.0, 10.0)
        robot.move_linear(Pose(0, 0, -10))  # from home, instantly
        srv.realtime_factor = 1.0  # from now on a move takes its duration of wall time
        threading.Timer(0.3, srv.shutdown).start()
        t0 = time.monotonic()
        with pytest.raises(HardwareError, match=rf"127.0.0.1:{srv.port}"):
            robot.move_linear(Pose(0, 0, -40))  # 30 mm at 10 mm/s: 3 s of (wall) motion
        assert time.monotonic() - t0 < 2.0
        with pytest.raises(HardwareError):
            robot.get_pose()
    finally:
        robot.close()
        srv.shutdown()


@pytest.mark.parametrize("client", ["cri", "native"])
def test_silent_server_times_out_naming_the_address(client):
    listener = socket.create_server(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    accepted: list[socket.socket] = []
    thread = threading.Thread(target=lambda: accepted.append(listener.accept()[0]), daemon=True)
    thread.start()
    try:
        robot = RobotDriver("127.0.0.1", port, client=client, reply_timeout_s=0.4)
        t0 = time.monotonic()
        with pytest.raises(HardwareError, match=rf"robot at 127.0.0.1:{port} did not answer SET_TOOL within 0.4 s"):
            robot.set_tool(TCP)
        assert time.monotonic() - t0 < 1.5
        robot.close()
    finally:
        thread.join(1.0)
        for conn in accepted:
            conn.close()
        listener.close()


def test_remote_bind_needs_consent():
    with pytest.raises(UserError, match="not a loopback address"):
        VirtualRobotServer("0.0.0.0", 0)


# ---------------------------------------------------------------------------- hardware environment
def _write_video(path: Path, n: int) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (640, 480))
    for i in range(n):
        frame = np.full((480, 640, 3), 30, np.uint8)
        cv2.circle(frame, (320, 240), 180, (70, 70, 70), -1)
        cv2.putText(frame, str(i), (250, 280), cv2.FONT_HERSHEY_SIMPLEX, 3, (255, 255, 255), 6)
        writer.write(frame)
    writer.release()
    return path


def test_hardware_environment_with_virtual_robot_and_video(server, tmp_path):
    video = _write_video(tmp_path / "tactip.avi", 10)
    config = hardware_config_from_dict(
        {
            "robot": {
                "port": server.port,
                "client": "native",
                "tcp_mm_deg": list(TCP.as_array()),
                "work_frame_mm_deg": list(WORK.as_array()),
                "linear_speed_mm_s": 30,
            },
            "camera": {"source": video.name},
        },
        "test.yaml",
        base_dir=tmp_path,
    )
    env = HardwareEnvironment(config)
    try:
        obs = env.reset()
        assert_pose_close(obs.pose, config.robot.start_pose)
        times = [obs.time]
        for pose in [Pose(0, 0, 2), Pose(5, -3, 1.5, 0, 0, 90), Pose(-10, 10, -5, 5, -5, -160)]:
            obs = env.step(pose, speed_mm_s=40)
            assert_pose_close(obs.pose, pose)
            assert obs.frame.shape == (480, 640, 3) and obs.pins_px is None and obs.truth == {}
            times.append(obs.time)
        assert all(b > a for a, b in zip(times, times[1:]))
        assert server.speed[0] == pytest.approx(40)

        n_commands = len(server.command_log)
        with pytest.raises(SafetyError, match=r"x = 81.0 mm is above the limit 80.0 mm \(safety.x_mm\)"):
            env.move_to(Pose(81, 0, 0))
        with pytest.raises(SafetyError, match="max indentation depth"):
            env.move_to(Pose(0, 0, 6.5))
        with pytest.raises(SafetyError, match="not a finite number"):
            env.move_to(Pose(0, float("nan"), 0))
        with pytest.raises(SafetyError, match="linear speed"):
            env.move_to(Pose(0, 0, 0), speed_mm_s=500)
        time.sleep(0.1)
        assert len(server.command_log) == n_commands, "a refused move sends nothing"
    finally:
        env.close()
        env.close()
    with pytest.raises(UserError, match="closed"):
        env.observe()


def test_bad_hardware_config_names_file_field_and_value():
    with pytest.raises(UserError, match=r"rig.yaml: invalid hardware config\n  robot.port = 70000"):
        hardware_config_from_dict({"robot": {"port": 70000}}, "rig.yaml")
    with pytest.raises(UserError, match=r"safety.x_mm"):
        hardware_config_from_dict({"safety": {"x_mm": [5, -5]}}, "rig.yaml")


def test_example_config_loads():
    from hardware.config import load_hardware_config

    config = load_hardware_config(Path(__file__).resolve().parents[2] / "hardware" / "example_config.yaml")
    assert (config.robot.host, config.robot.port) == ("127.0.0.1", 5000)


def test_missing_cri_is_a_user_error(monkeypatch, server):
    import sys

    monkeypatch.setitem(sys.modules, "cri", None)  # what Python sees when the extra is not installed
    monkeypatch.setitem(sys.modules, "cri.abb", None)
    monkeypatch.setitem(sys.modules, "cri.abb.abb_client", None)
    with pytest.raises(UserError, match=r"uv sync --extra robot \(GPL-3.0\)"):
        RobotDriver("127.0.0.1", server.port, client="cri")


def test_unknown_command_gets_error_status_and_connection_survives(server):
    with socket.create_connection(("127.0.0.1", server.port), timeout=2.0) as s:
        s.sendall(b"\x00\x2a")
        assert s.recv(16) == b"\x00\x00"
        s.sendall(encode_request(Command.GET_JOINTS))
        reply = s.recv(64)
        assert reply[:2] == b"\x00\x01" and len(reply) == 2 + 24
