"""A virtual IRB120 controller that speaks the lab's RAPID server protocol over TCP.

Any client of the real robot — the lab's `cri` ABB client, or `hardware.robot.RobotDriver`
— can connect to it as if it were the controller on port 5000 (protocol table in
`hardware.protocol`). It keeps the controller state (tool, work object, speeds, zone,
joints) and moves a simulated arm through a pluggable backend:

* `KinematicArm` (default): joint angles only. Linear moves are solved with the IK of
  `twin.world.kinematics` along the straight path (unreachable poses, joint-limit violations and
  configuration flips near singularities get the protocol's ERROR reply and the arm stays
  where it was); a simulated clock advances by each move's duration at the set speeds.
* anything implementing `ArmBackend` (e.g. the full MuJoCo scene) — four methods in SI.

One client at a time, like the RAPID server; a client that disconnects (or sends CLOSE)
frees the server for the next, and so does one that stalls mid-command for
`stall_timeout_s` or sends nothing for `idle_timeout_s` (dropped with the reason logged).
Requests are decoded incrementally (`hardware.protocol.RequestDecoder`): any bytes, split
anywhere, give requests or ERROR replies, never an exception. Every number of a request is
checked against `FIELD_RANGES` before any arithmetic (NaN, ±inf and float32 extremes
included): a value outside gets the ERROR status and changes nothing. What it keeps is bounded:
the command and move logs hold the last `log_limit` entries, and each client's refusals
are logged up to `MAX_LOGGED_REFUSALS`, then counted. Loopback only unless
`allow_remote=True`.

Differences from the real controller, on purpose: moves are checked *before* moving
(the robot would stop mid-path), MOVE_CIRCULAR is answered with ERROR (not simulated),
replies come at once unless `realtime_factor` > 0 (then a move takes
`realtime_factor` × its simulated duration of wall time).
"""

from __future__ import annotations

import contextlib
import ipaddress
import logging
import math
import socket
import threading
import time
from collections import Counter, deque
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from hardware.protocol import (
    DEFAULT_PORT,
    MIN_ANGULAR_SPEED_DEG_S,
    MIN_LINEAR_SPEED_MM_S,
    Command,
    DecodeError,
    ProtocolError,
    RequestDecoder,
    Zone,
    encode_reply,
    matrix_to_wire,
    wire_to_matrix,
)
from twin.core.errors import UnreachablePoseError, UserError
from twin.core.poses import angle_between_rotations_deg, invert_transform, make_transform
from twin.world.kinematics import Irb120Kinematics

log = logging.getLogger(__name__)

#: IRB120 maximum joint speeds, axes 1–6 (deg/s), from the ABB product specification
IRB120_MAX_JOINT_SPEED_DEG_S = np.array([250.0, 250.0, 250.0, 320.0, 320.0, 420.0])

_POLL_S = 0.05  # how often blocking socket calls look at the stop flag
#: refusals logged per client; further ones are only counted (a client sending garbage
#: cannot fill the log)
MAX_LOGGED_REFUSALS = 20

#: how far (mm, each coordinate) a work object or a move target may be from its frame's
#: origin: 8.6× the IRB120's 580 mm reach, so no reachable pose is refused by it
POSITION_LIMIT_MM = 5000.0
#: how far (mm, each coordinate) the tool centre point may be from the flange
TOOL_LIMIT_MM = 1000.0
#: joint targets (deg); the arm's own joint limits (axis 6: ±400°) are checked after it
JOINT_LIMIT_DEG = 720.0
#: quaternion components; the norm must then be 1 within 1e-3
QUAT_LIMIT = 1.001
#: fastest speeds accepted (mm/s, deg/s): above the IRB120's 6.2 m/s TCP and 420 deg/s axis 6
MAX_LINEAR_SPEED_MM_S = 10_000.0
MAX_ANGULAR_SPEED_DEG_S = 1000.0
#: largest fly-by zone (mm, deg)
MAX_ZONE_MM = 1000.0
MAX_ZONE_DEG = 180.0
#: the longest real time a move may take with `realtime_factor` > 0 (s, 1 year)
MAX_REALTIME_WAIT_S = 3.2e7


def _pose_ranges(prefix: str, limit_mm: float) -> tuple[tuple[str, float, float, str], ...]:
    return (
        *((f"{prefix}{c}", -limit_mm, limit_mm, "mm") for c in "xyz"),
        *((f"{prefix}q{c}", -QUAT_LIMIT, QUAT_LIMIT, "") for c in "wxyz"),
    )


