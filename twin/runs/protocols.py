"""The paper's data-collection protocols as sequences of moves (work frame, mm/deg).

A protocol is a list of `Move`s; the runner sends each to the environment and records
an observation where `record` is set. Geometry of the straight-edge protocols (§III-A2,
§III-C): the edge passes through `edge_point_mm` with outward normal n at
`edge_normal_deg`; the tangent t is n turned +90°. Lateral position l is the offset of
the sensor centre along n (+9.9 off the object, 0 on the edge, −6 on it). Sliding
direction δ: 0° = onto the object (−n), 90° = along the edge (+t, "west" in the paper's
Fig. 4), 180° = off the object (+n), 270° = −t. A sheared tap (`sheared_tap_moves`)
presses at its pose slid back by its slide and twist, then slides and twists in contact
to its pose and records there, as the lab's edge sets do (twin.runs.lab_recording).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.core.poses import Pose
from twin.core.scenario import (
    NO_CONTACT_LATERAL_MM,
    RenderProtocol,
    ShearedTap,
    ShearedTapProtocol,
    SlideProtocol,
    TapProtocol,
)


@dataclass(frozen=True)
class Move:
    """One commanded move; `record` marks the samples of the data set; `in_contact_turn`
    marks a turn (a change of γ) that continues a contact, so the runner does not start a
    new chunk there (twin.runs.runner.chunk_moves)."""

    pose: Pose
    speed_mm_s: float
    record: bool = False
    labels: dict = field(default_factory=dict)
    in_contact_turn: bool = False


def _edge_frame(edge_point_mm, edge_normal_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = np.radians(edge_normal_deg)
    n = np.array([np.cos(a), np.sin(a)])
    t = np.array([-n[1], n[0]])
    return np.asarray(edge_point_mm, dtype=float), n, t


def tap_moves(p: TapProtocol) -> list[Move]:
    """18 orientations × 8 lateral positions × 2 depths taps (288 samples by default).

    Between taps the sensor lifts `approach_mm` above the surface, so lateral moves
    happen out of contact and the taps carry no shear.
    """
    origin, n, _ = _edge_frame(p.edge_point_mm, p.edge_normal_deg)
    moves: list[Move] = []
    for theta in p.orientations_deg:
        for lateral in p.lateral_mm:
            x, y = origin + lateral * n
            above = Pose(x, y, -p.approach_mm, 0.0, 0.0, theta)
            moves.append(Move(above, p.free_speed_mm_s))  # lateral move out of contact
            for depth in p.depths_mm:
                labels = {"theta_deg": theta, "lateral_mm": lateral, "depth_mm": depth}
                moves.append(Move(Pose(x, y, depth, 0.0, 0.0, theta), p.speed_mm_s, True, labels))
                moves.append(Move(above, p.speed_mm_s))
    return moves


def slide_offsets_mm(lateral_mm: list[float]) -> np.ndarray:
    """Distances along the slide of the 8 samples: the spacing of the lateral positions
    (0, 3.9, 5.9, … 15.9 mm for the paper's positions)."""
    lat = np.sort(np.asarray(lateral_mm, dtype=float))[::-1]
    return lat[0] - lat


def slide_moves(p: SlideProtocol) -> list[Move]:
    """18 orientations × 8 directions × 8 samples recorded while sliding (1152 by default).

    Each slide starts at l = −6 mm (on the object) for directions 90°–270° and at
    l = +9.9 mm (off it) otherwise, descends to `depth_mm` there, then slides in a
    straight line through the 8 sample points without lifting. Labels carry the true
    lateral position of each sample and whether the sensor middle is on the object.
    """
    origin, n, t = _edge_frame(p.edge_point_mm, p.edge_normal_deg)
    offsets = slide_offsets_mm(p.lateral_mm)
    on_start, off_start = min(p.lateral_mm), max(p.lateral_mm)
    moves: list[Move] = []
    for theta in p.orientations_deg:
        for direction in p.directions_deg:
            d = np.radians(direction)
            unit = -n * np.cos(d) + t * np.sin(d)
            start_lateral = on_start if 90.0 <= (direction % 360.0) <= 270.0 else off_start
            start = origin + start_lateral * n
            x0, y0 = start
            moves.append(Move(Pose(x0, y0, -p.approach_mm, 0.0, 0.0, theta), p.free_speed_mm_s))  # out of contact
            for i, s in enumerate(offsets):
                x, y = start + s * unit
                lateral = float(np.dot(np.array([x, y]) - origin, n))
                labels = {
                    "theta_deg": theta,
                    "direction_deg": direction,
                    "lateral_mm": round(lateral, 6),
                    "depth_mm": p.depth_mm,
                    "on_object": bool(lateral <= 1e-9),
                    "sample_in_slide": i,
                }
                moves.append(Move(Pose(x, y, p.depth_mm, 0.0, 0.0, theta), p.speed_mm_s, True, labels))
            moves.append(Move(Pose(x, y, -p.approach_mm, 0.0, 0.0, theta), p.speed_mm_s))
    return moves


def drawn_sheared_taps(p: ShearedTapProtocol) -> list[ShearedTap]:
    """`p.taps` taps drawn uniformly from the protocol's ranges with `p.seed`, ordered by
    θ then lateral position as the lab orders its targets (neighbouring taps turn least)."""
    rng = np.random.default_rng(p.seed)
    n = p.taps
    lateral = rng.uniform(*p.lateral_range_mm, n)
    theta = rng.uniform(*p.angle_range_deg, n)
    depth = rng.uniform(-p.depth_offset_mm, p.depth_offset_mm, n)
    along, across = rng.uniform(-p.slide_mm, p.slide_mm, (2, n))
    twist = rng.uniform(-p.twist_deg, p.twist_deg, n)
    return [
        ShearedTap(
            lateral_mm=lateral[k],
            theta_deg=theta[k],
            depth_offset_mm=depth[k],
            slide_along_mm=along[k],
            slide_lateral_mm=across[k],
            twist_deg=twist[k],
        )
        for k in np.lexsort((lateral, theta))
    ]


def sheared_tap_moves(p: ShearedTapProtocol) -> list[Move]:
    """Per tap: above the slid-back pose (out of contact), press there to the tap's depth,
    slide and twist in contact to the tap's pose and record, lift. Labels: the tap's
    fields, its depth (mm) and its index in the protocol. With `rest_frame`, a no-contact
    frame first, hovering at l = NO_CONTACT_LATERAL_MM (labels tap −1, no_contact)."""
    origin, n, t = _edge_frame(p.edge_point_mm, p.edge_normal_deg)
    moves: list[Move] = []
    if p.rest_frame:
        x, y = origin + NO_CONTACT_LATERAL_MM * n
        labels = {
            "lateral_mm": NO_CONTACT_LATERAL_MM,
            "theta_deg": 0.0,
            "depth_mm": -p.approach_mm,
            "tap": -1,
            "no_contact": True,
        }
        moves.append(Move(Pose(x, y, -p.approach_mm, 0.0, 0.0, 0.0), p.free_speed_mm_s, True, labels))
    for k, tap in enumerate(p.given if p.given is not None else drawn_sheared_taps(p)):
        depth = p.depth_mm + tap.depth_offset_mm
        x, y = origin + tap.lateral_mm * n + tap.along_mm * t
        x0, y0 = np.array([x, y]) - tap.slide_lateral_mm * n - tap.slide_along_mm * t
        theta0 = tap.theta_deg - tap.twist_deg
        labels = {**tap.model_dump(), "depth_mm": depth, "tap": k}
        moves.append(Move(Pose(x0, y0, -p.approach_mm, 0.0, 0.0, theta0), p.free_speed_mm_s))
        moves.append(Move(Pose(x0, y0, depth, 0.0, 0.0, theta0), p.speed_mm_s))
        moves.append(Move(Pose(x, y, depth, 0.0, 0.0, tap.theta_deg), p.speed_mm_s, True, labels, in_contact_turn=True))
        moves.append(Move(Pose(x, y, -p.approach_mm, 0.0, 0.0, tap.theta_deg), p.speed_mm_s))
    return moves


def render_moves(p: RenderProtocol) -> list[Move]:
    return [Move(Pose.from_array(v), p.speed_mm_s, True, {"pose_index": i}) for i, v in enumerate(p.poses)]


def protocol_moves(protocol) -> list[Move]:
    """The moves of a non-closed-loop protocol (contour following is closed-loop: see twin.control.contour)."""
    builders = {"taps": tap_moves, "slides": slide_moves, "sheared_taps": sheared_tap_moves, "render": render_moves}
    return builders[protocol.kind](protocol)
