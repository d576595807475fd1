"""Importing a recording in the lab's format as a run of the twin (twin.runs.record).

The lab's format (nlepora/pbts-2d, e.g. the DigiTac paper's TacTip edge set): a folder of
frames, the no-contact frame `init_0.png` (or `init.png`), and a targets CSV with the
columns image_name, pose_1 … pose_6 and move_1 … move_6.

The lab's pose convention, from its collection code (pose_models_2d/lib/common.py,
`make_target_df` and `collect`):

* pose_k and move_k are [x, y, z mm, α, β, γ deg] in the robot's work frame (meta.json
  "work_frame"; the arm's base frame moved and turned about its vertical axis, so z is
  up). The robot's TCP is its flange on the sensor's axis, so a turn about z turns the
  sensor about its own axis.
* Each frame: the robot moves to pose − move (out of contact), down by `tap_move`
  ([0, 0, −5, 0, 0, 0]) to pose − move + tap_move (in contact), slides to pose + tap_move
  (an in-contact slide of +move_1, +move_2 mm and a turn of +move_6 deg), takes the
  frame there, and lifts to pose. The frame's pose is pose + tap_move.
* pose_2 is the sensor centre's offset across the edge, pose_1 (0) along it, pose_3 the
  height offset (z up: + is shallower; the depth at pose_3 = 0 is not recorded), pose_6
  the edge angle; pose_4, pose_5 and move_3 … move_5 are 0.

Mapped to the twin (work frame z down into the object; l + off the object, 0 at the edge;
θ about the twin's z; twin.core.poses, twin.core.scenario.ShearedTapProtocol), with
s = −1 when the object lies on the lab's +y side (the DigiTac set: the pins move more as
pose_2 grows) and s = +1 when it lies on the −y side:

    l = s·pose_2            along = s·pose_1          depth offset = −pose_3
    θ = −pose_6             slide_lateral = s·move_2  slide_along = s·move_1
    twist = −move_6         depth = depth_mm − pose_3 (depth_mm: the nominal, given)

A turn about the lab's up z is the opposite turn about the twin's down z; the lab's
(x, y) are the twin's (along, lateral) turned over the edge, so both flip with s.

The run's first sample is the no-contact frame (the sheared-taps protocol's rest frame,
hovering off the object); each frame is tracked on its own from it by the twin's tracker
(twin.sensing.tracker); a frame with pins the tracker did not find is recorded with
them flagged (`found`), one missing or unreadable is recorded without pins; both are
counted in run.json ("import") and by `twin import-lab`.
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from twin.core.environment import Observation
from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.scenario import Scenario, ShearedTapProtocol, scenario_from_dict
from twin.runs.protocols import sheared_tap_moves
from twin.runs.record import Run, RunRecorder
from twin.sensing.tracker import PinTracker, camera_for_frame

POSE_COLUMNS = tuple(f"pose_{k}" for k in range(1, 7))
MOVE_COLUMNS = tuple(f"move_{k}" for k in range(1, 7))
INIT_NAMES = ("init_0.png", "init.png")
#: the lab's tap_move (mm): the frame is taken this far along the lab's z from `pose`
LAB_TAP_MOVE_Z_MM = -5.0


@dataclass(frozen=True)
class LabTargets:
    """A lab targets CSV: frame names, poses (N, 6) and moves (N, 6), mm and deg, lab work frame."""

    image_names: list[str]
    poses: np.ndarray
    moves: np.ndarray


def read_lab_targets(path: Path) -> LabTargets:
    """The targets CSV; UserError naming the file, row and column of anything unreadable."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such targets file")
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    needed = ("image_name", *POSE_COLUMNS, *MOVE_COLUMNS)
    missing = [c for c in needed if not rows or c not in rows[0]]
    if missing:
        raise UserError(
            f"{path}: no rows or no column(s) {', '.join(missing)} (the lab's targets have {', '.join(needed)})"
        )
    values = np.empty((len(rows), 12))
    for i, row in enumerate(rows):
        for j, column in enumerate((*POSE_COLUMNS, *MOVE_COLUMNS)):
            try:
                values[i, j] = float(row[column])
            except (TypeError, ValueError):
                raise UserError(f"{path}: row {i + 2}, column {column} = {row[column]!r} is not a number") from None
    if not np.isfinite(values).all():
        i, j = np.argwhere(~np.isfinite(values))[0]
        raise UserError(f"{path}: row {i + 2}, column {needed[1 + j]} is not finite")
    return LabTargets([r["image_name"] for r in rows], values[:, :6], values[:, 6:])