#: (field, lowest, highest, unit) of each number of each request, in wire order; inclusive
FIELD_RANGES: dict[Command, tuple[tuple[str, float, float, str], ...]] = {
    Command.MOVE_JOINTS: tuple((f"joint {j}", -JOINT_LIMIT_DEG, JOINT_LIMIT_DEG, "deg") for j in range(1, 7)),
    Command.MOVE_LINEAR: _pose_ranges("", POSITION_LIMIT_MM),
    Command.MOVE_CIRCULAR: _pose_ranges("via ", POSITION_LIMIT_MM) + _pose_ranges("end ", POSITION_LIMIT_MM),
    Command.SET_TOOL: _pose_ranges("tool ", TOOL_LIMIT_MM),
    Command.SET_WORK_OBJECT: _pose_ranges("work object ", POSITION_LIMIT_MM),
    Command.SET_SPEED: (
        ("linear speed", MIN_LINEAR_SPEED_MM_S, MAX_LINEAR_SPEED_MM_S, "mm/s"),
        ("angular speed", MIN_ANGULAR_SPEED_DEG_S, MAX_ANGULAR_SPEED_DEG_S, "deg/s"),
    ),
    Command.SET_ZONE: (
        ("point_motion", 0, 1, ""),
        ("pzone_tcp", 0.0, MAX_ZONE_MM, "mm"),
        ("pzone_ori", 0.0, MAX_ZONE_MM, "mm"),
        ("zone_ori", 0.0, MAX_ZONE_DEG, "deg"),
    ),
}


#: FIELD_RANGES' bounds as they arrive in float32 (0.01 arrives as 0.0099999998): a bound
#: sent by a client is inside
_WIRE_BOUNDS = {
    command: tuple((float(np.float32(lo)), float(np.float32(hi))) for _, lo, hi, _ in ranges)
    for command, ranges in FIELD_RANGES.items()
}


def check_request_ranges(command: Command, args: tuple[float, ...]) -> None:
    """ProtocolError naming the first field of a request outside `FIELD_RANGES` (NaN
    included); nothing is computed from the values before this passes."""
    ranges, bounds = FIELD_RANGES.get(command, ()), _WIRE_BOUNDS.get(command, ())
    if len(args) != len(ranges):
        raise ProtocolError(f"{command.name} takes {len(ranges)} values, got {len(args)}")
    for (name, lo, hi, unit), (lo32, hi32), value in zip(ranges, bounds, args):
        if not lo32 <= value <= hi32:  # float32 needs 9 digits to show a value just beyond
            raise ProtocolError(f"{name} = {value:.9g}{' ' + unit if unit else ''} is outside [{lo:g}, {hi:g}]")


class ArmBackend(Protocol):
    """What the virtual controller needs from a simulated arm. SI units: m, rad, s.

    Moves return their duration (s) and raise `UnreachablePoseError` when refused, in
    which case the arm must not have moved.
    """

    def move_linear(
        self, tool2world: np.ndarray, tool2flange: np.ndarray, linear_speed_m_s: float, angular_speed_rad_s: float
    ) -> float: ...

    def move_joints(
        self, q_rad: np.ndarray, tool2flange: np.ndarray, linear_speed_m_s: float, angular_speed_rad_s: float
    ) -> float: ...

    def get_joints(self) -> np.ndarray: ...

    def get_pose(self, tool2flange: np.ndarray) -> np.ndarray: ...


