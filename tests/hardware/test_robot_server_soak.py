"""The virtual controller survives bad clients: its request decoder never raises on any
bytes split anywhere (hypothesis); a client that stalls mid-command or idles is dropped
and the next one served; a bounded loopback soak (10,000 commands, 200 connect/drop
cycles, random bytes) against `twin serve-robot` in its own process leaves it answering
correctly with flat memory and no leaked file descriptors; a second one sends 10,000
well-formed requests whose numbers are float32 extremes (±3.4e38, denormals, ±0, huge,
tiny, NaN and ±inf bit patterns) over 100 connections: the server stays up, accepts no
move with a number outside its ranges, never leaves its joint limits, and its memory
stays flat. SIGTERM ends it with exit code 143 (README, exit codes)."""

from __future__ import annotations

import contextlib
import os
import re
import socket
import struct
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hardware.protocol import (
    MAX_REQUEST_SIZE,
    REQUEST_LAYOUT,
    Command,
    DecodeError,
    Request,
    RequestDecoder,
    encode_request,
    pose_to_wire,
)
from hardware.virtual_controller import FIELD_RANGES, KinematicArm, VirtualRobotServer
from tests.hardware.loopback import free_port
from twin.core.poses import Pose
from twin.world.kinematics import Irb120Kinematics

N_COMMANDS = 10_000
N_CYCLES = 200
N_GARBAGE = 100
LOG_LIMIT = 500  # the server's command and move logs (entries), full after the warm-up
RSS_GROWTH_LIMIT_KB = 1024  # after warm-up


# ---------------------------------------------------------------------------- decoder fuzz
def _splits(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts})
    return [data[a:b] for a, b in zip([0, *points], [*points, len(data)])]


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=600), st.lists(st.integers(0, 600), max_size=20))
def test_decoder_never_raises_on_arbitrary_bytes(data: bytes, cuts: list[int]) -> None:
    decoder = RequestDecoder()
    for piece in _splits(data, cuts):
        for item in decoder.feed(piece):
            assert isinstance(item, (Request, DecodeError))
        assert decoder.pending < MAX_REQUEST_SIZE


_VALID = st.sampled_from([c for c in Command]).flatmap(
    lambda c: st.tuples(
        st.just(c),
        st.lists(
            st.floats(width=32, allow_nan=False),
            min_size=REQUEST_LAYOUT[c].size // 4,
            max_size=REQUEST_LAYOUT[c].size // 4,
        ),
    )
)


@settings(max_examples=200, deadline=None)
@given(st.lists(_VALID, max_size=12), st.lists(st.integers(0, 800), max_size=30))
def test_decoder_gives_the_same_requests_however_the_stream_is_split(requests, cuts) -> None:
    stream = b"".join(encode_request(c, *((1.0, *args) if c is Command.SET_ZONE else args)) for c, args in requests)
    decoded = _decode_split(stream, cuts)
    assert [r.command for r in decoded] == [c for c, _ in requests]
    assert all(isinstance(r, Request) for r in decoded)


def _decode_split(stream: bytes, cuts: list[int]) -> list:
    decoder = RequestDecoder()
    out = [item for piece in _splits(stream, cuts) for item in decoder.feed(piece)]
    assert decoder.pending == 0
    return out


# ---------------------------------------------------------------------------- timeouts
def _ask_joints(port: int, timeout_s: float = 5.0) -> tuple[float, ...]:
    with socket.create_connection(("127.0.0.1", port), timeout=timeout_s) as s:
        s.sendall(encode_request(Command.GET_JOINTS))
        reply = _recv_exactly(s, 2 + 24)
    assert reply[:2] == b"\x00\x01"
    return struct.unpack(">6f", reply[2:])


def _recv_exactly(s: socket.socket, n: int) -> bytes:
    buf = b""
    while len(buf) < n:
        chunk = s.recv(n - len(buf))
        if not chunk:
            raise ConnectionError(f"closed after {len(buf)} of {n} bytes")
        buf += chunk
    return buf


