"""The recorded pins a calibration fits: runs read and checked against the calibration
scenario, grouped (rest, contact, sliding) and weighted, and paired with the replayed
chunks that simulate them; on request, also each sheared-tap run's taps replayed without
their slides (the edge figures' signal, twin.analysis.calibration_fit.figures)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from twin.analysis.calibration_fit.settings import Weights
from twin.core.errors import UserError
from twin.core.scenario import Scenario, scenario_from_dict
from twin.runs.pairing import pair_samples
from twin.runs.record import Run, load_run
from twin.runs.replay import replay_chunks

GROUPS = ("rest", "contact", "sliding")
#: scenario fields a recorded run must share with the calibration scenario
SHARED_FIELDS = ("object", "placement", "work_frame")


@dataclass
class Data:
    """The recorded pins to fit, paired with the chunks that simulate them."""

    runs: list[Path]
    pins: np.ndarray  # (N, 127, 2) px recorded (NaN where not found)
    group: np.ndarray  # (N,) index into GROUPS
    run_index: np.ndarray  # (N,)
    chunks: list[tuple[int, list]]  # (run number, moves) to simulate
    weights: np.ndarray  # (N,) per-frame weight of its group
    sim_index: list[np.ndarray] = field(default_factory=list)  # per run: recorded sample -> simulated row
    unfinished: list[str] = field(default_factory=list)  # a line per run that did not finish (Run.unfinished_note)
    records: list[Run] = field(default_factory=list)  # the runs as read
    without_pins: list[str] = field(default_factory=list)  # a line per run with samples that have no pins (NaN here)
    #: per still replay (after the runs in `sim_index`): the run it replays without slides
    still_of: list[int] = field(default_factory=list)

    def still_rows(self, run: int) -> np.ndarray | None:
        """Rows of the simulated pins (after the N recorded samples') of `run`'s still replay,
        in its samples' order; None without one."""
        if run not in self.still_of:
            return None
        k = self.still_of.index(run)
        first = len(self.pins) + sum(len(self.records[r].samples) for r in self.still_of[:k])
        return first + np.arange(len(self.records[run].samples))


def _group(scenario: Scenario, sample: dict) -> int:
    if sample["target"][2] <= 0.0:
        return GROUPS.index("rest")
    return GROUPS.index("sliding" if scenario.protocol.kind in ("slides", "contour") else "contact")


def load_data(run_dirs: list[Path], scenario: Scenario, weights: Weights, still_replays: bool = False) -> Data:
    """Read and check the runs against the calibration scenario (UserError naming the run
    and field: another object, placement, work frame or camera; no samples; no sample with
    pins). A sample without pins (an imported recording's missing frame) is replayed, so the
    sensor's path is the recorded one, and its pins are NaN: not fitted. `still_replays`:
    each sheared-tap run is also replayed without its slides and twists (simulated after
    all the runs' samples, `Data.still_rows`)."""
    pins, group, run_index, chunks, records = [], [], [], [], []
    without_pins: list[str] = []
    cam = scenario.sensor.camera
    for r, path in enumerate(run_dirs):
        run = load_run(path)
        recorded = scenario_from_dict(run.meta["scenario"], str(path / "run.json"))
        for name in SHARED_FIELDS:
            if getattr(recorded, name) != getattr(scenario, name):
                raise UserError(
                    f"{path}: recorded with scenario field '{name}' = {getattr(recorded, name)!r}, but the "
                    f"calibration scenario {scenario.source} has {getattr(scenario, name)!r}: runs of "
                    "different scenarios cannot be fitted together"
                )
        if (recorded.sensor.camera.width, recorded.sensor.camera.height) != (cam.width, cam.height):
            raise UserError(
                f"{path}: recorded with a {recorded.sensor.camera.width}×{recorded.sensor.camera.height} "
                f"camera (field 'sensor.camera'), the calibration scenario has {cam.width}×{cam.height}"
            )
        if not run.samples:
            raise UserError(f"{path}: the run has no samples")
        without = [i for i, s in enumerate(run.samples) if s.get("pins_px") is None]
        if len(without) == len(run.samples):
            raise UserError(f"{path}: no sample has pins (field 'pins_px' is null in every one): nothing to fit")
        if without:  # a lab recording's missing frame: the tap happened, so it is replayed for the path
            shown = ", ".join(map(str, without[:5])) + (", …" if len(without) > 5 else "")
            without_pins.append(
                f"{path}: {len(without)} sample(s) without pins (samples {shown}: frames missing or unreadable), "
                "replayed for the sensor's path but not fitted"
            )
        recorded_pins = run.pins_px
        for i, s in enumerate(run.samples):  # a pin the tracker did not find holds its guess: not fitted
            if s.get("found") is not None:
                recorded_pins[i, ~np.asarray(s["found"], bool)] = np.nan
        pins.append(recorded_pins)
        group.extend(_group(recorded, s) for s in run.samples)
        run_index.extend([r] * len(run.samples))
        chunks.extend((r, c) for c in replay_chunks(run, recorded))
        records.append(run)
    group = np.array(group)
    data = Data(
        list(run_dirs),
        np.concatenate(pins),
        group,
        np.array(run_index),
        chunks,
        np.array([getattr(weights, g) for g in GROUPS])[group],
        unfinished=[n for n in (run.unfinished_note() for run in records) if n],
        records=records,
        without_pins=without_pins,
    )
    if still_replays:
        for r, run in enumerate(records):
            recorded = scenario_from_dict(run.meta["scenario"], str(run.path / "run.json"))
            if recorded.protocol.kind == "sheared_taps":
                still = recorded.with_changes(protocol=recorded.protocol.without_slides().model_dump())
                data.chunks.extend((len(records) + len(data.still_of), c) for c in replay_chunks(run, still))
                data.still_of.append(r)
    # pair each recorded sample with its simulated row by target pose (twin compare's pairing);
    # a still replay reaches the same poses
    for r, run in enumerate(records + [records[k] for k in data.still_of]):
        targets = [m.pose.as_array() for rr, c in data.chunks if rr == r for m in c if m.record]
        simulated = Run(run.path, run.meta, [{"target": t} for t in targets])
        pairs = dict(pair_samples(run, simulated))
        missing = [i for i in range(len(run.samples)) if i not in pairs]
        if missing:
            raise UserError(
                f"{run.path}: samples {missing[:5]} have target poses its protocol does not reach "
                "(an edited or foreign record)"
            )
        data.sim_index.append(np.array([pairs[i] for i in range(len(run.samples))]))
    return data
