"""Robot driver for the ABB IRB120 running the lab's RAPID server (protocol in
`hardware.protocol`).

Two interchangeable clients carry the bytes:

* ``client="cri"`` (default): the lab's Common Robot Interface client,
  `cri.abb.abb_client.ABBClient` — the object `cri.abb.ABBController` wraps. We call the
  client directly because the controller hides SET_WORK_OBJECT and the socket. Needs
  the optional ``robot`` extra (GPL-3.0): ``uv sync --extra robot``. Its connect timeout
  is fixed at 2.5 s by cri; we set the socket timeout of every request ourselves.
* ``client="native"``: this project's own socket client (MIT), same bytes on the wire.

Units at this interface: poses are lab poses (x, y, z mm; α, β, γ deg, extrinsic XYZ) of
the tool (TCP) in the work frame; joints in deg; speeds in mm/s and deg/s. Orientations
travel as w-first quaternions computed by `twin.core.poses` (no Euler conversion inside any
client library, whose axis conventions differ between forks).

Speeds are sent with SET_SPEED (linear and angular together) — setting `robot.speed` on
a cri `SyncRobot` sends nothing to an ABB. The driver sets a fine-point zone so that a
move's reply means "the robot has stopped at the target".

Every failure of the link raises `HardwareError` naming ``host:port``: connection refused,
no reply within the timeout, connection closed. After such a failure the connection is
closed (a late reply would desynchronise the stream); make a new driver to reconnect.
"""

from __future__ import annotations

import contextlib
import io
import logging
import socket
import struct
import time
from typing import Literal
from typing import Protocol as TypingProtocol

import numpy as np

from hardware.protocol import (
    CODE_SIZE,
    DEFAULT_PORT,
    FINE_POINT,
    MIN_ANGULAR_SPEED_DEG_S,
    MIN_LINEAR_SPEED_MM_S,
    Command,
    ProtocolError,
    Zone,
    check_pose_numbers,
    decode_reply_values,
    encode_request,
    parse_status,
    pose_to_wire,
    reply_values_size,
    show_value,
    wire_number,
    wire_to_pose,
)
from twin.core.errors import HardwareError, SafetyError, UserError
from twin.core.poses import Pose, angle_between_rotations_deg

log = logging.getLogger(__name__)

CRI_MISSING = "install the robot extra: uv sync --extra robot (GPL-3.0)"

#: upper bound of the TCP's distance from joint 1's axis plus tool (m), for move-time bounds
_REACH_BOUND_M = 0.8
#: the longest a move's reply is waited for (s, 11.6 days): a joint move of 1e38 deg
#: would otherwise ask the socket for a timeout it cannot hold
MAX_MOVE_TIMEOUT_S = 1e6


class RobotCommandRefused(HardwareError):
    """The controller answered a command with the ERROR status (e.g. unreachable pose)."""


class _Transport(TypingProtocol):
    def request(self, command: Command, args: tuple[float, ...], timeout_s: float) -> tuple[float, ...] | str | None:
        """Send one request, wait for its reply; values (wire units), info text or None."""

    def close(self) -> None: ...


