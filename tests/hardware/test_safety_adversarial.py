"""Safety counted where it matters: ≥ 10,000 adversarial poses and speeds (NaN, ±inf, None,
bools, strings, numbers float32 cannot carry, outside the box, too deep, extreme tilts,
huge γ, bad speeds (too small to send or to move included), and straight moves between
two legal poses whose slerped tilt leaves the α/β box) go through the hardware backend
(HardwareEnvironment → RobotDriver → loopback socket) to the virtual controller, which
records every move it receives. An independent oracle walks each recorded move's whole
path (position and slerped orientation, as the controller moves) and every SET_SPEED:
zero of them may leave the safety limits."""

from __future__ import annotations

import math
import time
from collections import Counter
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from hardware.config import hardware_config_from_dict
from hardware.env import HardwareEnvironment
from hardware.protocol import MIN_ANGULAR_SPEED_DEG_S, MIN_LINEAR_SPEED_MM_S, Command, wire_to_pose
from hardware.robot import RobotCommandRefused
from hardware.safety import SafetyLimits
from hardware.virtual_controller import KinematicArm, VirtualRobotServer
from twin.core.errors import SafetyError
from twin.core.poses import EULER_AXES, Pose
from twin.world.kinematics import Irb120Kinematics

N_COMMANDS = 10_000
TCP = Pose(0, 0, 101.0, 0, 0, 0)
WORK = Pose(400, 0, 50, 180, 0, 0)
#: what float32 on the wire can move a value by (mm, deg), far below any violation tried
WIRE_TOL = 1e-4


def _video(path: Path) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (640, 480))
    for _ in range(3):
        writer.write(np.full((480, 640, 3), 40, np.uint8))
    writer.release()
    return path


def adversarial(rng: np.random.Generator, limits: SafetyLimits, at: Pose) -> tuple[str, Pose, float | None]:
    """(kind, pose, speed) of one adversarial command; `at` is where the robot is."""
    box = {
        "x": limits.x_mm,
        "y": limits.y_mm,
        "z": (limits.z_mm[0], limits.z_max_mm),
        "alpha": limits.alpha_deg,
        "beta": limits.beta_deg,
    }

    def legal(**fixed) -> dict:
        v = {k: float(rng.uniform(*b)) for k, b in box.items()} | {"gamma": float(rng.uniform(-180, 180))}
        return v | fixed

    kind = rng.choice(
        [
            "legal",
            "tilt_arc",
            "non_finite",
            "not_a_wire_number",
            "outside",
            "too_deep",
            "extreme_tilt",
            "bad_speed",
            "huge_gamma",
            "on_a_face",
        ],
        p=[0.06, 0.1, 0.13, 0.05, 0.2, 0.1, 0.15, 0.13, 0.02, 0.06],
    )
    speed = None
    if kind == "legal":
        v = legal()
    elif kind == "tilt_arc":  # both ends legal; a big turn of γ with both tilts near opposite corners
        a, b = box["alpha"][int(rng.integers(2))], box["beta"][int(rng.integers(2))]
        v = legal(
            alpha=-a * float(rng.uniform(0.8, 1.0)),
            beta=-b * float(rng.uniform(0.8, 1.0)),
            gamma=at.gamma + float(rng.choice([-1, 1]) * rng.uniform(60, 179)),
        )
    elif kind == "non_finite":
        v = legal() | {
            str(rng.choice(["x", "y", "z", "alpha", "beta", "gamma"])): float(
                rng.choice([math.nan, math.inf, -math.inf])
            )
        }
    elif kind == "not_a_wire_number":  # what float32 cannot carry, or not a number at all
        bad = [None, True, False, "5", 10**400, 3.5e38, -1e300]
        v = legal() | {str(rng.choice(["x", "y", "z", "alpha", "beta", "gamma"])): bad[int(rng.integers(len(bad)))]}
    elif kind == "outside":
        name = str(rng.choice(list(box)))
        lo, hi = box[name]
        beyond = float(10 ** rng.uniform(-9, 3))
        v = legal() | {name: hi + beyond if rng.random() < 0.5 else lo - beyond}
    elif kind == "too_deep":
        v = legal(z=limits.max_depth_mm + float(10 ** rng.uniform(-9, 2)))
    elif kind == "extreme_tilt":
        v = legal() | {str(rng.choice(["alpha", "beta"])): float(rng.choice([-1, 1]) * rng.uniform(20, 180))}
    elif kind == "bad_speed":
        v = legal(alpha=0.0, beta=0.0, gamma=at.gamma)
        bad = [
            math.nan,
            math.inf,
            -math.inf,
            -1.0,
            0.0,
            1e9,
            limits.max_linear_speed_mm_s * (1 + 1e-12),
            251.0,
            1e-300,
            1e-40,
            1e-30,
            5e-3,
            "5",
            True,
            10**400,
        ]  # too small to send, or to move, or no number
        speed = bad[int(rng.integers(len(bad)))]
    elif kind == "huge_gamma":
        v = legal(alpha=0.0, beta=0.0, gamma=float(rng.choice([-1, 1]) * 10 ** rng.uniform(3, 12)))
    else:  # on_a_face: exactly on a limit (legal), the path from here may or may not stay inside
        name = str(rng.choice(list(box)))
        v = legal() | {name: box[name][int(rng.integers(2))]}
    if speed is None and rng.random() < 0.3:
        speed = float(rng.uniform(1, limits.max_linear_speed_mm_s))
    return kind, Pose(v["x"], v["y"], v["z"], v["alpha"], v["beta"], v["gamma"]), speed