@pytest.mark.parametrize("how", ["stall", "idle"])
def test_a_stalled_or_idle_client_is_dropped_and_the_next_served(how: str, caplog) -> None:
    with VirtualRobotServer("127.0.0.1", 0, KinematicArm(), stall_timeout_s=0.3, idle_timeout_s=0.6) as server:
        hog = socket.create_connection(("127.0.0.1", server.port), timeout=5.0)
        if how == "stall":
            hog.sendall(encode_request(Command.MOVE_LINEAR, *range(7))[:9])  # half a command
        t0 = time.monotonic()
        assert len(_ask_joints(server.port)) == 6  # served once the hog is dropped
        waited = time.monotonic() - t0
        assert hog.recv(16) == b""  # the hog's connection was closed
        hog.close()
    limit = 0.3 if how == "stall" else 0.6
    assert limit <= waited < limit + 2.0
    reason = "stalled mid-command (9 bytes" if how == "stall" else "idle for"
    assert any(reason in d for d in server.dropped), server.dropped
    assert any("dropped client" in r.getMessage() for r in caplog.records)


# ---------------------------------------------------------------------------- soak
def _rss_kb(pid: int) -> int:
    text = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(r"VmRSS:\s+(\d+) kB", text).group(1))


def _fds(pid: int) -> int:
    return len(os.listdir(f"/proc/{pid}/fd"))


