"""Numbers at both ends of the wire, over real loopback sockets. The driver refuses what
float32 cannot carry (bool, str, None, non-finite, beyond ±3.4e38, a speed too small to
send) by name before a byte leaves; the virtual controller range-checks every number of
every request before computing with it and answers ERROR, changing nothing and staying up;
`twin serve-robot`'s own options are refused with one line and exit 2."""

from __future__ import annotations

import logging
import math
import signal
import socket
import struct
import subprocess
import sys
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hardware.protocol import Command, encode_request, pose_to_wire
from hardware.robot import RobotDriver
from hardware.virtual_controller import FIELD_RANGES, KinematicArm, VirtualRobotServer
from tests.hardware.loopback import free_port
from twin.core.errors import SafetyError, UserError
from twin.core.poses import Pose
from twin.tools.cli import main as twin_main

TCP = Pose(0, 0, 101.0, 0, 0, 0)
WORK = Pose(400, 0, 50, 180, 0, 0)


@pytest.fixture
def server():
    with VirtualRobotServer("127.0.0.1", 0, KinematicArm()) as srv:
        yield srv


@pytest.fixture
def robot(server):
    with RobotDriver("127.0.0.1", server.port, client="native") as driver:
        driver.configure(TCP, WORK, 20.0, 20.0)
        driver.move_linear(Pose(0, 0, -10))
        yield driver


def _settled_log_length(server: VirtualRobotServer) -> int:
    time.sleep(0.05)  # anything sent has arrived
    return len(server.command_log)


# ---------------------------------------------------------------------------- the driver
@pytest.mark.parametrize(
    "call, match",
    [
        (lambda r: r.set_speed(1e-300, 20), r"^linear speed = 1e-300 mm/s is too small to send: .* carries it as 0 "),
        (lambda r: r.set_speed(1e-40, 20), r"^linear speed = 1e-40 mm/s is too small to send: .* as 9\.99995e-41 "),
        (
            lambda r: r.set_speed(20, 1e-30),
            r"^angular speed = 1e-30 deg/s is below the slowest speed the driver sends, 0\.01",
        ),
        (lambda r: r.set_speed("5", 20), r"^linear speed = '5' is not a number \(str\)$"),
        (lambda r: r.set_speed(10**400, 20), r"^linear speed = ~1e\+400 mm/s is beyond the robot's float32 range"),
        (lambda r: r.set_speed(True, 20), r"^linear speed = True is not a number \(bool\)$"),
        (lambda r: r.move_linear(Pose(None, 0, -10)), r"^pose \(None, 0, -10, 0, 0, 0\): x = None is not a number"),
        (lambda r: r.move_linear(Pose(True, 0, -10)), r"^pose \(True, .*\): x = True is not a number \(bool\)$"),
        (lambda r: r.move_linear(Pose(0, "5", -10)), r"^pose \(0, '5', .*\): y = '5' is not a number \(str\)$"),
        (
            lambda r: r.move_linear(Pose(0, 0, 10**400)),
            r"^pose .*: z = ~1e\+400 mm is beyond the robot's float32 range",
        ),
        (
            lambda r: r.move_linear(Pose(0, 0, -10, 0, 0, math.inf)),
            r"^pose .*: gamma = inf deg is not a finite number$",
        ),
        (lambda r: r.set_tool(Pose(0, 0, 3.5e38)), r"^tool \(0, 0, 3\.5e\+38, .*\): z = 3\.5e\+38 mm is beyond"),
        (lambda r: r.set_work_frame(Pose(400, 0, 50, None)), r"^work frame \(.*\): alpha = None is not a number"),
        (lambda r: r.move_joints([0, 0, 0, 0, "30", 0]), r"^joint 5 = '30' is not a number \(str\)$"),
        (lambda r: r.move_joints([0, 0, 0, 0, 1e39, 0]), r"^joint 5 = 1e\+39 deg is beyond the robot's float32 range"),
    ],
)
def test_the_driver_refuses_a_number_the_wire_cannot_carry_by_name_and_sends_nothing(server, robot, call, match):
    before = _settled_log_length(server)
    with pytest.raises(SafetyError, match=match) as err:
        call(robot)
    assert "\n" not in str(err.value) and len(str(err.value)) < 250
    assert _settled_log_length(server) == before, "a refused number sends nothing"
    robot.move_linear(Pose(1, 0, -10))  # the link is intact: nothing half-sent
    assert robot.get_pose().x == pytest.approx(1, abs=1e-3)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"port": 70000}, r"robot port = 70000 is not a TCP port"),
        ({"port": True}, r"robot port = True is not a TCP port"),
        ({"reply_timeout_s": math.nan}, r"robot reply_timeout_s = nan must be a number in \(0, 1e\+06\]"),
        ({"connect_timeout_s": -1.0}, r"robot connect_timeout_s = -1 must be"),
    ],
)
def test_the_driver_refuses_an_address_or_timeout_it_cannot_use(kwargs, match):
    with pytest.raises(UserError, match=match):
        RobotDriver(**{"host": "127.0.0.1", "port": 1, "client": "native"} | kwargs)


