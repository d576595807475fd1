"""Wire protocol of the ABB RAPID server used by the lab (Common Robot Interface).

Own implementation, written from the protocol facts (command codes, byte layout, units);
shared by the client (`hardware.robot`) and the virtual controller
(`hardware.virtual_controller`). One TCP connection, one request at a time, strictly
request → reply, everything big-endian ("network order"):

    request = uint16 command code, then the arguments as float32 (or uint16 where noted)
    reply   = uint16 status (1 = OK, 0 = ERROR), then the reply values (only when OK)

| code | command          | request arguments (after the code)                      | reply after the status      |
|------|------------------|---------------------------------------------------------|-----------------------------|
| 0    | GET_INFO         | —                                                       | ASCII text, unframed        |
| 1    | MOVE_JOINTS      | 6 × f32: joints 1–6 (deg)                               | —                           |
| 2    | MOVE_LINEAR      | 7 × f32: x, y, z (mm), qw, qx, qy, qz — tool in work obj | —                           |
| 3    | MOVE_CIRCULAR    | 14 × f32: via pose (7), end pose (7), as MOVE_LINEAR     | —                           |
| 4    | SET_TOOL         | 7 × f32: tool (TCP) in the flange frame tool0, mm + quat | —                           |
| 5    | SET_WORK_OBJECT  | 7 × f32: work object frame in the base frame, mm + quat | —                           |
| 6    | SET_SPEED        | 2 × f32: linear TCP speed (mm/s), angular speed (deg/s) | —                           |
| 7    | SET_ZONE         | u16 point_motion (1 = fine point), 3 × f32: pzone_tcp    | —                           |
|      |                  | (mm), pzone_ori (mm), zone_ori (deg)                     |                             |
| 8    | GET_JOINTS       | —                                                       | 6 × f32: joints 1–6 (deg)   |
| 9    | GET_POSE         | —                                                       | 7 × f32: tool in work obj,  |
|      |                  |                                                         | x, y, z (mm), qw, qx, qy, qz |
| 99   | CLOSE            | —                                                       | none: the server closes the |
|      |                  |                                                         | connection                  |

Semantics (as on the controller):

* Quaternions are w-first (RAPID `orient` q1..q4 = w, x, y, z).
* A move's reply is sent when the RAPID instruction returns. With a *fine point*
  zone (SET_ZONE with point_motion = 1) that is when the robot has stopped at the target;
  with a fly-by zone the reply can come before the motion has finished. Our driver always
  sets the fine point.
* The work object is ABB's object frame `oframe` (the user frame stays identity), so it
  is simply the work frame's pose in the robot base frame.
* Unknown command codes and refused commands (e.g. an unreachable pose on the virtual
  controller) get a bare ERROR status. The real controller may instead stop the RAPID
  program with an error on the FlexPendant and drop the connection.
* GET_INFO's text has no length prefix; a client reads what arrives after the status.
* Every number travels as a float32: beyond ±FLOAT32_MAX it cannot be sent, and below
  FLOAT32_TINY (the smallest normal float32) it arrives as a denormal or 0.
  `wire_number` refuses both before anything is sent.

Replies have no length prefix either, so a reader must know the command it is waiting
for: `reply_value_count` gives the number of float32 values after an OK status.
"""

from __future__ import annotations

import math
import numbers
import struct
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from scipy.spatial.transform import Rotation

from twin.core.errors import SafetyError
from twin.core.poses import Pose, make_transform, quat_wxyz_to_matrix, quat_xyzw_to_wxyz

#: default TCP port of the RAPID server
DEFAULT_PORT = 5000

STATUS_ERROR = 0
STATUS_OK = 1

_CODE = struct.Struct(">H")


class Command(IntEnum):
    """Command codes of the RAPID server."""

    GET_INFO = 0
    MOVE_JOINTS = 1
    MOVE_LINEAR = 2
    MOVE_CIRCULAR = 3
    SET_TOOL = 4
    SET_WORK_OBJECT = 5
    SET_SPEED = 6
    SET_ZONE = 7
    GET_JOINTS = 8
    GET_POSE = 9
    CLOSE = 99