def _cpu_s(pid: int) -> float:
    """CPU time (user + system, s) the process has used so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.fixture
def served(tmp_path):
    """`twin serve-robot` in its own process: (process, port); its log (stderr) goes to a
    file, which a pipe nobody reads during the soak could not take."""
    log_path = tmp_path / "serve-robot.log"
    with log_path.open("w") as log_file:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "twin.tools.cli",
                "serve-robot",
                "--port",
                str(free_port()),
                "--stall-timeout",
                "0.2",
                "--idle-timeout",
                "1",
                "--log-limit",
                str(LOG_LIMIT),
            ],
            stdout=subprocess.PIPE,
            stderr=log_file,
            text=True,
        )
    try:
        line = proc.stdout.readline()
        port = int(re.search(r"listening on [\d.]+:(\d+)", line).group(1))
        yield proc, port
    finally:
        alive = proc.poll() is None
        proc.terminate()
        proc.communicate(timeout=20)
    err = log_path.read_text()
    assert alive, f"the server died: {err[-2000:]}"
    assert proc.returncode == 143 and "Traceback" not in err, err[-2000:]  # README: SIGTERM exits 143
    assert "internal fault" not in err, "every bad number is caught by a range check, not by the last resort"
    assert len(err.splitlines()) < 25 * 150, "the server's log is bounded (20 refusals per client, then a count)"


def _commands(sock: socket.socket, n: int, rng: np.random.Generator) -> None:
    """n commands on one connection, each reply checked: joints, poses, speeds, small moves."""
    for i in range(n):
        kind = i % 5
        if kind == 0:
            sock.sendall(encode_request(Command.GET_JOINTS))
            reply = _recv_exactly(sock, 26)
            assert reply[:2] == b"\x00\x01" and np.all(np.isfinite(struct.unpack(">6f", reply[2:])))
        elif kind == 1:
            sock.sendall(encode_request(Command.SET_SPEED, float(rng.uniform(5, 100)), 20.0))
            assert _recv_exactly(sock, 2) == b"\x00\x01"
        elif kind == 2:
            target = Pose(*rng.uniform(-5, 5, 2), float(rng.uniform(-10, -5)), 0, 0, float(rng.uniform(-5, 5)))
            sock.sendall(encode_request(Command.MOVE_LINEAR, *pose_to_wire(target)))
            assert _recv_exactly(sock, 2) == b"\x00\x01"
            sock.sendall(encode_request(Command.GET_POSE))
            reply = _recv_exactly(sock, 30)
            assert reply[:2] == b"\x00\x01"
            xyz = struct.unpack(">7f", reply[2:])[:3]
            assert np.allclose(xyz, target.as_array()[:3], atol=1e-3), (xyz, target)
        elif kind == 3:
            sock.sendall(encode_request(Command.SET_ZONE, 1, 0, 0, 0))
            assert _recv_exactly(sock, 2) == b"\x00\x01"
        # kind 4: the GET_POSE above counts as the fifth command


def _setup(sock: socket.socket) -> None:
    for cmd, args in (
        (Command.SET_TOOL, pose_to_wire(Pose(0, 0, 101, 0, 0, 0))),
        (Command.SET_WORK_OBJECT, pose_to_wire(Pose(400, 0, 50, 180, 0, 0))),
    ):
        sock.sendall(encode_request(cmd, *args))
        assert _recv_exactly(sock, 2) == b"\x00\x01"
    sock.sendall(encode_request(Command.MOVE_LINEAR, *pose_to_wire(Pose(0, 0, -10, 0, 0, 0))))
    assert _recv_exactly(sock, 2) == b"\x00\x01"


def test_soak_commands_drops_and_garbage(served, capsys) -> None:
    proc, port = served
    rng = np.random.default_rng(17)
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        _setup(sock)
        _commands(sock, 1000, rng)  # warm-up: imports, caches, the logs' first entries
    time.sleep(0.3)  # the server has seen the close
    rss0, fds0 = _rss_kb(proc.pid), _fds(proc.pid)
    t0 = time.perf_counter()

    n_sent = 1000
    for cycle in range(N_CYCLES):  # connect/drop cycles, some mid-command, some abortive
        s = socket.create_connection(("127.0.0.1", port), timeout=10)
        if cycle % 4 == 1:
            s.sendall(encode_request(Command.MOVE_LINEAR, *range(7))[: int(rng.integers(1, 30))])
        elif cycle % 4 == 2:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # RST on close
            s.sendall(encode_request(Command.GET_JOINTS))
        elif cycle % 4 == 3:
            _setup(s)
            _commands(s, 40, rng)
            n_sent += 43
        s.close()
    t1 = time.perf_counter()
    for _ in range(N_GARBAGE):  # random bytes: answered with ERROR or dropped, never a crash
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            s.sendall(rng.bytes(int(rng.integers(1, 300))))
            s.shutdown(socket.SHUT_WR)  # done sending: the server sees the end and lets go
            replies = b""
            with contextlib.suppress(ConnectionResetError):
                while chunk := s.recv(4096):
                    replies += chunk
            assert len(replies) % 2 == 0 and not replies.strip(b"\x00\x01")[:0]
    t2 = time.perf_counter()
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        _setup(sock)
        _commands(sock, N_COMMANDS - n_sent, rng)
    n_sent = N_COMMANDS
    t3 = time.perf_counter()

    time.sleep(0.3)
    rss1, fds1 = _rss_kb(proc.pid), _fds(proc.pid)
    assert len(_ask_joints(port)) == 6  # still answering correctly
    with capsys.disabled():
        print(
            f"\nserve-robot soak: {n_sent} commands checked, {N_CYCLES} connect/drop cycles, {N_GARBAGE} random-byte "
            f"clients; RSS {rss0} -> {rss1} kB ({rss1 - rss0:+d} kB), fds {fds0} -> {fds1}; "
            f"{t1 - t0:.1f} s cycles, {t2 - t1:.1f} s garbage, {t3 - t2:.1f} s commands"
        )
    assert fds1 == fds0
    assert rss1 - rss0 < RSS_GROWTH_LIMIT_KB


# ---------------------------------------------------------------------------- extreme numbers
N_EXTREME_COMMANDS = 10_000
N_EXTREME_CONNECTIONS = 100
N_EXTREME_WARMUP = 1_000  # on 10 more connections, before memory is measured
#: float32 bit patterns sent in place of numbers: ±max, ±smallest and largest denormals,
#: ±smallest normal, ±0, ±inf, quiet and signalling NaNs (with payloads), huge, tiny
EXTREME_WORDS = [
    bytes.fromhex(h)
    for h in (
        "7f7fffff",
        "ff7fffff",
        "00000001",
        "80000001",
        "007fffff",
        "807fffff",
        "00800000",
        "80800000",
        "00000000",
        "80000000",
        "7f800000",
        "ff800000",
        "7fc00000",
        "ffc00000",
        "7f800001",
        "7fbfffff",
        "ffffffff",
        "7fc0dead",
    )
] + [struct.pack(">f", v) for v in (1e30, -1e30, 1e20, -1e20, 1e-30, -1e-30, 1e-20, -1e-20)]
#: request mix: moves most, every command with numbers, the two readings
EXTREME_MIX = {
    Command.MOVE_LINEAR: 0.2,
    Command.MOVE_JOINTS: 0.1,
    Command.MOVE_CIRCULAR: 0.05,
    Command.SET_TOOL: 0.12,
    Command.SET_WORK_OBJECT: 0.12,
    Command.SET_SPEED: 0.13,
    Command.SET_ZONE: 0.12,
    Command.GET_POSE: 0.08,
    Command.GET_JOINTS: 0.08,
}
#: joint limits of the simulated IRB120 (deg), with what float32 rounding may add
JOINT_LIMITS_DEG = np.degrees(Irb120Kinematics().joint_limits_rad) + np.array([-1e-3, 1e-3])
#: joints (deg) with the TCP above the middle of the plausible work objects (the soak's
#: plausible joint moves stay near them, so that linear moves stay short: the simulated
#: arm solves its IK every 5 mm and 5° of a path)
_WORK_JOINTS_DEG = np.degrees(
    Irb120Kinematics().inverse(
        Pose(400, 0, 50, 180, 0, 0).to_matrix() @ Pose(0, 0, -15).to_matrix(), Pose(0, 0, 100).to_matrix()
    )
)


def _plausible_args(command: Command, rng: np.random.Generator) -> list[float]:
    """Numbers a lab client would send, so that some moves are carried out."""

    def target() -> tuple[float, ...]:
        return pose_to_wire(
            Pose(
                *rng.uniform(-20, 20, 2),
                float(rng.uniform(-25, -5)),
                *rng.uniform(-5, 5, 2),
                float(rng.uniform(-20, 20)),
            )
        )

    if command is Command.MOVE_LINEAR:
        return list(target())
    if command is Command.MOVE_CIRCULAR:
        return [*target(), *target()]
    if command is Command.MOVE_JOINTS:
        return list(_WORK_JOINTS_DEG + rng.uniform(-5, 5, 6))
    if command is Command.SET_TOOL:
        return list(pose_to_wire(Pose(0, 0, float(rng.uniform(90, 110)), 0, 0, float(rng.uniform(-5, 5)))))
    if command is Command.SET_WORK_OBJECT:
        return list(pose_to_wire(Pose(*rng.uniform([390, -10, 40], [410, 10, 60]), 180, 0, float(rng.uniform(-5, 5)))))
    if command is Command.SET_SPEED:
        return [float(10 ** rng.uniform(-3, 5)), float(10 ** rng.uniform(-3, 4))]
    if command is Command.SET_ZONE:
        return [int(rng.integers(0, 3)), *rng.uniform(0, 5, 3)]
    return []


def _extreme_request(rng: np.random.Generator) -> tuple[Command, bytes, bool]:
    """(command, bytes, whether every number is inside the server's FIELD_RANGES): a
    plausible request with none, one, some or all of its numbers replaced by extremes."""
    command = Command(rng.choice(list(EXTREME_MIX), p=list(EXTREME_MIX.values())))
    args = _plausible_args(command, rng)
    words = [struct.pack(">H" if command is Command.SET_ZONE and i == 0 else ">f", a) for i, a in enumerate(args)]
    if words and rng.random() < 0.65:
        for i in rng.choice(len(words), size=int(rng.integers(1, len(words) + 1)), replace=False):
            if command is Command.SET_ZONE and i == 0:
                words[i] = struct.pack(">H", int(rng.choice([0, 1, 2, 255, 65535])))
            else:
                words[i] = EXTREME_WORDS[int(rng.integers(len(EXTREME_WORDS)))]
    values = [struct.unpack(">H" if len(w) == 2 else ">f", w)[0] for w in words]
    in_range = all(
        float(np.float32(lo)) <= v <= float(np.float32(hi))
        for v, (_, lo, hi, _) in zip(values, FIELD_RANGES.get(command, ()))
    )
    return command, struct.pack(">H", int(command)) + b"".join(words), in_range


def _extreme_connection(port: int, n: int, rng: np.random.Generator, tally: Counter) -> None:
    """n extreme requests on one connection; each reply read and checked, each accepted
    move followed by readings (joints inside the limits, the pose where it was sent)."""
    with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:

        def ask(data: bytes, n_values: int) -> tuple[float, ...] | None:
            sock.sendall(data)
            status = _recv_exactly(sock, 2)
            assert status in (b"\x00\x00", b"\x00\x01"), status
            if status == b"\x00\x00":
                return None
            return struct.unpack(f">{n_values}f", _recv_exactly(sock, 4 * n_values)) if n_values else ()

        for _ in range(n):
            command, data, in_range = _extreme_request(rng)
            n_values = {Command.GET_POSE: 7, Command.GET_JOINTS: 6}.get(command, 0)
            reply = ask(data, n_values)
            tally["commands"] += 1
            tally["accepted" if reply is not None else "refused"] += 1
            if reply is not None and not in_range:
                tally["accepted out of range"] += 1
            if reply is not None and not np.all(np.isfinite(reply)):
                tally["non-finite readings"] += 1
            if reply is None or command not in (Command.MOVE_LINEAR, Command.MOVE_JOINTS):
                continue
            tally[f"{command.name} carried out"] += 1
            joints = np.array(ask(encode_request(Command.GET_JOINTS), 6))
            if not np.all((JOINT_LIMITS_DEG[:, 0] <= joints) & (joints <= JOINT_LIMITS_DEG[:, 1])):
                tally["moves outside the joint limits"] += 1
            if command is Command.MOVE_LINEAR:
                sent = np.array(struct.unpack(">7f", data[2:]), dtype=float)
                pose = np.array(ask(encode_request(Command.GET_POSE), 7))
                q_sent = sent[3:] / np.linalg.norm(sent[3:])
                if not (np.allclose(pose[:3], sent[:3], atol=1e-2) and abs(abs(q_sent @ pose[3:]) - 1) < 1e-5):
                    tally["moves not where they were sent"] += 1
        if rng.random() < 0.5:
            sock.sendall(encode_request(Command.CLOSE))


def test_soak_extreme_float32_numbers(served, capsys) -> None:
    proc, port = served
    rng = np.random.default_rng(41)
    warmup: Counter = Counter()
    for _ in range(10):
        _extreme_connection(port, N_EXTREME_WARMUP // 10, rng, warmup)
    time.sleep(0.3)
    rss0, fds0, cpu0 = _rss_kb(proc.pid), _fds(proc.pid), _cpu_s(proc.pid)
    t0 = time.perf_counter()
    tally: Counter = Counter()
    for _ in range(N_EXTREME_CONNECTIONS):
        _extreme_connection(port, N_EXTREME_COMMANDS // N_EXTREME_CONNECTIONS, rng, tally)
    elapsed, server_cpu_s = time.perf_counter() - t0, _cpu_s(proc.pid) - cpu0
    time.sleep(0.3)
    rss1, fds1 = _rss_kb(proc.pid), _fds(proc.pid)
    assert proc.poll() is None and len(_ask_joints(port)) == 6  # alive, answering correctly
    with capsys.disabled():
        print(
            f"\nserve-robot extreme soak: {tally['commands']} requests over {N_EXTREME_CONNECTIONS} connections in "
            f"{elapsed:.1f} s (server CPU {server_cpu_s:.1f} s): {tally['refused']} refused, {tally['accepted']} accepted "
            f"({tally['MOVE_LINEAR carried out']} linear and {tally['MOVE_JOINTS carried out']} joint moves carried out); "
            f"accepted out of range {tally['accepted out of range']}, outside the joint limits "
            f"{tally['moves outside the joint limits']}, not where sent {tally['moves not where they were sent']}; "
            f"RSS {rss0} -> {rss1} kB ({rss1 - rss0:+d} kB), fds {fds0} -> {fds1}"
        )
    assert tally["commands"] == N_EXTREME_COMMANDS
    assert tally["accepted out of range"] == 0 and tally["non-finite readings"] == 0
    assert tally["moves outside the joint limits"] == 0 and tally["moves not where they were sent"] == 0
    # not vacuous: plenty refused, and plenty of moves carried out between the extremes
    assert tally["refused"] > 3000 and tally["MOVE_LINEAR carried out"] > 100 and tally["MOVE_JOINTS carried out"] > 100
    assert fds1 == fds0
    # the logs were full after the warm-up (LOG_LIMIT < N_EXTREME_WARMUP): keeping one more
    # request record per command (a CommandRecord holds ~400 bytes with a pose's 7 numbers,
    # measured with tracemalloc) would grow RSS by ~3 MB over these 10,000 requests
    assert rss1 - rss0 < RSS_GROWTH_LIMIT_KB