def path_violations(limits: SafetyLimits, start: Pose, end: Pose) -> list[str]:
    """The oracle: where a straight move (linear position, slerped orientation, as the
    virtual controller moves) leaves the limits, sampled every 0.05° of rotation and at
    11 points of travel (the box is convex: the ends decide the position)."""
    out = []
    for p in (start, end):
        for name, value, (lo, hi) in (
            ("x", p.x, limits.x_mm),
            ("y", p.y, limits.y_mm),
            ("z", p.z, (limits.z_mm[0], limits.z_max_mm)),
        ):
            if not (math.isfinite(value) and lo - WIRE_TOL <= value <= hi + WIRE_TOL):
                out.append(f"{name} = {value}")
    rotations = Rotation.from_euler(EULER_AXES, [start.as_array()[3:], end.as_array()[3:]], degrees=True)
    angle = math.degrees((rotations[1] * rotations[0].inv()).magnitude())
    s = np.linspace(0, 1, max(2, math.ceil(angle / 0.05) + 1))
    ab = Slerp([0, 1], rotations)(s).as_euler(EULER_AXES, degrees=True)[:, :2]
    for k, (name, (lo, hi)) in enumerate((("alpha", limits.alpha_deg), ("beta", limits.beta_deg))):
        if ab[:, k].max() > hi + WIRE_TOL or ab[:, k].min() < lo - WIRE_TOL:
            out.append(f"{name} in [{ab[:, k].min():.6f}, {ab[:, k].max():.6f}] on the way")
    return out


@pytest.fixture
def rig(tmp_path):
    kin = Irb120Kinematics()
    config = hardware_config_from_dict(
        {
            "robot": {
                "port": 1,
                "client": "native",
                "tcp_mm_deg": list(TCP.as_array()),
                "work_frame_mm_deg": list(WORK.as_array()),
            },
            "camera": {"source": _video(tmp_path / "v.avi").name},
        },
        "rig.yaml",
        base_dir=tmp_path,
    )
    start = WORK.to_matrix() @ config.robot.start_pose.to_matrix()
    q0 = kin.inverse(start, TCP.to_matrix())  # the arm waits at the start pose, inside the limits
    # the simulated arm solves its IK every 20 mm / 15° of a path (default 5 mm / 5°): the moves
    # are what this test counts, the arm's own path checks are tested in test_virtual_robot.py
    arm = KinematicArm(kin, q0_rad=q0, path_step_m=0.02, path_step_rad=math.radians(15))
    with VirtualRobotServer("127.0.0.1", 0, arm, log_limit=None) as server:
        config = config.model_copy(update={"robot": config.robot.model_copy(update={"port": server.port})})
        env = HardwareEnvironment(config)
        try:
            yield env, server
        finally:
            env.close()


def test_no_move_outside_the_limits_reaches_the_controller(rig, capsys) -> None:
    env, server = rig
    limits = env.safety
    rng = np.random.default_rng(2026)
    outcomes: Counter = Counter()
    at = env.config.robot.start_pose
    t0 = time.perf_counter()
    for _ in range(N_COMMANDS):
        kind, pose, speed = adversarial(rng, limits, at)
        try:
            env.move_to(pose, speed)
            at = pose
            outcomes[kind, "sent"] += 1
        except SafetyError:
            outcomes[kind, "refused by the safety limits"] += 1
        except RobotCommandRefused:  # the controller's own refusal (reach, joint limits)
            outcomes[kind, "refused by the controller"] += 1
    elapsed = time.perf_counter() - t0

    moves = list(server.moves)
    assert len(moves) == sum(n for (_, how), n in outcomes.items() if how != "refused by the safety limits")
    bad = [(m, v) for m in moves if (v := path_violations(limits, wire_to_pose(m.start), wire_to_pose(m.end)))]
    speeds = [r.args for r in server.command_log if r.command is Command.SET_SPEED]
    bad_speeds = [
        s
        for s in speeds
        if not (
            MIN_LINEAR_SPEED_MM_S * (1 - 1e-6) <= s[0] <= limits.max_linear_speed_mm_s * (1 + 1e-6)
            and MIN_ANGULAR_SPEED_DEG_S * (1 - 1e-6) <= s[1] <= limits.max_angular_speed_deg_s * (1 + 1e-6)
        )
    ]
    with capsys.disabled():
        print(
            f"\nsafety: {N_COMMANDS} adversarial commands in {elapsed:.1f} s; {len(moves)} moves and {len(speeds)} "
            f"speed changes reached the controller; outside the limits: {len(bad)} moves, {len(bad_speeds)} speeds"
        )
        for key in sorted(outcomes):
            print(f"  {key[0]:>17}: {key[1]:<28} {outcomes[key]}")
    assert not bad, bad[:3]
    assert not bad_speeds, bad_speeds[:3]
    # every kind was tried, and the safety limits (not luck) stopped the dangerous ones
    assert outcomes["tilt_arc", "refused by the safety limits"] > 100 and outcomes["tilt_arc", "sent"] > 100
    assert outcomes["legal", "sent"] > 100 and outcomes["on_a_face", "sent"] > 100
    for kind in ("non_finite", "not_a_wire_number", "outside", "too_deep", "extreme_tilt", "bad_speed"):
        assert outcomes[kind, "sent"] == 0 and outcomes[kind, "refused by the safety limits"] > 200, kind