# ---------------------------------------------------------------------------- native client
class NativeClient:
    """Socket client of the RAPID server protocol with timeouts (MIT, no cri needed)."""

    def __init__(self, host: str, port: int, connect_timeout_s: float) -> None:
        self.address = f"{host}:{port}"
        try:
            self._sock: socket.socket | None = socket.create_connection((host, port), timeout=connect_timeout_s)
        except OSError as err:
            raise HardwareError(
                f"cannot connect to the robot at {self.address}: {err} (is the RAPID server running?)"
            ) from None
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def request(self, command: Command, args: tuple[float, ...], timeout_s: float) -> tuple[float, ...] | str | None:
        sock = self._sock
        if sock is None:
            raise HardwareError(f"connection to the robot at {self.address} is closed")
        data = encode_request(command, *args)
        deadline = time.monotonic() + timeout_s
        try:
            sock.settimeout(timeout_s)
            sock.sendall(data)
            if command is Command.CLOSE:
                return None
            ok = parse_status(self._read_exactly(CODE_SIZE, deadline, command))
            if not ok:
                raise RobotCommandRefused(f"the robot at {self.address} refused {command.name} {_fmt_args(args)}")
            size = reply_values_size(command)
            if size is None:  # GET_INFO: text without a length; take what arrives promptly
                return self._read_available(deadline).decode("ascii", errors="replace")
            return decode_reply_values(command, self._read_exactly(size, deadline, command))
        except TimeoutError:
            self.close()
            raise HardwareError(
                f"the robot at {self.address} did not answer {command.name} within {timeout_s:.1f} s"
            ) from None
        except (OSError, ProtocolError) as err:
            self.close()
            raise HardwareError(
                f"lost the connection to the robot at {self.address} during {command.name}: {err}"
            ) from None

    def _read_exactly(self, n: int, deadline: float, command: Command) -> bytes:
        buf = bytearray()
        while len(buf) < n:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError
            self._sock.settimeout(remaining)
            chunk = self._sock.recv(n - len(buf))
            if not chunk:
                raise ConnectionError("the controller closed the connection")
            buf += chunk
        return bytes(buf)

    def _read_available(self, deadline: float, idle_s: float = 0.05) -> bytes:
        buf = bytearray()
        while time.monotonic() < deadline:
            self._sock.settimeout(idle_s)
            try:
                chunk = self._sock.recv(4096)
            except TimeoutError:
                break
            if not chunk:
                break
            buf += chunk
        return bytes(buf)

    def close(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
            sock.close()


# ---------------------------------------------------------------------------- cri client
def _import_cri_client():
    try:
        from cri.abb.abb_client import ABBClient
    except ImportError:
        raise UserError(CRI_MISSING) from None
    return ABBClient


class CriClient:
    """The lab's client (`cri.abb.abb_client.ABBClient`) behind the same interface."""

    def __init__(self, host: str, port: int, connect_timeout_s: float) -> None:
        abb_client = _import_cri_client()
        self.address = f"{host}:{port}"
        self._failed = abb_client.CommandFailed
        try:
            with contextlib.redirect_stdout(io.StringIO()):  # cri prints "Client connected ..."
                self._client = abb_client(host, port)  # cri's own 2.5 s connect timeout
        except OSError as err:
            raise HardwareError(
                f"cannot connect to the robot at {self.address}: {err} (is the RAPID server running?)"
            ) from None
        self._client.set_units("millimeters", "degrees")
        self._open = True

    def request(self, command: Command, args: tuple[float, ...], timeout_s: float) -> tuple[float, ...] | str | None:
        if not self._open:
            raise HardwareError(f"connection to the robot at {self.address} is closed")
        c = self._client
        try:
            c.sock.settimeout(timeout_s)
            if command is Command.GET_INFO:
                return c.get_info()
            if command is Command.MOVE_JOINTS:
                c.move_joints(args)
            elif command is Command.MOVE_LINEAR:
                c.move_linear(args)
            elif command is Command.SET_TOOL:
                c.set_tcp(args)
            elif command is Command.SET_WORK_OBJECT:
                c.set_work_object(args)
            elif command is Command.SET_SPEED:
                c.set_speed(float(args[0]), float(args[1]))
            elif command is Command.SET_ZONE:
                c.set_zone(point_motion=bool(args[0]), manual_zone=[float(a) for a in args[1:]])
            elif command is Command.GET_JOINTS:
                return tuple(float(v) for v in c.get_joint_angles())
            elif command is Command.GET_POSE:
                return tuple(float(v) for v in c.get_pose())
            elif command is Command.CLOSE:
                self._open = False
                try:
                    with contextlib.redirect_stdout(io.StringIO()):
                        c.close()  # sends CLOSE, then shuts the socket down
                finally:
                    c.sock.close()
                return None
            else:
                raise ProtocolError(f"{command.name} is not supported through cri")
            return ()
        except self._failed:
            raise RobotCommandRefused(f"the robot at {self.address} refused {command.name} {_fmt_args(args)}") from None
        except TimeoutError:
            self.close()
            raise HardwareError(
                f"the robot at {self.address} did not answer {command.name} within {timeout_s:.1f} s"
            ) from None
        except (OSError, struct.error, UnicodeDecodeError) as err:
            # struct.error: cri unpacked an empty reply, i.e. the controller closed the socket
            self.close()
            raise HardwareError(
                f"lost the connection to the robot at {self.address} during {command.name}: {err or type(err).__name__}"
            ) from None

    def close(self) -> None:
        if not getattr(self, "_open", False):
            return
        self._open = False
        with contextlib.suppress(OSError):
            self._client.sock.shutdown(socket.SHUT_RDWR)
        self._client.sock.close()


def _fmt_args(args: tuple[float, ...]) -> str:
    return "(" + ", ".join(show_value(a, 12) for a in args) + ")"


# ---------------------------------------------------------------------------- driver
class RobotDriver:
    """Blocking driver of the IRB120 through its RAPID server.

    | method / attribute | units                                                        |
    |--------------------|--------------------------------------------------------------|
    | set_tool(pose)     | tool (TCP) in the flange frame tool0, mm / deg               |
    | set_work_frame(p)  | work frame in the robot base frame, mm / deg                 |
    | set_speed(v, w)    | linear TCP speed mm/s, angular speed deg/s                   |
    | move_linear(pose)  | TCP pose in the work frame, mm / deg; returns when stopped   |
    | move_joints(q)     | joints 1–6 in deg; returns when stopped                      |
    | get_pose()         | measured TCP pose in the work frame, mm / deg                |
    | get_joints()       | measured joints 1–6, deg                                     |

    A move's timeout is `reply_timeout_s` plus `move_timeout_factor` × the move's expected
    duration at the set speeds (distance / linear speed, rotation / angular speed), at most
    `MAX_MOVE_TIMEOUT_S`. Every number is checked before it is sent (`wire_number`: a
    type, finiteness and float32 range; speeds at least `MIN_LINEAR_SPEED_MM_S` and
    `MIN_ANGULAR_SPEED_DEG_S`): SafetyError naming the field and value, nothing sent.
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = DEFAULT_PORT,
        *,
        client: Literal["cri", "native"] = "cri",
        connect_timeout_s: float = 3.0,
        reply_timeout_s: float = 5.0,
        move_timeout_factor: float = 2.0,
    ) -> None:
        if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
            raise UserError(f"robot port = {show_value(port)} is not a TCP port (1-65535)")
        for name, value in (
            ("connect_timeout_s", connect_timeout_s),
            ("reply_timeout_s", reply_timeout_s),
            ("move_timeout_factor", move_timeout_factor),
        ):
            if not (
                isinstance(value, (int, float)) and not isinstance(value, bool) and 0 < value <= MAX_MOVE_TIMEOUT_S
            ):
                raise UserError(f"robot {name} = {show_value(value)} must be a number in (0, {MAX_MOVE_TIMEOUT_S:g}]")
        self.host, self.port = host, port
        self.reply_timeout_s = float(reply_timeout_s)
        self.move_timeout_factor = float(move_timeout_factor)
        self._linear_speed_mm_s: float | None = None
        self._angular_speed_deg_s: float | None = None
        self._last_pose: Pose | None = None
        self._last_joints_deg: np.ndarray | None = None
        if client == "cri":
            self._transport: _Transport | None = CriClient(host, self.port, connect_timeout_s)
        elif client == "native":
            self._transport = NativeClient(host, self.port, connect_timeout_s)
        else:
            raise UserError(f"robot client must be 'cri' or 'native', got {client!r}")
        self.client = client

    @property
    def address(self) -> str:
        return f"{self.host}:{self.port}"

    @property
    def connected(self) -> bool:
        return self._transport is not None

    # ------------------------------------------------------------------ set-up
    def configure(
        self, tool2flange: Pose, work2world: Pose, linear_speed_mm_s: float, angular_speed_deg_s: float
    ) -> None:
        """Tool, work frame, speeds and a fine-point zone, in that order."""
        self.set_tool(tool2flange)
        self.set_work_frame(work2world)
        self.set_speed(linear_speed_mm_s, angular_speed_deg_s)
        self.set_zone(FINE_POINT)

    def info(self) -> str:
        """The controller's identification text."""
        return str(self._request(Command.GET_INFO, ()))

    def set_tool(self, tool2flange: Pose) -> None:
        """Tool centre point (dome apex) in the flange frame tool0 (mm / deg)."""
        check_pose_numbers(tool2flange, "tool")
        self._request(Command.SET_TOOL, pose_to_wire(tool2flange))
        self._last_pose = None

    def set_work_frame(self, work2world: Pose) -> None:
        """Work frame (work object) in the robot base frame (mm / deg)."""
        check_pose_numbers(work2world, "work frame")
        self._request(Command.SET_WORK_OBJECT, pose_to_wire(work2world))
        self._last_pose = None

    def set_speed(self, linear_mm_s: float, angular_deg_s: float) -> None:
        """Linear TCP speed (mm/s) and reorientation speed (deg/s), sent together. SafetyError
        for a speed that is not a number the wire carries (one too small to send included)."""
        speeds = []
        for name, v, unit, slowest in (
            ("linear speed", linear_mm_s, "mm/s", MIN_LINEAR_SPEED_MM_S),
            ("angular speed", angular_deg_s, "deg/s", MIN_ANGULAR_SPEED_DEG_S),
        ):
            speed = wire_number(name, v, unit, refuse_underflow=True)
            if not speed >= slowest:
                raise SafetyError(
                    f"{name} = {show_value(v)} {unit} is below the slowest speed the driver sends, {slowest} {unit}"
                )
            speeds.append(speed)
        self._request(Command.SET_SPEED, tuple(speeds))
        self._linear_speed_mm_s, self._angular_speed_deg_s = speeds

    @property
    def linear_speed_mm_s(self) -> float | None:
        return self._linear_speed_mm_s

    @property
    def angular_speed_deg_s(self) -> float | None:
        return self._angular_speed_deg_s

    def set_zone(self, zone: Zone = FINE_POINT) -> None:
        """Fine point (default: moves reply when stopped) or fly-by zone."""
        for name, value, unit in (
            ("zone pzone_tcp", zone.pzone_tcp_mm, "mm"),
            ("zone pzone_ori", zone.pzone_ori_mm, "mm"),
            ("zone zone_ori", zone.zone_ori_deg, "deg"),
        ):
            if not wire_number(name, value, unit) >= 0:
                raise SafetyError(f"{name} = {show_value(value)} {unit} must be ≥ 0")
        self._request(Command.SET_ZONE, zone.as_args())

    # ------------------------------------------------------------------ motion
    def move_linear(self, pose: Pose) -> None:
        """Straight-line move of the TCP to `pose` (work frame, mm / deg); blocks until the
        controller replies (robot stopped, with the fine-point zone)."""
        check_pose_numbers(pose)
        start = self._last_pose if self._last_pose is not None else self.get_pose()
        duration = self._linear_duration_s(start, pose)
        self._last_pose = None
        self._request(Command.MOVE_LINEAR, pose_to_wire(pose), self._move_timeout(duration))
        self._last_pose = pose
        self._last_joints_deg = None

    def move_joints(self, joints_deg) -> None:
        """Joint move to joints 1–6 (deg); blocks until the controller replies."""
        values = list(np.ravel(np.asarray(joints_deg, dtype=object)))
        if len(values) != 6:
            raise UserError(f"move_joints needs 6 joint angles (deg), got {len(values)} values")
        q = np.array([wire_number(f"joint {j + 1}", v, "deg") for j, v in enumerate(values)])
        start = self._last_joints_deg if self._last_joints_deg is not None else self.get_joints()
        # bound on the TCP path: every joint swings the TCP on a radius < _REACH_BOUND_M
        path_mm = float(np.sum(np.abs(np.radians(q - start)))) * _REACH_BOUND_M * 1e3
        duration = max(
            path_mm / (self._linear_speed_mm_s or 1.0),
            float(np.sum(np.abs(q - start))) / (self._angular_speed_deg_s or 1.0),
        )
        self._last_joints_deg = None
        self._request(Command.MOVE_JOINTS, tuple(float(v) for v in q), self._move_timeout(duration))
        self._last_joints_deg = q
        self._last_pose = None

    def get_pose(self) -> Pose:
        """Measured TCP pose in the work frame (mm / deg, extrinsic XYZ)."""
        pose = wire_to_pose(self._request(Command.GET_POSE, ()))
        self._last_pose = pose
        return pose

    def get_joints(self) -> np.ndarray:
        """Measured joints 1–6 (deg)."""
        q = np.array(self._request(Command.GET_JOINTS, ()), dtype=float)
        self._last_joints_deg = q
        return q

    # ------------------------------------------------------------------ plumbing
    def _linear_duration_s(self, start: Pose, end: Pose) -> float:
        distance = float(np.linalg.norm(end.as_array()[:3] - start.as_array()[:3]))
        angle = angle_between_rotations_deg(start.rotation, end.rotation)
        v = self._linear_speed_mm_s or 1.0  # unknown speed: assume slow (long timeout)
        w = self._angular_speed_deg_s or 1.0
        return max(distance / v, angle / w)

    def _move_timeout(self, duration_s: float) -> float:
        return min(self.reply_timeout_s + self.move_timeout_factor * duration_s, MAX_MOVE_TIMEOUT_S)

    def _request(self, command: Command, args: tuple[float, ...], timeout_s: float | None = None):
        if self._transport is None:
            raise HardwareError(f"the robot driver for {self.address} is closed")
        try:
            return self._transport.request(command, tuple(args), timeout_s or self.reply_timeout_s)
        except RobotCommandRefused:
            raise
        except HardwareError:
            self._transport = None  # the client closed itself; the stream is unusable
            raise

    def close(self) -> None:
        """Say goodbye (CLOSE) and release the socket. Safe to call twice."""
        transport, self._transport = self._transport, None
        if transport is None:
            return
        try:
            transport.request(Command.CLOSE, (), 1.0)
        except HardwareError as err:  # already gone: nothing to release
            log.debug("robot close: %s", err)
        finally:
            transport.close()

    def __enter__(self) -> RobotDriver:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
