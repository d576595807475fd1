"""The virtual controller survives bad clients: its request decoder never raises on any
bytes split anywhere (hypothesis); a client that stalls mid-command or idles is dropped
and the next one served; a bounded loopback soak (10,000 commands, 200 connect/drop
cycles, random bytes) against `twin serve-robot` in its own process leaves it answering
correctly with flat memory and no leaked file descriptors."""
from __future__ import annotations

import contextlib
import os
import re
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

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
from hardware.virtual_controller import KinematicArm, VirtualRobotServer
from twin.core.poses import Pose

N_COMMANDS = 10_000
N_CYCLES = 200
N_GARBAGE = 100
LOG_LIMIT = 500             # the server's command and move logs (entries), full after the warm-up
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
    lambda c: st.tuples(st.just(c), st.lists(st.floats(width=32, allow_nan=False), min_size=REQUEST_LAYOUT[c].size // 4,
                                             max_size=REQUEST_LAYOUT[c].size // 4)))


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
            hog.sendall(encode_request(Command.MOVE_LINEAR, *range(7))[:9])   # half a command
        t0 = time.monotonic()
        assert len(_ask_joints(server.port)) == 6      # served once the hog is dropped
        waited = time.monotonic() - t0
        assert hog.recv(16) == b""                      # the hog's connection was closed
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


@pytest.fixture
def served():
    proc = subprocess.Popen([sys.executable, "-m", "twin.tools.cli", "serve-robot", "--port", "0",
                             "--stall-timeout", "0.2", "--idle-timeout", "1", "--log-limit", str(LOG_LIMIT)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    port = int(re.search(r"listening on [\d.]+:(\d+)", line).group(1))
    yield proc, port
    proc.terminate()
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 0 and "Traceback" not in err, err
    assert len(err.splitlines()) < 400, "the server's log is bounded"


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
    for cmd, args in ((Command.SET_TOOL, pose_to_wire(Pose(0, 0, 101, 0, 0, 0))),
                      (Command.SET_WORK_OBJECT, pose_to_wire(Pose(400, 0, 50, 180, 0, 0)))):
        sock.sendall(encode_request(cmd, *args))
        assert _recv_exactly(sock, 2) == b"\x00\x01"
    sock.sendall(encode_request(Command.MOVE_LINEAR, *pose_to_wire(Pose(0, 0, -10, 0, 0, 0))))
    assert _recv_exactly(sock, 2) == b"\x00\x01"


def test_soak_commands_drops_and_garbage(served, capsys) -> None:
    proc, port = served
    rng = np.random.default_rng(17)
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        _setup(sock)
        _commands(sock, 1000, rng)                  # warm-up: imports, caches, the logs' first entries
    time.sleep(0.3)                                 # the server has seen the close
    rss0, fds0 = _rss_kb(proc.pid), _fds(proc.pid)
    t0 = time.perf_counter()

    n_sent = 1000
    for cycle in range(N_CYCLES):                   # connect/drop cycles, some mid-command, some abortive
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
    for _ in range(N_GARBAGE):                      # random bytes: answered with ERROR or dropped, never a crash
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            s.sendall(rng.bytes(int(rng.integers(1, 300))))
            s.shutdown(socket.SHUT_WR)                  # done sending: the server sees the end and lets go
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
    assert len(_ask_joints(port)) == 6              # still answering correctly
    with capsys.disabled():
        print(f"\nserve-robot soak: {n_sent} commands checked, {N_CYCLES} connect/drop cycles, {N_GARBAGE} random-byte "
              f"clients; RSS {rss0} -> {rss1} kB ({rss1 - rss0:+d} kB), fds {fds0} -> {fds1}; "
              f"{t1 - t0:.1f} s cycles, {t2 - t1:.1f} s garbage, {t3 - t2:.1f} s commands")
    assert fds1 == fds0
    assert rss1 - rss0 < RSS_GROWTH_LIMIT_KB