def lab_to_twin_tap(pose: np.ndarray, move: np.ndarray, object_side: int = 1) -> dict:
    """One lab target (pose, move: [x, y, z mm, α, β, γ deg]) as a twin sheared tap's fields
    (module docstring); `object_side` +1: the object lies on the lab's +y side, −1: on −y."""
    s = -float(object_side)
    return {
        "lateral_mm": s * pose[1],
        "along_mm": s * pose[0],
        "theta_deg": -pose[5],
        "depth_offset_mm": -pose[2],
        "slide_along_mm": s * move[0],
        "slide_lateral_mm": s * move[1],
        "twist_deg": -move[5],
    }


def lab_pose_to_twin(lab_pose: np.ndarray, protocol: ShearedTapProtocol, object_side: int = 1) -> Pose:
    """A pose of the lab's arm (lab work frame, with tap_move applied) as the twin's pose
    (twin work frame) on `protocol`'s edge: the whole-frame map that `lab_to_twin_tap`
    applies to the labels."""
    s = -float(object_side)
    a = np.radians(protocol.edge_normal_deg)
    n, t = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
    x, y = np.asarray(protocol.edge_point_mm) + s * lab_pose[1] * n + s * lab_pose[0] * t
    return Pose(x, y, protocol.depth_mm + LAB_TAP_MOVE_Z_MM - lab_pose[2], 0.0, 0.0, -lab_pose[5])


def lab_scenario(
    targets: LabTargets,
    frame_shape: tuple[int, int],
    depth_mm: float,
    object_side: int,
    name: str,
    source: str,
    edge_radius_mm: float = 0.0,
) -> Scenario:
    """The scenario an imported recording is a run of: its taps given in order on the
    rectangle's edge (the twin's stand-in for the lab's straight edge, rounded by
    `edge_radius_mm`, mm, where the lab's object is), its camera's size."""
    given = [lab_to_twin_tap(p, m, object_side) for p, m in zip(targets.poses, targets.moves)]
    return scenario_from_dict(
        {
            "name": name,
            "description": f"imported from the lab recording {source}",
            "backend": "hardware",
            "object": {"name": "rectangle", "edge_radius_mm": edge_radius_mm},
            "sensor": {"camera": {"width": frame_shape[1], "height": frame_shape[0]}},
            "protocol": {"kind": "sheared_taps", "depth_mm": depth_mm, "taps": max(len(given), 1), "given": given},
        },
        source,
    )


def _init_frame(folder: Path, init: Path | None) -> Path:
    candidates = [init] if init is not None else [folder / n for n in INIT_NAMES]
    for path in candidates:
        if path.is_file():
            return path
    raise UserError(f"{folder}: no no-contact frame ({' or '.join(str(c) for c in candidates)}); name it with --init")


def _gray(path: Path) -> np.ndarray | None:
    return cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)