def test_safety_messages_show_numpy_numbers_as_numbers():
    from hardware.safety import SafetyLimits

    with pytest.raises(SafetyError, match=r": x = 81\.0 mm is above the limit 80\.0 mm \(safety\.x_mm\)$"):
        SafetyLimits().check_pose(Pose(np.float64(81.0), np.float32(0), 0))


def test_a_tiny_coordinate_goes_out_as_the_zero_it_is(server, robot):
    robot.move_linear(Pose(1e-40, 0, -10))
    x = server.command_log[-1].args[0]
    assert x == pytest.approx(0, abs=1.2e-38) and robot.get_pose().x == pytest.approx(0, abs=1e-3)


# ---------------------------------------------------------------------------- the controller
#: float32 bit patterns no field accepts: ±max, ±inf, NaNs with and without payloads
BAD_PATTERNS = [
    "7f7fffff",
    "ff7fffff",
    "7f800000",
    "ff800000",
    "7fc00000",
    "ffc00000",
    "7f800001",
    "7fbfffff",
    "ffffffff",
]


def _valid_args(command: Command, here: tuple[float, ...]) -> list[float]:
    """Arguments every field range accepts; a linear move goes to `here` (the TCP's pose)."""
    return {
        Command.MOVE_JOINTS: [0, 10, 10, 0, 30, 0],
        Command.MOVE_LINEAR: list(here),
        Command.MOVE_CIRCULAR: [*here, *here],
        Command.SET_TOOL: list(pose_to_wire(TCP)),
        Command.SET_WORK_OBJECT: list(pose_to_wire(WORK)),
        Command.SET_SPEED: [20.0, 20.0],
        Command.SET_ZONE: [1, 0, 0, 0],
    }[command]


def _out_of_range_words(command: Command, index: int) -> list[bytes]:
    """A field's 4 bytes (point_motion: 2) out of its range: the next float32 beyond each
    bound and every bad pattern; point_motion (uint16) above 1."""
    if command is Command.SET_ZONE and index == 0:
        return [struct.pack(">H", v) for v in (2, 65535)]
    _, lo, hi, _ = FIELD_RANGES[command][index]
    beyond = [np.nextafter(np.float32(hi), np.float32(np.inf)), np.nextafter(np.float32(lo), np.float32(-np.inf))]
    return [struct.pack(">f", v) for v in beyond] + [bytes.fromhex(b) for b in BAD_PATTERNS]


def _state(server: VirtualRobotServer) -> tuple:
    return server.tool, server.work_object, server.speed, server.zone, tuple(server.backend.get_joints())


def _ask(sock: socket.socket, data: bytes, n: int = 2) -> bytes:
    sock.sendall(data)
    buf = b""
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        assert chunk, "the server closed the connection"
        buf += chunk
    return buf