class KinematicArm:
    """Kinematics-only IRB120: joint state, IK along straight paths, a simulated clock.

    `time_s` is the simulated time (s) that has passed in moves. Not thread-safe; the
    server calls it from one thread.
    """

    def __init__(
        self,
        kinematics=None,
        q0_rad: np.ndarray | None = None,
        path_step_m: float = 0.005,
        path_step_rad: float = math.radians(5.0),
        max_joint_step_rad: float = math.radians(30.0),
    ) -> None:
        if kinematics is None:
            kinematics = Irb120Kinematics()
        self.kinematics = kinematics
        self.q = np.array(kinematics.home_q if q0_rad is None else q0_rad, dtype=float)
        self._check_limits(self.q)
        self.path_step_m = path_step_m
        self.path_step_rad = path_step_rad
        self.max_joint_step_rad = max_joint_step_rad
        self.time_s = 0.0

    def get_joints(self) -> np.ndarray:
        """(6,) joint angles (rad)."""
        return self.q.copy()

    def get_pose(self, tool2flange: np.ndarray) -> np.ndarray:
        """tool2world (4×4, m) at the current joints."""
        return self.kinematics.forward(self.q) @ tool2flange

    def move_linear(
        self, tool2world: np.ndarray, tool2flange: np.ndarray, linear_speed_m_s: float, angular_speed_rad_s: float
    ) -> float:
        start = self.get_pose(tool2flange)
        distance = float(np.linalg.norm(tool2world[:3, 3] - start[:3, 3]))
        angle = math.radians(angle_between_rotations_deg(start[:3, :3], tool2world[:3, :3]))
        n = max(1, min(400, math.ceil(max(distance / self.path_step_m, angle / self.path_step_rad))))
        slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([start[:3, :3], tool2world[:3, :3]])))
        q = self.q
        joint_time = 0.0
        for i in range(1, n + 1):
            s = i / n
            target = (
                tool2world
                if i == n
                else make_transform(slerp([s]).as_matrix()[0], (1 - s) * start[:3, 3] + s * tool2world[:3, 3])
            )
            q_next = self.kinematics.inverse(target, tool2flange, q)
            step = np.abs(q_next - q)
            if float(np.max(step)) > self.max_joint_step_rad:
                raise UnreachablePoseError(
                    f"linear move passes a singularity or changes configuration near "
                    f"{np.round(target[:3, 3] * 1e3, 1).tolist()} mm (joint {int(np.argmax(step)) + 1} "
                    f"would jump {math.degrees(float(np.max(step))):.0f}°)"
                )
            joint_time += float(np.max(np.degrees(step) / IRB120_MAX_JOINT_SPEED_DEG_S))
            q = q_next
        duration = max(distance / linear_speed_m_s, angle / angular_speed_rad_s, joint_time)
        self.q = q
        self.time_s += duration
        return duration

    def move_joints(
        self, q_rad: np.ndarray, tool2flange: np.ndarray, linear_speed_m_s: float, angular_speed_rad_s: float
    ) -> float:
        q = np.asarray(q_rad, dtype=float)
        self._check_limits(q)
        start, end = self.get_pose(tool2flange), self.kinematics.forward(q) @ tool2flange
        distance = float(np.linalg.norm(end[:3, 3] - start[:3, 3]))
        angle = math.radians(angle_between_rotations_deg(start[:3, :3], end[:3, :3]))
        joint_time = float(np.max(np.degrees(np.abs(q - self.q)) / IRB120_MAX_JOINT_SPEED_DEG_S))
        duration = max(distance / linear_speed_m_s, angle / angular_speed_rad_s, joint_time)
        self.q = q.copy()
        self.time_s += duration
        return duration

    def _check_limits(self, q: np.ndarray) -> None:
        limits = self.kinematics.joint_limits_rad
        if q.shape != (6,) or not np.all(np.isfinite(q)):
            raise UnreachablePoseError(f"joint target {q.tolist()} is not 6 finite angles")
        bad = [
            f"joint {j + 1} = {math.degrees(q[j]):.2f}°, limit {math.degrees(limits[j, 0]):.0f}…{math.degrees(limits[j, 1]):.0f}°"
            for j in range(6)
            if not limits[j, 0] - 1e-9 <= q[j] <= limits[j, 1] + 1e-9
        ]
        if bad:
            raise UnreachablePoseError("joint target outside the limits: " + "; ".join(bad))


@dataclass(frozen=True)
class CommandRecord:
    """One request the server received (wire units), in arrival order."""

    time: float  # time.monotonic() at arrival (s)
    command: Command
    args: tuple[float, ...]


@dataclass(frozen=True)
class MoveRecord:
    """One move request as the controller received it, before executing it: where the
    TCP was (`start`) and where it was sent (`end`), both (x, y, z mm, qw, qx, qy, qz) in
    the work object; the speeds in force (mm/s, deg/s); whether it was carried out. The
    controller moves the TCP on the straight line between them, slerping the orientation."""

    start: tuple[float, ...]
    end: tuple[float, ...]
    linear_speed_mm_s: float
    angular_speed_deg_s: float
    command: Command
    accepted: bool