#: struct layout of each request's arguments (after the 2-byte code)
REQUEST_LAYOUT: dict[Command, struct.Struct] = {
    Command.GET_INFO: struct.Struct(">"),
    Command.MOVE_JOINTS: struct.Struct(">6f"),
    Command.MOVE_LINEAR: struct.Struct(">7f"),
    Command.MOVE_CIRCULAR: struct.Struct(">14f"),
    Command.SET_TOOL: struct.Struct(">7f"),
    Command.SET_WORK_OBJECT: struct.Struct(">7f"),
    Command.SET_SPEED: struct.Struct(">2f"),
    Command.SET_ZONE: struct.Struct(">H3f"),
    Command.GET_JOINTS: struct.Struct(">"),
    Command.GET_POSE: struct.Struct(">"),
    Command.CLOSE: struct.Struct(">"),
}

#: struct layout of each OK reply's values (after the 2-byte status); None = no fixed
#: layout (GET_INFO: free text) or no reply at all (CLOSE)
REPLY_LAYOUT: dict[Command, struct.Struct | None] = {
    Command.GET_INFO: None,
    Command.MOVE_JOINTS: struct.Struct(">"),
    Command.MOVE_LINEAR: struct.Struct(">"),
    Command.MOVE_CIRCULAR: struct.Struct(">"),
    Command.SET_TOOL: struct.Struct(">"),
    Command.SET_WORK_OBJECT: struct.Struct(">"),
    Command.SET_SPEED: struct.Struct(">"),
    Command.SET_ZONE: struct.Struct(">"),
    Command.GET_JOINTS: struct.Struct(">6f"),
    Command.GET_POSE: struct.Struct(">7f"),
    Command.CLOSE: None,
}

CODE_SIZE = _CODE.size  # bytes of a command code or a status

#: the largest finite float32 and the smallest normal one: the range a number keeps on the wire
FLOAT32_MAX = float(np.finfo(np.float32).max)
FLOAT32_TINY = float(np.finfo(np.float32).tiny)

#: the slowest speeds the driver sends and the virtual controller accepts (mm/s, deg/s):
#: a move across the IRB120's whole reach still ends within days, and its time fits a timeout
MIN_LINEAR_SPEED_MM_S = 0.01
MIN_ANGULAR_SPEED_DEG_S = 0.01


class ProtocolError(ValueError):
    """Bytes that do not follow the protocol (unknown code, wrong length)."""


# ---------------------------------------------------------------------------- requests
def encode_request(command: Command, *args: float) -> bytes:
    """Bytes of one request. `args` in wire units (mm, deg, mm/s, deg/s, unit quats)."""
    command = Command(command)
    layout = REQUEST_LAYOUT[command]
    if command is Command.SET_ZONE:
        if len(args) != 4:
            raise ProtocolError(f"SET_ZONE takes point_motion and 3 zone values, got {len(args)} values")
        values: tuple = (int(bool(args[0])), *(float(a) for a in args[1:]))
    else:
        values = tuple(float(a) for a in args)
    try:
        return _CODE.pack(int(command)) + layout.pack(*values)
    except (struct.error, OverflowError) as err:  # OverflowError: beyond float32
        raise ProtocolError(f"{command.name}: {err} (got {len(values)} values)") from None


def parse_command_code(code_bytes: bytes) -> Command:
    """The command of a request's first 2 bytes; ProtocolError if unknown."""
    (code,) = _CODE.unpack(code_bytes)
    try:
        return Command(code)
    except ValueError:
        raise ProtocolError(f"unknown command code {code}") from None


def decode_request_payload(command: Command, payload: bytes) -> tuple[float, ...]:
    """Arguments of a request from the bytes after its code."""
    layout = REQUEST_LAYOUT[Command(command)]
    if len(payload) != layout.size:
        raise ProtocolError(f"{Command(command).name} needs {layout.size} payload bytes, got {len(payload)}")
    return layout.unpack(payload)


def decode_request(data: bytes) -> tuple[Command, tuple[float, ...]]:
    """(command, arguments) of one complete request."""
    if len(data) < CODE_SIZE:
        raise ProtocolError(f"a request has at least {CODE_SIZE} bytes, got {len(data)}")
    command = parse_command_code(data[:CODE_SIZE])
    return command, decode_request_payload(command, data[CODE_SIZE:])


@dataclass(frozen=True)
class Request:
    """One complete request: its command and arguments (wire units)."""

    command: Command
    args: tuple[float, ...]


@dataclass(frozen=True)
class DecodeError:
    """Bytes that are not a request; `discarded` bytes were dropped with them."""

    message: str
    discarded: int


#: the longest request (MOVE_CIRCULAR), bytes: the most a decoder ever holds between feeds
MAX_REQUEST_SIZE = CODE_SIZE + max(layout.size for layout in REQUEST_LAYOUT.values())