def import_lab_recording(
    folder: Path,
    targets_csv: Path,
    out: Path,
    *,
    init: Path | None = None,
    depth_mm: float = 3.0,
    object_side: int = 1,
    edge_radius_mm: float = 0.0,
    limit: int | None = None,
    progress: bool = True,
) -> dict:
    """Write the recording in `folder` (frames named by `targets_csv`) as a run in `out`:
    each frame's pins tracked from the no-contact frame, labels and targets mapped to the
    twin's convention (module docstring). Returns run.json's "import" summary."""
    folder, out = Path(folder), Path(out)
    targets = read_lab_targets(targets_csv)
    if limit is not None:
        targets = LabTargets(targets.image_names[:limit], targets.poses[:limit], targets.moves[:limit])
    init_path = _init_frame(folder, init)
    reference = _gray(init_path)
    if reference is None:
        raise UserError(f"{init_path}: not a readable image")
    tracker = PinTracker(reference)
    name = Path(targets_csv).resolve().parent.name  # the set's folder (frames may sit in a subfolder)
    scenario = lab_scenario(
        targets, reference.shape, depth_mm, object_side, name, str(Path(targets_csv)), edge_radius_mm
    )
    frames = [m for m in sheared_tap_moves(scenario.protocol) if m.record]  # the no-contact frame, then the taps
    files = [init_path, *(folder / name for name in targets.image_names)]
    camera = camera_for_frame(reference.shape[1], reference.shape[0])
    summary = {
        "folder": str(folder),
        "targets": str(targets_csv),
        "init": str(init_path),
        "depth_mm": depth_mm,
        "object_side": object_side,
        "edge_radius_mm": edge_radius_mm,
        "frames": len(frames),
    }
    incomplete, unreadable = [], []
    wall = time.perf_counter()
    with RunRecorder(out, scenario, 0, "hardware", camera, extra={"import": summary}) as recorder:
        recorder.set_rest_pins(tracker.reference_pins_px)
        for k, (move, path) in enumerate(
            tqdm(list(zip(frames, files)), desc=folder.name, unit="frame", disable=not progress)
        ):
            labels = {**move.labels, "lab_frame": path.name}
            gray = _gray(path)
            if gray is None or gray.shape != reference.shape:
                unreadable.append(k)
                recorder.add(Observation(float(k), move.pose), move.pose, labels)
                continue
            tracker.reset()  # every frame is its own tap from out of contact
            result = tracker.track(gray)
            if not result.found.all():
                incomplete.append(k)
            recorder.add(
                Observation(float(k), move.pose, cv2.cvtColor(gray, cv2.COLOR_GRAY2RGB)),
                move.pose,
                labels,
                result.pins_px,
                result.found,
            )
        summary.update(
            complete=len(frames) - len(incomplete) - len(unreadable),
            incomplete=incomplete,
            unreadable=unreadable,
            wall_time_s=time.perf_counter() - wall,
        )
        recorder.meta["import"] = summary
    return summary


def nominal_depth_mm(run: Run) -> float | None:
    """The depth (mm) a sheared-taps run's taps are offsets from: for an imported lab
    recording, the nominal it was imported at (`twin import-lab --depth-mm`; the lab does
    not record it). None for a run of another protocol."""
    protocol = run.meta["scenario"].get("protocol", {})
    return float(protocol["depth_mm"]) if protocol.get("kind") == "sheared_taps" else None


def with_taps_from(
    scenario: Scenario, run: Run, first: int | None = None, without_slides: bool = False, every: int = 1
) -> Scenario:
    """`scenario` (a sheared-taps one) with the taps of a recorded sheared-taps run (an
    imported lab recording), in order: every `every`-th tap from the first (a sample spread
    over a recording ordered by pose), then the first `first` of those when given; the twin
    replays the recording sample by sample. `without_slides`: each tap at its pose without
    its in-contact slide and twist, the imprint the slides are measured against."""
    if scenario.protocol.kind != "sheared_taps":
        raise UserError(
            f"{scenario.source}: --taps-from needs a sheared_taps protocol, this one is {scenario.protocol.kind!r}"
        )
    recorded = run.meta["scenario"]["protocol"]
    if recorded.get("kind") != "sheared_taps" or not recorded.get("given"):
        raise UserError(f"{run.path}: not a run of given sheared taps (an imported lab recording)")
    given = recorded["given"][::every][:first]
    replay = scenario.with_changes(protocol={**scenario.protocol.model_dump(), "given": given, "taps": len(given)})
    return replay.with_changes(protocol=replay.protocol.without_slides().model_dump()) if without_slides else replay