@pytest.mark.parametrize("command", list(FIELD_RANGES))
def test_every_field_out_of_range_gets_error_naming_it_and_changes_nothing(server, command):
    state = _state(server)
    with socket.create_connection(("127.0.0.1", server.port), timeout=5) as sock:
        here = struct.unpack(">7f", _ask(sock, encode_request(Command.GET_POSE), 30)[2:])
        for index, (name, *_) in enumerate(FIELD_RANGES[command]):
            for word in _out_of_range_words(command, index):
                words = [
                    struct.pack(">H" if command is Command.SET_ZONE and i == 0 else ">f", a)
                    for i, a in enumerate(_valid_args(command, here))
                ]
                words[index] = word
                assert _ask(sock, struct.pack(">H", int(command)) + b"".join(words)) == b"\x00\x00", (name, word)
                assert server.last_error.startswith(f"{command.name}: {name} = ") and "is outside" in server.last_error
                assert _state(server) == state
        assert _ask(sock, encode_request(Command.GET_POSE), 30)[:2] == b"\x00\x01"  # still answering
        if command is not Command.MOVE_CIRCULAR:  # the same request in range is carried out
            assert _ask(sock, encode_request(command, *_valid_args(command, here))) == b"\x00\x01"
    assert server.internal_faults == 0


@pytest.fixture(scope="module")
def shared_server():
    with (
        VirtualRobotServer("127.0.0.1", 0, KinematicArm()) as srv,
        socket.create_connection(("127.0.0.1", srv.port), timeout=10) as sock,
    ):
        yield srv, sock


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.sampled_from(list(FIELD_RANGES)).flatmap(
        lambda c: st.tuples(
            st.just(c),
            st.lists(st.integers(0, 2**32 - 1), min_size=len(FIELD_RANGES[c]), max_size=len(FIELD_RANGES[c])),
        )
    )
)
def test_any_bit_pattern_in_any_field_is_answered_and_none_out_of_range_is_accepted(shared_server, request_bits):
    """Every 32-bit pattern is a float32 (NaN payloads, denormals, ±0, ±inf, ±max alike)."""
    server, sock = shared_server
    command, bits = request_bits
    words = [
        struct.pack(">H", b & 0xFFFF) if command is Command.SET_ZONE and i == 0 else struct.pack(">I", b)
        for i, b in enumerate(bits)
    ]
    values = [struct.unpack(">H" if len(w) == 2 else ">f", w)[0] for w in words]
    in_range = all(
        float(np.float32(lo)) <= v <= float(np.float32(hi)) for v, (_, lo, hi, _) in zip(values, FIELD_RANGES[command])
    )
    status = _ask(sock, struct.pack(">H", int(command)) + b"".join(words))
    assert status in (b"\x00\x00", b"\x00\x01")
    assert in_range or status == b"\x00\x00", (command.name, values)
    assert server.internal_faults == 0, server.last_error


def test_every_field_at_its_bounds_passes_the_range_check():
    from hardware.virtual_controller import check_request_ranges

    for command, ranges in FIELD_RANGES.items():
        for pick in (1, 2):  # lows, highs, as float32 carries them
            args = tuple(float(np.float32(r[pick])) for r in ranges)
            check_request_ranges(command, args)


def test_the_first_round_crashes_are_refused_and_the_server_stays_up():
    """SET_TOOL 3.4e38 mm with a work object turned 45° then GET_POSE; SET_SPEED 1e-30
    then a move with real-time moves: each killed the server before."""
    c, s = math.cos(math.radians(22.5)), math.sin(math.radians(22.5))
    with (
        VirtualRobotServer("127.0.0.1", 0, KinematicArm(), realtime_factor=1.0) as server,
        socket.create_connection(("127.0.0.1", server.port), timeout=5) as sock,
    ):
        assert _ask(sock, encode_request(Command.SET_TOOL, 3.4e38, 3.4e38, 3.4e38, 1, 0, 0, 0)) == b"\x00\x00"
        assert _ask(sock, encode_request(Command.SET_WORK_OBJECT, 0, 0, 0, c, s, 0, 0)) == b"\x00\x01"
        reply = _ask(sock, encode_request(Command.GET_POSE), 30)
        assert reply[:2] == b"\x00\x01" and np.all(np.isfinite(struct.unpack(">7f", reply[2:])))
        assert _ask(sock, encode_request(Command.SET_SPEED, 1e-30, 1e-30)) == b"\x00\x00"
        assert _ask(sock, encode_request(Command.MOVE_JOINTS, 0, 0, 0, 0, 30.5, 0)) == b"\x00\x01"  # 0.5° at 50 deg/s
        assert server.speed == (100.0, 50.0) and server.internal_faults == 0
        assert len(_ask(sock, encode_request(Command.GET_JOINTS), 26)) == 26