class VirtualRobotServer:
    """TCP server answering the RAPID server protocol with a simulated arm.

    | state            | units (as on the wire)                                   |
    |------------------|----------------------------------------------------------|
    | tool             | (x, y, z mm, qw, qx, qy, qz) TCP in the flange frame     |
    | work_object      | (x, y, z mm, qw, qx, qy, qz) work frame in the base frame |
    | speed            | (linear mm/s, angular deg/s); controller default (100, 50) |
    | zone             | `hardware.protocol.Zone`                                 |
    | command_log      | the last `log_limit` requests received, `CommandRecord`s |
    | moves            | the last `log_limit` moves received, `MoveRecord`s        |
    | counts           | how many requests of each command arrived (all of them)  |

    Use as a context manager (starts a background thread, shuts down on exit), or call
    `start()`/`shutdown()`, or `serve_forever()` in the calling thread. The socket is
    bound in the constructor: with port 0 the OS picks a free port (`self.port`).
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = DEFAULT_PORT,
        backend: ArmBackend | None = None,
        *,
        allow_remote: bool = False,
        realtime_factor: float = 0.0,
        info: str = "virtual IRB120, tactip-twin, RAPID server protocol",
        idle_timeout_s: float = 300.0,
        stall_timeout_s: float = 5.0,
        log_limit: int | None = 10_000,
    ) -> None:
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise UserError(f"virtual robot: port = {port!r} is not a TCP port (0-65535; 0 = any free one)")
        if log_limit is not None and (isinstance(log_limit, bool) or not isinstance(log_limit, int) or log_limit < 0):
            raise UserError(f"virtual robot: log limit = {log_limit!r} must be a count ≥ 0 (commands and moves kept)")
        if not (math.isfinite(realtime_factor) and 0 <= realtime_factor <= 1000):
            raise UserError(
                f"virtual robot: realtime factor = {realtime_factor!r} must be in [0, 1000] "
                "(0 = instant moves, 1 = real durations)"
            )
        if not allow_remote and not _is_loopback(host):
            raise UserError(
                f"virtual robot: host {host!r} is not a loopback address; pass allow_remote=True to serve on it"
            )
        self.backend: ArmBackend = backend if backend is not None else KinematicArm()
        self.realtime_factor = float(realtime_factor)
        self.info_text = info
        self.tool: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
        self.work_object: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
        self.speed: tuple[float, float] = (100.0, 50.0)
        self.zone = Zone(True, 0.3, 0.3, 0.03)
        for name, value in (("idle_timeout_s", idle_timeout_s), ("stall_timeout_s", stall_timeout_s)):
            if not (math.isfinite(value) and value > 0):
                raise UserError(f"virtual robot: {name} must be a positive number of seconds, got {value!r}")
        self.idle_timeout_s = float(idle_timeout_s)
        self.stall_timeout_s = float(stall_timeout_s)
        self.command_log: deque[CommandRecord] = deque(maxlen=log_limit)
        self.moves: deque[MoveRecord] = deque(maxlen=log_limit)
        self.counts: Counter[Command] = Counter()
        self.dropped: deque[str] = deque(maxlen=100)  # why the last clients were dropped
        self.last_error: str | None = None
        self.internal_faults = 0  # requests whose handling raised unexpectedly (answered ERROR)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._client: socket.socket | None = None
        self._lock = threading.Lock()
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind((host, port))
        except OSError as err:
            self._listener.close()
            raise UserError(f"virtual robot: cannot listen on {host}:{port}: {err}") from None
        self._listener.listen(8)  # clients wait in the queue (served one at a time) instead of SYN retries
        self._listener.settimeout(_POLL_S)
        self.host, self.port = self._listener.getsockname()[:2]

    @property
    def address(self) -> str:
        return f"{self.host}:{self.port}"

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> VirtualRobotServer:
        """Serve in a background (daemon) thread; returns self."""
        if self._thread is None:
            self._thread = threading.Thread(target=self.serve_forever, name=f"virtual-robot-{self.port}", daemon=True)
            self._thread.start()
        return self

    def serve_forever(self) -> None:
        """Accept and serve clients one at a time until `shutdown()`."""
        try:
            while not self._stop.is_set():
                try:
                    conn, peer = self._listener.accept()
                except TimeoutError:
                    continue
                except OSError:
                    break  # listener closed by shutdown()
                log.info("virtual robot %s: client %s connected", self.address, peer)
                with conn:
                    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    self._client = conn
                    try:
                        self._serve_client(conn, peer)
                    except (ConnectionError, OSError) as err:
                        log.info("virtual robot %s: client %s gone: %s", self.address, peer, err)
                    except Exception as err:  # a fault of ours: drop this client, serve the next
                        self._internal_fault(f"serving client {peer}", err, "dropped it, still serving")
                    finally:
                        self._client = None
        finally:
            with contextlib.suppress(OSError):
                self._listener.close()

    def shutdown(self, timeout_s: float = 2.0) -> None:
        """Stop serving, drop the client connection, close the port. Safe to call twice."""
        self._stop.set()
        client = self._client
        if client is not None:
            with contextlib.suppress(OSError):
                client.shutdown(socket.SHUT_RDWR)
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout_s)
        with contextlib.suppress(OSError):
            self._listener.close()

    def __enter__(self) -> VirtualRobotServer:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.shutdown()

    def count(self, command: Command) -> int:
        """How many `command` requests have arrived so far."""
        with self._lock:
            return self.counts[command]

    # ------------------------------------------------------------------ one client
    def _serve_client(self, conn: socket.socket, peer) -> None:
        decoder = RequestDecoder()
        refusals = 0
        last_byte = time.monotonic()
        conn.settimeout(_POLL_S)
        try:
            while not self._stop.is_set():
                try:
                    chunk = conn.recv(4096)
                except TimeoutError:
                    quiet = time.monotonic() - last_byte
                    if decoder.pending and quiet > self.stall_timeout_s:
                        return self._drop(
                            peer,
                            f"stalled mid-command ({decoder.pending} bytes of a request, "
                            f"nothing more for {quiet:.1f} s > stall timeout {self.stall_timeout_s:g} s)",
                        )
                    if not decoder.pending and quiet > self.idle_timeout_s:
                        return self._drop(peer, f"idle for {quiet:.1f} s > idle timeout {self.idle_timeout_s:g} s")
                    continue
                if not chunk:
                    return  # client closed
                last_byte = time.monotonic()
                for item in decoder.feed(chunk):
                    if isinstance(item, DecodeError):
                        refusals += 1
                        self._refused(refusals, f"{item.message} ({item.discarded} bytes dropped)")
                        self._drain(conn)  # the rest of a malformed request: no framing to resync on
                        decoder.reset()
                        conn.sendall(encode_reply(Command.SET_TOOL, ok=False))  # bare ERROR status
                        break
                    with self._lock:
                        self.command_log.append(CommandRecord(time.monotonic(), item.command, item.args))
                        self.counts[item.command] += 1
                    if item.command is Command.CLOSE:
                        return
                    reply, duration, error = self._execute(item.command, item.args)
                    if error:
                        refusals += 1
                        self._refused(refusals, error)
                    wait_s = min(duration * self.realtime_factor, MAX_REALTIME_WAIT_S)
                    if wait_s > 0 and self._stop.wait(wait_s):
                        return  # shut down mid-move: the client gets no reply
                    conn.sendall(reply)
        finally:
            if refusals > MAX_LOGGED_REFUSALS:
                log.warning(
                    "virtual robot %s: client %s: %d refusals in all (%d not logged)",
                    self.address,
                    peer,
                    refusals,
                    refusals - MAX_LOGGED_REFUSALS,
                )

    def _drop(self, peer, reason: str) -> None:
        self.dropped.append(f"{peer}: {reason}")
        log.warning("virtual robot %s: dropped client %s: %s", self.address, peer, reason)

    def _internal_fault(self, doing: str, err: Exception, outcome: str) -> None:
        self.internal_faults += 1
        self.last_error = f"internal fault {doing}: {type(err).__name__}: {err}"
        log.error("virtual robot %s: %s (%s)", self.address, self.last_error, outcome)
        log.debug("virtual robot %s: internal fault", self.address, exc_info=err)

    def _refused(self, n: int, error: str) -> None:
        self.last_error = error
        if n <= MAX_LOGGED_REFUSALS:
            log.warning(
                "virtual robot %s: refused %s%s",
                self.address,
                error,
                " (further refusals from this client are counted, not logged)" if n == MAX_LOGGED_REFUSALS else "",
            )

    def _execute(self, command: Command, args: tuple[float, ...]) -> tuple[bytes, float, str | None]:
        """(reply bytes, simulated duration s, why it was refused or None) of one request."""
        try:
            check_request_ranges(command, args)
            if command is Command.GET_INFO:
                return encode_reply(command, True, self.info_text), 0.0, None
            if command is Command.SET_TOOL:
                self._check_frame(args)
                self.tool = tuple(args)
            elif command is Command.SET_WORK_OBJECT:
                self._check_frame(args)
                self.work_object = tuple(args)
            elif command is Command.SET_SPEED:
                self.speed = (float(args[0]), float(args[1]))
            elif command is Command.SET_ZONE:
                self.zone = Zone(bool(args[0]), *(float(a) for a in args[1:]))
            elif command is Command.GET_JOINTS:
                return encode_reply(command, True, tuple(np.degrees(self.backend.get_joints()))), 0.0, None
            elif command is Command.GET_POSE:
                return encode_reply(command, True, self._tool_in_work()), 0.0, None
            elif command in (Command.MOVE_LINEAR, Command.MOVE_JOINTS):
                return encode_reply(command, True), self._move(command, args), None
            elif command is Command.MOVE_CIRCULAR:
                raise ProtocolError("MOVE_CIRCULAR is not simulated by the virtual controller")
            return encode_reply(command, True), 0.0, None
        except (UnreachablePoseError, ProtocolError) as err:
            return encode_reply(command, False), 0.0, f"{command.name}: {err}"
        except Exception as err:  # a fault of ours the range checks missed: refuse, keep serving
            self._internal_fault(f"on {command.name}", err, "answered ERROR, still serving")
            return encode_reply(command, False), 0.0, None

    def _tool_in_work(self) -> tuple[float, ...]:
        """The TCP's pose in the work object now (wire units)."""
        return matrix_to_wire(invert_transform(self._work2world) @ self.backend.get_pose(self._tool2flange))

    def _move(self, command: Command, args: tuple[float, ...]) -> float:
        """Record the move (`moves`), then carry it out; its simulated duration (s)."""
        start = self._tool_in_work()
        record = dict(start=start, linear_speed_mm_s=self.speed[0], angular_speed_deg_s=self.speed[1], command=command)
        try:
            if command is Command.MOVE_LINEAR:
                end = tuple(float(a) for a in args)
                self._check_frame(args)
                duration = self.backend.move_linear(
                    self._work2world @ wire_to_matrix(args), self._tool2flange, *self._speeds_si
                )
            else:
                end = ()
                duration = self.backend.move_joints(np.radians(args), self._tool2flange, *self._speeds_si)
                end = self._tool_in_work()
        except BaseException:
            with self._lock:
                self.moves.append(MoveRecord(end=end, accepted=False, **record))
            raise
        with self._lock:
            self.moves.append(MoveRecord(end=end, accepted=True, **record))
        return duration

    @staticmethod
    def _check_frame(args: tuple[float, ...]) -> None:
        q = np.asarray(args[3:], dtype=float)
        if not np.all(np.isfinite(args)) or abs(float(np.linalg.norm(q)) - 1.0) > 1e-3:
            raise ProtocolError(f"pose {tuple(round(a, 6) for a in args)} has no finite unit quaternion")

    @property
    def _tool2flange(self) -> np.ndarray:
        return wire_to_matrix(self.tool)

    @property
    def _work2world(self) -> np.ndarray:
        return wire_to_matrix(self.work_object)

    @property
    def _speeds_si(self) -> tuple[float, float]:
        return self.speed[0] * 1e-3, math.radians(self.speed[1])

    @staticmethod
    def _drain(conn: socket.socket) -> None:
        """Discard what is left of a malformed request."""
        conn.settimeout(0.02)
        with contextlib.suppress(TimeoutError, socket.timeout, OSError):
            while conn.recv(4096):
                pass


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(socket.gethostbyname(host)).is_loopback
    except (OSError, ValueError):
        return False


def serve_robot(
    host: str = "127.0.0.1",
    port: int = DEFAULT_PORT,
    *,
    realtime_factor: float = 0.0,
    backend: ArmBackend | None = None,
    idle_timeout_s: float = 300.0,
    stall_timeout_s: float = 5.0,
    log_limit: int | None = 10_000,
) -> None:
    """Run the virtual controller in the foreground until Ctrl-C or SIGTERM (for the CLI)."""
    server = VirtualRobotServer(
        host,
        port,
        backend,
        realtime_factor=realtime_factor,
        idle_timeout_s=idle_timeout_s,
        stall_timeout_s=stall_timeout_s,
        log_limit=log_limit,
    )
    print(
        f"virtual IRB120 controller (RAPID server protocol) listening on {server.address}; Ctrl-C stops it", flush=True
    )
    try:
        server.serve_forever()  # Ctrl-C and SIGTERM reach the CLI, which exits 130 or 143
    finally:
        server.shutdown()