class RequestDecoder:
    """Incremental decoder of a request stream: `feed` any bytes as they arrive (split
    anywhere) and get the complete requests, and errors as values. Never raises; holds at
    most MAX_REQUEST_SIZE - 1 bytes between feeds.

    The protocol has no framing, so after an unknown command code the decoder cannot
    find the next request: it drops everything it holds (the server also drains the
    socket and answers ERROR, as for any unknown code)."""

    def __init__(self) -> None:
        self._buf = bytearray()

    @property
    def pending(self) -> int:
        """Bytes of an incomplete request held back (0 = between requests)."""
        return len(self._buf)

    def reset(self) -> None:
        self._buf.clear()

    def feed(self, data: bytes) -> list[Request | DecodeError]:
        self._buf += data
        out: list[Request | DecodeError] = []
        while len(self._buf) >= CODE_SIZE:
            (code,) = _CODE.unpack_from(self._buf, 0)
            try:
                command = Command(code)
            except ValueError:
                out.append(DecodeError(f"unknown command code {code}", len(self._buf)))
                self._buf.clear()
                break
            layout = REQUEST_LAYOUT[command]
            if len(self._buf) < CODE_SIZE + layout.size:
                break
            args = layout.unpack_from(self._buf, CODE_SIZE)
            del self._buf[: CODE_SIZE + layout.size]
            out.append(Request(command, args))
        return out


# ---------------------------------------------------------------------------- replies
def encode_reply(command: Command, ok: bool = True, values: tuple[float, ...] | str = ()) -> bytes:
    """Bytes of one reply: status, then (only when OK) the values or GET_INFO's text."""
    command = Command(command)
    if command is Command.CLOSE:
        raise ProtocolError("CLOSE has no reply")
    status = _CODE.pack(STATUS_OK if ok else STATUS_ERROR)
    if not ok:
        return status
    if command is Command.GET_INFO:
        return status + str(values).encode("ascii", errors="replace")
    layout = REPLY_LAYOUT[command]
    try:
        return status + layout.pack(*(float(v) for v in values))
    except (struct.error, OverflowError) as err:  # OverflowError: beyond float32
        raise ProtocolError(f"{command.name} reply: {err}") from None


def parse_status(status_bytes: bytes) -> bool:
    """True for OK, False for ERROR; ProtocolError for anything else."""
    (status,) = _CODE.unpack(status_bytes)
    if status not in (STATUS_OK, STATUS_ERROR):
        raise ProtocolError(f"reply status {status} is neither OK (1) nor ERROR (0)")
    return status == STATUS_OK


def reply_values_size(command: Command) -> int | None:
    """Bytes after an OK status for `command`; None for GET_INFO (free text) and CLOSE."""
    layout = REPLY_LAYOUT[Command(command)]
    return None if layout is None else layout.size


def decode_reply_values(command: Command, data: bytes) -> tuple[float, ...]:
    """Values of an OK reply from the bytes after the status."""
    layout = REPLY_LAYOUT[Command(command)]
    if layout is None:
        raise ProtocolError(f"{Command(command).name} has no fixed reply layout")
    if len(data) != layout.size:
        raise ProtocolError(f"{Command(command).name} reply needs {layout.size} bytes, got {len(data)}")
    return layout.unpack(data)