@pytest.mark.parametrize(
    "option, value, shown",
    [
        ("--port", "70000", "70000"),
        ("--port", "-1", "-1"),
        ("--log-limit", "-1", "-1"),
        ("--realtime", "nan", "nan"),
        ("--realtime", "1e308", "1e+308"),
        ("--realtime", "-1", "-1"),
        ("--idle-timeout", "inf", "inf"),
    ],
)
def test_serve_robot_options_out_of_range_exit_2_with_one_line_naming_them(capsys, option, value, shown):
    assert twin_main(["serve-robot", "--port", str(free_port()), option, value]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    words = lines[0].replace("-", " ").replace("_", " ")
    assert option.lstrip("-").replace("-", " ") in words and shown in lines[0], err


def test_constructor_refuses_what_the_cli_cannot_send():
    with pytest.raises(UserError, match=r"port = True is not a TCP port"):
        VirtualRobotServer("127.0.0.1", True)
    with pytest.raises(UserError, match=r"log limit = 2\.5 must be a count"):
        VirtualRobotServer("127.0.0.1", 0, log_limit=2.5)


def test_serve_robot_exits_130_on_ctrl_c():
    """README, exit codes: SIGINT 130 (SIGTERM's 143 is checked after every soak)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "twin.tools.cli", "serve-robot", "--port", str(free_port())],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert "listening on 127.0.0.1:" in proc.stdout.readline()
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=20)
    finally:
        proc.kill()
    assert proc.returncode == 130 and "Traceback" not in err, err


def test_serve_robot_port_0_takes_a_free_port_and_says_which():
    proc = subprocess.Popen(
        [sys.executable, "-m", "twin.tools.cli", "serve-robot", "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        port = int(line.split("listening on 127.0.0.1:")[1].split(";")[0])
        assert 0 < port <= 65535
        with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
            assert _ask(sock, encode_request(Command.GET_JOINTS), 26)[:2] == b"\x00\x01"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
    finally:
        proc.kill()
    assert proc.returncode == 143 and "Traceback" not in err, err


class _FaultyArm(KinematicArm):
    """A backend with a bug in its linear moves (the `ArmBackend` a MuJoCo scene plugs in
    could have one): the server must survive it."""

    def move_linear(self, tool2world, tool2flange, linear_speed_m_s, angular_speed_rad_s) -> float:
        return 1 / 0


def test_a_fault_the_ranges_miss_is_answered_error_logged_in_one_line_and_the_server_serves_on(caplog):
    with (
        VirtualRobotServer("127.0.0.1", 0, _FaultyArm()) as server,
        socket.create_connection(("127.0.0.1", server.port), timeout=5) as sock,
    ):
        here = _ask(sock, encode_request(Command.GET_POSE), 30)[2:]
        assert _ask(sock, struct.pack(">H", int(Command.MOVE_LINEAR)) + here) == b"\x00\x00"
        assert _ask(sock, encode_request(Command.GET_JOINTS), 26)[:2] == b"\x00\x01"
    assert server.internal_faults == 1
    assert server.last_error == "internal fault on MOVE_LINEAR: ZeroDivisionError: division by zero"
    faults = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
    assert faults == [f"virtual robot {server.address}: {server.last_error} (answered ERROR, still serving)"]