# ---------------------------------------------------------------------------- numbers on the wire
def show_value(value: object, limit: int = 40) -> str:
    """A value for a one-line message, whatever its type: floats as %.6g (1e-40 stays
    readable), anything else as a repr cut to `limit` characters (10**400 has 401 digits)."""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**16:
        return f"~1e+{int(math.log10(abs(value)))}" if value > 0 else f"~-1e+{int(math.log10(-value))}"
    try:
        text = repr(value)
    except Exception:  # a repr that fails must not take the message with it
        text = f"<{type(value).__name__}>"
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def wire_number(field: str, value: object, unit: str = "", *, refuse_underflow: bool = False) -> float:
    """`value` as a float that the protocol's float32 carries: a real number (bool and
    str are not), finite and at most FLOAT32_MAX in size. With `refuse_underflow` (speeds,
    where it changes the meaning: 0 or a crawl) also 0 or at least FLOAT32_TINY in size;
    without it (coordinates) a smaller one arrives as a denormal or 0, off by < 1.2e-38.
    SafetyError naming `field` and the value otherwise; nothing has been sent."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SafetyError(f"{field} = {show_value(value)} is not a number ({type(value).__name__})")
    shown = f"{field} = {show_value(value)}{' ' + unit if unit else ''}"
    try:
        number = float(value)
    except OverflowError:  # an int beyond float64
        raise SafetyError(f"{shown} is beyond the robot's float32 range (±{FLOAT32_MAX:.7g})") from None
    if not math.isfinite(number):
        raise SafetyError(f"{shown} is not a finite number")
    if abs(number) > FLOAT32_MAX:
        raise SafetyError(f"{shown} is beyond the robot's float32 range (±{FLOAT32_MAX:.7g})")
    if refuse_underflow and 0.0 < abs(number) < FLOAT32_TINY:
        sent = float(np.float32(number))
        raise SafetyError(
            f"{shown} is too small to send: the robot's float32 carries it as {sent:.6g} "
            f"(the smallest normal float32 is {FLOAT32_TINY:.7g})"
        )
    return number


# ---------------------------------------------------------------------------- poses on the wire
@dataclass(frozen=True)
class Zone:
    """RAPID zonedata subset sent by SET_ZONE: fine point, or fly-by radii (mm, mm, deg)."""

    point_motion: bool = True
    pzone_tcp_mm: float = 0.0
    pzone_ori_mm: float = 0.0
    zone_ori_deg: float = 0.0

    def as_args(self) -> tuple[float, float, float, float]:
        return (float(self.point_motion), self.pzone_tcp_mm, self.pzone_ori_mm, self.zone_ori_deg)


FINE_POINT = Zone()


POSE_FIELDS = (("x", "mm"), ("y", "mm"), ("z", "mm"), ("alpha", "deg"), ("beta", "deg"), ("gamma", "deg"))


def format_pose(pose: Pose) -> str:
    """(x, y, z, α, β, γ) of a pose for a message, whatever its fields hold."""
    return "(" + ", ".join(show_value(getattr(pose, name, None), 12) for name, _ in POSE_FIELDS) + ")"


def check_pose_numbers(pose: Pose, what: str = "pose") -> None:
    """SafetyError naming `what`, the field and its value unless every field of `pose` is
    a number the wire carries (`wire_number`)."""
    for name, unit in POSE_FIELDS:
        try:
            wire_number(name, getattr(pose, name), unit)
        except SafetyError as err:
            raise SafetyError(f"{what} {format_pose(pose)}: {err}") from None


def pose_to_wire(pose: Pose) -> tuple[float, ...]:
    """(x, y, z mm, qw, qx, qy, qz) of a lab pose (mm, extrinsic-XYZ deg); SafetyError for
    a field the wire cannot carry (`check_pose_numbers`).

    The quaternion is computed here by `twin.core.poses` (Euler axes explicit), so no client
    library converts Euler angles with its own (fork-dependent) axis convention.
    """
    check_pose_numbers(pose)
    q = pose.quat_wxyz()
    if q[0] < 0:  # same rotation; keep w ≥ 0 for readable logs
        q = -q
    return (float(pose.x), float(pose.y), float(pose.z), *(float(c) for c in q))


def normalised_quat(q_wxyz) -> np.ndarray:
    """Unit quaternion (w-first) from wire values; ProtocolError if not finite or ~zero."""
    q = np.asarray(q_wxyz, dtype=float)
    norm = float(np.linalg.norm(q))
    if not np.all(np.isfinite(q)) or norm < 1e-6:
        raise ProtocolError(f"quaternion {q.tolist()} is not a rotation")
    return q / norm


def wire_to_matrix(values) -> np.ndarray:
    """4×4 transform (m) from (x, y, z mm, qw, qx, qy, qz)."""
    v = np.asarray(values, dtype=float)
    if v.shape != (7,) or not np.all(np.isfinite(v[:3])):
        raise ProtocolError(f"a wire pose has 7 finite values, got {v.tolist()}")
    return make_transform(quat_wxyz_to_matrix(normalised_quat(v[3:])), v[:3] * 1e-3)


def matrix_to_wire(a2b: np.ndarray) -> tuple[float, ...]:
    """(x, y, z mm, qw, qx, qy, qz) of a 4×4 transform (m)."""

    q = quat_xyzw_to_wxyz(Rotation.from_matrix(a2b[:3, :3]).as_quat())
    if q[0] < 0:
        q = -q
    return (*(float(c) for c in a2b[:3, 3] * 1e3), *(float(c) for c in q))


def wire_to_pose(values) -> Pose:
    """Lab pose (mm, extrinsic-XYZ deg) from (x, y, z mm, qw, qx, qy, qz)."""
    m = wire_to_matrix(values)
    pose = Pose.from_matrix(m)
    return Pose(float(values[0]), float(values[1]), float(values[2]), pose.alpha, pose.beta, pose.gamma)
