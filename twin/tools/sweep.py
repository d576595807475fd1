"""Fidelity sweep: what accuracy costs in time (`twin bench sweep`, part of `twin bench`).

For each *setting* (one knob turned away from the default scenario: dome resolution, time
step, settle tolerance, render resolution, anti-aliasing, each effect on or off) the same
*probe* runs in one process, through `SimEnvironment` directly (no recording, no disk I/O,
so the stage timings are the simulation's own):

1. a reduced tap set on the rectangle's straight edge (the paper's §III-A2 protocol at
   fewer orientations): trains the paper's PCA + GP model (twin.sensing.perception);
2. a reduced multi-directional slide set (§III-C: the same orientations, 4 directions,
   8 samples per slide): the pins of these frames give the **pin error**, and the model
   trained in 1. predicts θ̂ and l̂ on them: the **perception error**;
3. closed-loop contour following of the rectangle (§III-D) with that model: the
   **contour error**. The loop is `twin.runs.contour.run_contour`'s, step for step, without
   the recorder (so no PNG writing lands in the timings); the metrics are computed by
   `twin.runs.contour.contour_metrics` itself.

Figures per setting (units in the column names; the CSV's columns are `CSV_COLUMNS`):

* time per frame (ms), split into physics (`env.move_to` into the frame: move +
  settle), render (`env.observe`: the frame, or the projection without `render`),
  tracking (`PinReader.read`) and perception (one single-frame
  `PerceptionModel.predict`); the sum is `total_ms`. CPU ms of one process (all its
  threads). Physics, render and tracking come from the **timing pass** (`time_settings`):
  after the parallel accuracy jobs, every setting replays the slide probe's first
  orientations alone on the machine, in rounds (each round every setting once), best of
  TIMING_REPEATS rounds; timed inside the parallel jobs instead, physics-identical
  settings spread over 12–18 ms. Each setting's time against the default's, best against
  best and the range of the ratio within one round, is in the `*_x_default` columns. Perception
  (≈ 1 ms, the same model size for every setting) is the accuracy job's mean. The
  accuracy jobs' wall-clock figures (every slide and contour frame, contention included)
  are in the `*_wall_ms` columns. Resets, lifts between slides and the tap probe are not
  timed.
* pin error (px RMS over all pins and slide frames, at 640×480 — pins of other
  resolutions are rescaled as `PerceptionModel` does): the setting's pins as the
  pipeline sees them (tracked from frames when rendering, projected otherwise) against
  the **reference setting's true pins** at the same commanded poses. Split into the
  physics part (the setting's true pins vs the reference's) and the tracking part (the
  setting's tracked pins vs its own true pins).
* settling error (px RMS over all pins and slide frames, at 640×480): the setting's true
  pins against the pins it was settling towards, settled on to convergence at the same
  frame (`SensorPhysics.converged_pins`; not timed, and the simulation then continues as
  if it had not happened). The pin error cannot see what a settle tolerance costs: ≈ 4 px
  of it is the coarse grid's discretisation, which hides the tenths of a px a settle
  tolerance leaves (README). Not measured (None) without contact.
* perception error on the slide probe: orientation RMS (deg, wrapped) and lateral RMS
  (mm) of the PCA + GP model trained on the setting's own tap probe.
* contour error on the rectangle: mean distance of the sensor path from the contour
  (mm), the contour's orientation RMS (deg), steps and how the run ended (loop closed,
  step limit, lost the contour, or out of the arm's reach: run_contour's stop rules).

The reference setting is the `reference` fidelity level with projected pins (no render:
exact pins, so its pin error is 0 by construction). The compliant dome's settings
(`compliant_*`, twin.world.dome.compliant) are measured against their own reference,
`compliant_reference`: the two models' pins are not one another's truth, so pin errors
are compared within a dome model only, while the θ and contour fronts (errors against
the true orientation and the true contour) place both models together. The compliant
skins (`compliant_membrane`, `compliant_shell`, `compliant_shell_held_65`) change the
material itself, so they have no pin error; their time, θ and contour figures are placed
as any other's.
**Pareto front** (primary): a setting is on it when no *peer* setting dominates it, i.e.
is no slower and no worse in every physics-accuracy figure (pin error *and* settling
error, `PRIMARY`) and better beyond the noise margins in time or in one of them
(`dominates`; in time, round by round of the timing pass: a setting that is faster in
one round and slower in another is neither); the θ and contour fronts weigh one figure
each against time. The contour
front places only the runs that complete the contour (`contour_completed_mm`): one that
loses it is no alternative, however fast.
Peers (`peers`) produce the same output from the same sensor:
* settings that render camera frames (and so exercise the tracker, as the real sensor
  does) are compared with each other, and settings with projected pins with each other.
  Projected pins skip the tracker and so always look "more accurate" than rendered ones,
  but rendering is there to exercise the tracker on camera frames, not to be accurate;
* rendered settings are compared only at the same camera resolution. The resolution is the
  simulated camera's spec (the real TacTip's is 640×480, and sim-vs-real comparisons and
  models trained on one run on the other need the same one), not a fidelity choice: a
  320×240 twin is faster because it simulates a different camera. The sweep still
  measures it, to show what a cheaper camera would cost in tracking error.
`on_front_all` ignores both splits.

A setting that fails (PhysicsError, LostPinsError, …) is reported with its error and
stage, counted in every output, and makes the command exit 1; the others still run.
"""
from __future__ import annotations

import csv
import json
import math
import os
import platform
import time
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from twin.world import gl
from twin.world.dome.compliant import SKIN_PHYSICS
from twin.world.dome.flex import FIDELITY_LEVELS
from twin.runs.record import Run
from twin.runs.runner import chunk_moves, chunk_samples
from twin.runs.sim_env import SimEnvironment
from twin.control.contour import ContourFollower
from twin.runs.contour import COMPLETED_STOPS, contour_metrics
from twin.world.scene import load_scenario_stimulus
from twin.sensing.perception import GPConfig, PerceptionModel, angle_error_deg
from twin.runs.protocols import protocol_moves
from twin.world.scene import dome_params
from twin.core.errors import UserError
from twin.runs.parallel import default_workers, map_ordered
import matplotlib
import matplotlib.pyplot as plt
import matplotlib.ticker
from twin.core.scenario import scenario_from_dict
from twin.core.sensor import CameraModel

if TYPE_CHECKING:
    from twin.core.scenario import Scenario

BASE_EFFECTS: tuple[str, ...] = ("contact", "friction", "render")
REFERENCE = "reference"
DEFAULT = "default"
#: Each dome model's accuracy reference (its reference level, exact projected pins): a
#: setting's pin error is measured against the reference of its own dome — the two models'
#: pins are not one another's truth, so their pin errors are never compared.
COMPLIANT_REFERENCE = "compliant_reference"
REFERENCES: dict[str, str] = {"flex": REFERENCE, "compliant": COMPLIANT_REFERENCE}
#: Accuracy columns measured against the dome's own reference (compared within a dome only).
PIN_METRICS: tuple[str, ...] = ("pin_rms_px", "pin_physics_rms_px", "pin_settling_rms_px")
#: pareto.png's marker per dome model
DOME_MARKERS: dict[str, str] = {"flex": "o", "compliant": "^"}
#: Reference camera resolution (W, H) px: pin errors are expressed at this resolution.
REFERENCE_RESOLUTION = (640, 480)
#: The timing pass (`time_settings`): best of this many rounds (full, quick sweep), after
#: an untimed one, over the slide probe's first TIMING_ORIENTATIONS orientations.
TIMING_REPEATS = (3, 2)
TIMING_ORIENTATIONS = 2
#: Noise margins of the Pareto dominance test: relative time, relative and absolute error.
TIME_MARGIN = 0.05
ERROR_MARGIN_REL = 0.02
#: pin_settling_rms_px: the smallest settling difference that changes anything downstream.
#: The measure itself resolves ≈ 0.01 px (halving converged_pins' band moved it by
#: 0.003–0.010 px), but below 0.05 px a settle tolerance is invisible: the tracker reads
#: rendered pins to 0.08 px RMS, the pin error against the reference is ≈ 2 px either way
#: (2.14 px at the default 0.1 px band and at 0.05 px), and a frictionless slide ends
#: 9 / 13 / 18 µm (≈ 0.1–0.2 px) from the static press at settle 0.025 / 0.05 / 0.1 px
#: (tests/test_dome.py asks < 20 µm). Settle ×2 (0.28 vs 0.12 px) stays distinguishable.
ERROR_MARGIN_ABS = {"pin_rms_px": 0.02, "pin_settling_rms_px": 0.05, "theta_rms_deg": 0.5,
                    "contour_completed_mm": 0.1}


# ----------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class Setting:
    """One point of the sweep: the default scenario with one knob turned.

    name: short id (CSV `setting`); knob: which knob it turns (groups the table).
    fidelity: the dome model's fidelity level (twin.world.dome.flex.FIDELITY_LEVELS or
    twin.world.dome.compliant.COMPLIANT_LEVELS). physics: scenario `physics` overrides
    (cellcount [i, j, k], timestep_s s, settle_px px, surface_spacing_mm mm, skin_spacing_mm mm,
    gel_enclosed, increment_mm mm, …; twin.core.scenario.PhysicsOverrides). dome: the scenario's dome model ('flex' or 'compliant').
    effects: scenario effects. camera: scenario `sensor.camera` overrides (width px,
    height px, msaa samples, noise_std grey levels). note: what the setting shows.
    pins_comparable: False where the setting changes the dome's material model (a skin over
    the compliant gel): its pins are then not an approximation of its dome's reference, and
    it gets no pin error (its time, θ, l and contour figures stand).
    """

    name: str
    knob: str
    fidelity: str = "default"
    physics: dict = field(default_factory=dict)
    effects: tuple[str, ...] = BASE_EFFECTS
    camera: dict = field(default_factory=dict)
    note: str = ""
    dome: str = "flex"
    pins_comparable: bool = True

    @property
    def renders(self) -> bool:
        return "render" in self.effects

    @property
    def output(self) -> str:
        """Output kind: 'frames' (rendered and tracked) or 'pins' (projected)."""
        return "frames" if self.renders else "pins"

    def scenario(self, protocol: dict, seed: int = 0) -> Scenario:
        """The scenario of this setting on the rectangle with `protocol` (a protocol dict)."""

        data = {"name": f"sweep_{self.name}", "object": {"name": "rectangle"}, "dome": self.dome,
                "placement": {"position_mm": [400, 0], "yaw_deg": 0}, "fidelity": self.fidelity,
                "physics": dict(self.physics), "effects": list(self.effects),
                "sensor": {"camera": dict(self.camera)}, "seed": seed, "protocol": protocol}
        return scenario_from_dict(data, f"<sweep setting {self.name}>")


def _default_settle_px() -> float:

    return FIDELITY_LEVELS["default"].settle_px


def full_settings() -> list[Setting]:
    """Every knob that matters, one at a time (the reference first: it runs longest).

    The time steps 0.01 / 0.04 s bracket the default 0.02 s (twin.world.dome.flex notes 0.04 s
    oscillating on the flower's slivers; the probe's rectangle has none)."""
    no_render = ("contact", "friction")
    s0 = _default_settle_px()
    return [
        Setting(REFERENCE, "reference", "reference", effects=no_render,
                note="reference fidelity, exact projected pins: the accuracy reference"),
        Setting("reference_render", "fidelity", "reference", note="reference physics, rendered and tracked"),
        Setting("fast", "fidelity", "fast"),
        Setting(DEFAULT, "default", "default", note="the shipped defaults (fidelity default, 640×480, no MSAA)"),
        Setting("dt_0.01", "time step", physics={"timestep_s": 0.01}),
        Setting("dt_0.04", "time step", physics={"timestep_s": 0.04}),
        Setting("settle_x0.5", "settle tolerance", physics={"settle_px": s0 * 0.5}),
        Setting("settle_x2", "settle tolerance", physics={"settle_px": s0 * 2.0}),
        Setting("grid_3x3x2", "dome resolution", physics={"cellcount": [3, 3, 2]}),
        Setting("grid_5x5x2", "dome resolution", physics={"cellcount": [5, 5, 2]}),
        Setting("skin_off", "skin layer", physics={"skin_spacing_mm": 0.0}, note="no sub-grid skin layer (twin.world.dome.skin)"),
        Setting("skin_1mm", "skin layer", physics={"skin_spacing_mm": 1.0}),
        Setting("membrane_off", "skin membrane", physics={"membrane_young_mpa": 0.0}, note="gel only (twin.world.dome.flex)"),
        Setting("render_off", "render", effects=no_render, note="pins projected, no frames"),
        Setting("fast_render_off", "render", "fast", effects=no_render, note="fast physics, pins projected"),
        Setting("cam_320x240", "render resolution", camera={"width": 320, "height": 240}),
        Setting("cam_1280x960", "render resolution", camera={"width": 1280, "height": 960}),
        Setting("msaa_4", "anti-aliasing", camera={"msaa": 4}),
        Setting("lighting", "effect", effects=BASE_EFFECTS + ("lighting",)),
        Setting("camera_noise", "effect", effects=BASE_EFFECTS + ("camera_noise",)),
        Setting("friction_off", "effect", effects=("contact", "render"), note="no shear"),
        Setting("arm_dynamics", "effect", effects=BASE_EFFECTS + ("arm_dynamics",)),
        # the compliant dome (twin.world.dome.compliant): its levels and effects, pin errors
        # against its own reference
        Setting(COMPLIANT_REFERENCE, "compliant dome", "reference", effects=no_render, dome="compliant",
                note="compliant reference level (1 mm nodes, 0.25 mm increments), exact projected pins: its accuracy reference"),
        Setting("compliant_fast", "compliant dome", "fast", dome="compliant", note="2.5 mm nodes, 1 mm increments"),
        Setting("compliant_default", "compliant dome", "default", dome="compliant", note="1.5 mm nodes, 0.5 mm increments"),
        Setting("compliant_render_off", "compliant dome", "default", effects=no_render, dome="compliant",
                note="compliant, pins projected"),
        Setting("compliant_friction_off", "compliant dome", "default", effects=("contact", "render"), dome="compliant",
                note="compliant, no tangential problem"),
        Setting("compliant_open_gel", "compliant dome", "default", physics={"gel_enclosed": False}, dome="compliant",
                note="compliant, the gel as an open half-space (not sealed)"),
        Setting("compliant_increment_1mm", "compliant increment", "default", physics={"increment_mm": 1.0},
                dome="compliant", note="compliant, 1.5 mm nodes, 1 mm increments (the default's are 0.5 mm)"),
        Setting("compliant_membrane", "compliant skin", "default", physics=SKIN_PHYSICS["membrane"], dome="compliant",
                pins_comparable=False, note="compliant, the skin as a membrane over a softer gel (no pin error: "
                "another material than compliant_reference)"),
        Setting("compliant_shell", "compliant skin", "default", physics=SKIN_PHYSICS["shell"], dome="compliant",
                pins_comparable=False, note="compliant, the skin as a thin shell over a softer gel (no pin error: "
                "another material than compliant_reference)"),
        Setting("compliant_shell_held_65", "compliant skin", "default", physics=SKIN_PHYSICS["shell_held_65"],
                dome="compliant", pins_comparable=False, note="compliant, the thin shell held by the base at the "
                "cap's rim, 65° (no pin error: another material than compliant_reference)"),
    ]


def quick_settings() -> list[Setting]:
    """The smoke check's five: reference, fast, default, default with projected pins, default with 4× MSAA."""
    by_name = {s.name: s for s in full_settings()}
    return [by_name[n] for n in (REFERENCE, "fast", DEFAULT, "render_off", "msaa_4")]


# ----------------------------------------------------------------------------- probe


@dataclass(frozen=True)
class Probe:
    """What every setting runs (on the rectangle's +x edge, as the paper's data sets).

    tap_orientations_deg: sensor orientations θ of the tap (training) probe (deg).
    slide_orientations_deg: orientations of the slide (test) probe (deg).
    directions_deg: sliding directions (deg; 0 = onto the object, 90 = along the edge).
    lateral_mm: lateral positions of taps and slide samples (mm, +9.9 off the object).
    tap_depths_mm: tap depths (mm); slide_depth_mm: slide depth (mm).
    contour_max_steps: step limit of the contour run (the rectangle's loop closes after
      ≈ 130 steps of 3 mm).
    gp_restarts: hyperparameter restarts of each GP fit.
    """

    tap_orientations_deg: tuple[float, ...]
    slide_orientations_deg: tuple[float, ...]
    directions_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)
    lateral_mm: tuple[float, ...] = (9.9, 6.0, 4.0, 2.0, 0.0, -2.0, -4.0, -6.0)
    tap_depths_mm: tuple[float, ...] = (2.0, 4.0)
    slide_depth_mm: float = 3.0
    contour_max_steps: int = 220
    gp_restarts: int = 2

    def taps(self) -> dict:
        return {"kind": "taps", "orientations_deg": list(self.tap_orientations_deg), "lateral_mm": list(self.lateral_mm),
                "depths_mm": list(self.tap_depths_mm), "edge_point_mm": [60, 0], "edge_normal_deg": 0}

    def slides(self) -> dict:
        return {"kind": "slides", "orientations_deg": list(self.slide_orientations_deg),
                "directions_deg": list(self.directions_deg), "lateral_mm": list(self.lateral_mm),
                "depth_mm": self.slide_depth_mm, "edge_point_mm": [60, 0], "edge_normal_deg": 0}

    def contour(self) -> dict:
        return {"kind": "contour", "depth_mm": 3, "step_mm": 3, "gain": 0.35, "lateral_target_mm": 0,
                "orientation_deg": 0, "max_steps": self.contour_max_steps, "controller": "paper"}


#: Full sweep: θ every 40° (9 orientations): 144 taps, 288 slide frames, the whole loop.
FULL_PROBE = Probe(tap_orientations_deg=tuple(float(a) for a in range(-160, 181, 40)),
                   slide_orientations_deg=tuple(float(a) for a in range(-160, 181, 40)))
#: Quick sweep (smoke check): θ every 90° for training (64 taps), 2 of them for testing
#: (64 slide frames), 20 contour steps (60 mm along the first edge).
QUICK_PROBE = Probe(tap_orientations_deg=(-90.0, 0.0, 90.0, 180.0), slide_orientations_deg=(0.0, 90.0),
                    contour_max_steps=20, gp_restarts=0)


# ----------------------------------------------------------------------------- one setting


def _rescale_pins(pins_px: np.ndarray, width: int) -> np.ndarray:
    """Pins (px) at image width `width` → px at REFERENCE_RESOLUTION (pixel centres at integers)."""
    if int(width) == REFERENCE_RESOLUTION[0]:
        return np.asarray(pins_px, float)
    return CameraModel(*REFERENCE_RESOLUTION).rescale_px(pins_px, width)


STAGES: tuple[str, ...] = ("physics", "render", "track", "perception")


class _Stages:
    """Per-stage clocks of one setting's probe: CPU time of this process (all its threads:
    MuJoCo, the GL rasteriser, BLAS) and wall time, accumulated over the timed frames.

    CPU time, unlike wall time, does not grow with the number of runnable processes
    (13.7 vs 13.9 ms physics per frame with and without two busy processes beside it,
    when the wall time went from 13.9 to 20.8 ms), but on this VM it still varies with
    what runs beside it (cache and host contention), hence the sweep's timing pass.
    """

    def __init__(self) -> None:
        self.cpu = dict.fromkeys(STAGES, 0.0)
        self.wall = dict.fromkeys(STAGES, 0.0)
        self.calls = dict.fromkeys(STAGES, 0)

    @contextmanager
    def clock(self, stage: str) -> Iterator[None]:
        """Charge the time spent in the block to `stage` (one call)."""
        w, c = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.cpu[stage] += time.process_time() - c
            self.wall[stage] += time.perf_counter() - w
            self.calls[stage] += 1

    @property
    def frames(self) -> int:
        return self.calls["render"]

    def ms_per_frame(self) -> dict[str, float]:
        """{stage}_ms (CPU) and {stage}_wall_ms per call of that stage (ms; NaN if none)."""
        out = {}
        for k in STAGES:
            n = self.calls[k]
            out[f"{k}_ms"] = 1e3 * self.cpu[k] / n if n else float("nan")
            out[f"{k}_wall_ms"] = 1e3 * self.wall[k] / n if n else float("nan")
        return out


class _NoClock(_Stages):
    """Stages that are not timed (the tap probe)."""

    @contextmanager
    def clock(self, stage: str) -> Iterator[None]:
        yield


def _open_loop(env, moves, stages: _Stages, settling: bool = False) -> dict:
    """Run protocol moves chunk by chunk (a reset per orientation, as twin.runs.runner does).

    Timed per recorded frame: the move into it (physics: move + settle), observe (render;
    with projected pins the projection), the tracker (track). Lifts and traverses out of
    contact between slides are not charged to any frame. Returns pins (N, 127, 2) px as
    the pipeline sees them, truth (N, 127, 2) px exact, found (N, 127) bool (all True when
    projected), labels (list of dicts) and converged: with `settling` on a simulated
    environment, the pins each frame was settling towards ((N, 127, 2) px, projected as
    truth; `SensorPhysics.converged_pins`, untimed), else None."""

    settling = settling and isinstance(env, SimEnvironment)
    pins, truth, found, labels, converged = [], [], [], [], []
    for chunk in chunk_moves(moves):
        for sample in chunk_samples(env, chunk, stages.clock):
            obs, p, f, move = sample.observation, sample.pins_px, sample.found, sample.move
            pins.append(np.asarray(p, float))
            truth.append(np.asarray(obs.truth["pins_px"], float))
            found.append(np.ones(len(p), bool) if f is None else np.asarray(f, bool))
            labels.append(move.labels)
            if settling:
                converged.append(env.converged_pins_px())
    return {"pins": np.array(pins), "truth": np.array(truth), "found": np.array(found), "labels": labels,
            "converged": np.array(converged) if settling else None}


def _contour(env, scenario, model, stages: _Stages) -> dict:
    """Contour following of the scenario's object with twin.control.contour.ContourFollower (the
    same loop and stop rules as `twin run`, without the recorder); returns
    twin.runs.contour.contour_metrics of the steps."""

    stimulus = load_scenario_stimulus(scenario)
    follower = ContourFollower(env, scenario, model, stimulus, clock=stages.clock)
    samples = [{"pose": [float(v) for v in step.observation.pose.as_array()], "time": float(step.observation.time),
                "labels": step.labels} for step in follower]
    run = Run(Path(f"<sweep {scenario.name}>"), {"status": "completed", "stop_reason": follower.stop_reason}, samples)
    return contour_metrics(run, stimulus)


def probe_setting(setting: Setting, probe: Probe, seed: int = 0) -> dict:
    """Run the probe for one setting in this process (one job of the sweep).

    Returns a dict: `row` (the setting's figures, see module doc; pin errors are filled in
    by `run_sweep`, which needs the reference's pins), `slide_pins_px` and
    `slide_truth_px` ((N, 127, 2) px at REFERENCE_RESOLUTION, None if the slide probe did
    not finish). A failure is caught, recorded in row["status"] = "failed", row["stage"]
    and row["error"], and the figures measured before it are kept.
    """

    wall0 = time.perf_counter()
    row: dict = {"setting": setting.name, "knob": setting.knob, "output": setting.output, "dome": setting.dome,
                 "fidelity": setting.fidelity,
                 "effects": "+".join(setting.effects), "status": "ok", "stage": "", "error": "", "note": setting.note}
    out: dict = {"row": row, "slide_pins_px": None, "slide_truth_px": None}
    stage = "build"
    env = None
    stages = _Stages()
    try:
        scenario = setting.scenario(probe.contour(), seed)
        params = dome_params(scenario)
        cam = scenario.sensor.camera
        if scenario.dome == "compliant":  # quasi-static: no time step, nothing to settle
            resolution = {"cellcount": f"{params.spacing * 1e3:g} mm nodes", "timestep_s": None, "settle_px": None}
        else:
            resolution = {"cellcount": "x".join(str(c) for c in params.cellcount), "timestep_s": params.timestep,
                          "settle_px": params.settle_px}
        row.update({**resolution, "camera": f"{cam.width}x{cam.height}" if setting.renders else "—",
                    "msaa": cam.msaa if setting.renders else 0, "effects": "+".join(scenario.effects)})
        env = SimEnvironment(scenario, seed=seed)
        stage = "taps"
        taps = _open_loop(env, protocol_moves(setting.scenario(probe.taps(), seed).protocol), _NoClock())
        row["n_taps"] = len(taps["labels"])
        stage = "train"
        t0 = time.perf_counter()
        lab = {k: np.array([x[k] for x in taps["labels"]], float) for k in ("theta_deg", "lateral_mm", "depth_mm")}
        model = PerceptionModel(gp=GPConfig(n_restarts=probe.gp_restarts))
        model.fit(taps["pins"], lab["theta_deg"], lab["lateral_mm"], lab["depth_mm"], np.random.default_rng(seed),
                  resolution=(cam.width, cam.height))
        row["train_s"] = time.perf_counter() - t0
        stage = "slides"
        slides = _open_loop(env, protocol_moves(setting.scenario(probe.slides(), seed).protocol), stages,
                            settling=scenario.has("contact"))
        row["n_slide_frames"] = len(slides["labels"])
        out["slide_pins_px"] = _rescale_pins(slides["pins"], cam.width)
        out["slide_truth_px"] = _rescale_pins(slides["truth"], cam.width)
        row["pin_tracking_rms_px"] = _rms_px(out["slide_pins_px"], out["slide_truth_px"])
        if slides["converged"] is not None:
            row["pin_settling_rms_px"] = _rms_px(out["slide_truth_px"], _rescale_pins(slides["converged"], cam.width))
        stage = "perception"
        theta_hat, lat_hat = [], []
        resolution = (cam.width, cam.height)
        for pins, found in zip(slides["pins"], slides["found"]):
            with stages.clock("perception"):  # one frame at a time, as in the closed loop
                pred = model.predict(pins, found, resolution=resolution)
            theta_hat.append(pred.theta_deg[0])
            lat_hat.append(pred.lateral_mm[0])
        theta = np.array([x["theta_deg"] for x in slides["labels"]], float)
        lateral = np.array([x["lateral_mm"] for x in slides["labels"]], float)
        row["theta_rms_deg"] = float(np.sqrt(np.mean(angle_error_deg(np.array(theta_hat), theta) ** 2)))
        row["lateral_rms_mm"] = float(np.sqrt(np.mean((np.array(lat_hat) - lateral) ** 2)))
        stage = "contour"
        metrics = _contour(env, scenario, model, stages)
        row["contour_path_mean_mm"] = metrics["path_distance_mean_mm"]
        row["contour_path_max_mm"] = metrics["path_distance_max_mm"]
        row["contour_orientation_rms_deg"] = metrics["orientation_rms_deg"]
        row["contour_steps"] = metrics["steps"]
        row["contour_stop"] = metrics["stop_reason"]
        row["contour_coverage"] = metrics["coverage"]
    except Exception as err:  # recorded, counted and reported; never hidden (module doc)
        row["status"] = "failed"
        row["stage"] = stage
        row["error"] = " | ".join(line.strip() for line in f"{type(err).__name__}: {err}".splitlines())[:400]
        row["traceback"] = traceback.format_exc(limit=6)
    finally:
        if env is not None:
            env.close()
    row["n_timed_frames"] = stages.frames
    row.update(stages.ms_per_frame())
    row["total_ms"] = float(sum(row[f"{k}_ms"] for k in STAGES))
    row["total_wall_ms"] = float(sum(row[f"{k}_wall_ms"] for k in STAGES))
    row["wall_s"] = time.perf_counter() - wall0
    return out


TIMED_STAGES: tuple[str, ...] = ("physics", "render", "track")


def timing_pass(setting: Setting, probe: Probe, seed: int = 0) -> dict:
    """{physics,render,track}_ms (CPU ms per frame) and n_timed_frames of one pass of
    `setting` over the timing probe (the slide probe's first TIMING_ORIENTATIONS
    orientations) on a fresh environment."""
    timing = replace(probe, slide_orientations_deg=probe.slide_orientations_deg[:TIMING_ORIENTATIONS])
    moves = protocol_moves(setting.scenario(timing.slides(), seed).protocol)
    env = SimEnvironment(setting.scenario(timing.contour(), seed), seed=seed)
    stages = _Stages()
    try:
        _open_loop(env, moves, stages)
    finally:
        env.close()
    per_frame = stages.ms_per_frame()
    return {**{f"{k}_ms": per_frame[f"{k}_ms"] for k in TIMED_STAGES}, "n_timed_frames": stages.calls["physics"]}


def time_settings(settings: list[Setting], rows: list[dict], probe: Probe, seed: int = 0,
                  repeats: int = TIMING_REPEATS[0], verbose: bool = False) -> None:
    """The timing pass, into `rows` (one per setting; those not "ok" are skipped). After
    the parallel accuracy jobs, in this one process, so that no other job competes for
    the cores (timed inside the parallel jobs, physics-identical settings spread over
    12–18 ms per frame). In rounds: an untimed round (each dome model's first run in a
    process loads what it caches: influence matrices, compiled kernels, GL contexts), then
    `repeats` rounds, each running every setting once (`timing_pass`), so that a host that
    speeds up or slows down during the pass moves every setting alike. Sets each stage's
    best (min over rounds) as {stage}_ms, n_timed_frames, each round's physics + render +
    tracking as round_ms (what `dominates` compares round by round), and against the default in the
    same run (NaN without it): time_x_default (physics + render + tracking, best against
    best), physics_x_default, and each one's lowest and highest ratio within one round
    (`*_x_default_min`, `*_x_default_max`: how far one run's ratio can be trusted). A
    setting whose pass raises is recorded as failed in the "timing" stage."""
    live = [i for i, r in enumerate(rows) if r["status"] == "ok"]
    passes: dict[int, list[dict]] = {i: [] for i in live}
    for round_ in range(-1, repeats):  # round −1 untimed
        for i in live:
            if rows[i]["status"] != "ok":
                continue
            try:
                result = timing_pass(settings[i], probe, seed)
            except Exception as err:  # recorded like a failed probe (module doc)
                rows[i].update(status="failed", stage="timing", error=f"{type(err).__name__}: {err}"[:400])
                continue
            if round_ >= 0:
                passes[i].append(result)
        if verbose and round_ >= 0:
            print(f"[timing round {round_ + 1}/{repeats}] done", flush=True)
    names = [s.name for s in settings]
    default = names.index(DEFAULT) if DEFAULT in names and rows[names.index(DEFAULT)]["status"] == "ok" else None

    def per_round(i: int, stages: tuple[str, ...]) -> np.ndarray:
        return np.array([sum(p[f"{k}_ms"] for k in stages) for p in passes[i]])

    for i in live:
        row = rows[i]
        if row["status"] != "ok":
            continue
        for key in TIMED_STAGES:
            row[f"{key}_ms"] = min(p[f"{key}_ms"] for p in passes[i])
        row["n_timed_frames"] = passes[i][0]["n_timed_frames"]
        row["total_ms"] = float(sum(row[f"{k}_ms"] for k in STAGES))
        row["round_ms"] = [float(t) for t in per_round(i, TIMED_STAGES)]
        for name, stages in (("time", TIMED_STAGES), ("physics", ("physics",))):
            if default is None:
                row[f"{name}_x_default"] = row[f"{name}_x_default_min"] = row[f"{name}_x_default_max"] = math.nan
                continue
            mine, theirs = per_round(i, stages), per_round(default, stages)
            row[f"{name}_x_default"] = float(mine.min() / theirs.min())
            row[f"{name}_x_default_min"], row[f"{name}_x_default_max"] = (float((mine / theirs).min()),
                                                                          float((mine / theirs).max()))
        if verbose:
            print(f"[timing] {row['setting']:18s} {row['total_ms']:7.1f} ms/frame  ×{row['time_x_default']:.2f} "
                  f"of the default ({row['time_x_default_min']:.2f}–{row['time_x_default_max']:.2f} within a round)",
                  flush=True)


def _rms_px(a: np.ndarray, b: np.ndarray) -> float:
    """RMS pin distance (px) over all frames and pins of two (N, 127, 2) arrays."""
    return float(np.sqrt(np.mean(np.sum((np.asarray(a) - np.asarray(b)) ** 2, axis=-1))))


# ----------------------------------------------------------------------------- the sweep


#: The Pareto fronts: (row flag, accuracy columns weighed together against time). The first
#: is the primary front; its columns (`PRIMARY`) are every physics-accuracy figure.
FRONTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("on_front", ("pin_rms_px", "pin_settling_rms_px")),
    ("on_front_theta", ("theta_rms_deg",)),
    ("on_front_contour", ("contour_completed_mm",)),
)
PRIMARY: tuple[str, ...] = FRONTS[0][1]
#: Axis labels of the accuracy columns (pareto.png: one panel per column of FRONTS).
METRIC_LABELS: dict[str, str] = {
    "pin_rms_px": "pin error (px RMS)",
    "pin_settling_rms_px": "settling error (px RMS)",
    "theta_rms_deg": "orientation error on the slides (deg RMS)",
    "contour_completed_mm": "contour error on the rectangle, completed runs (mm, mean)",
}

#: Column order of the CSV (everything a row can hold; missing values are blank).
CSV_COLUMNS: tuple[str, ...] = (
    "setting", "knob", "output", "dome", "fidelity", "cellcount", "timestep_s", "settle_px", "camera", "msaa", "effects",
    "status", "stage", "error",
    "physics_ms", "render_ms", "track_ms", "perception_ms", "total_ms",
    "time_x_default", "time_x_default_min", "time_x_default_max",
    "physics_x_default", "physics_x_default_min", "physics_x_default_max",
    "physics_wall_ms", "render_wall_ms", "track_wall_ms", "perception_wall_ms", "total_wall_ms",
    "pin_rms_px", "pin_physics_rms_px", "pin_tracking_rms_px", "pin_settling_rms_px", "theta_rms_deg",
    "lateral_rms_mm",
    "contour_path_mean_mm", "contour_completed_mm", "contour_path_max_mm", "contour_orientation_rms_deg",
    "contour_steps", "contour_stop",
    "contour_coverage", "on_front", "dominated_by", "on_front_theta", "on_front_contour", "on_front_all",
    "n_taps", "n_slide_frames", "n_timed_frames", "train_s", "wall_s", "note",
)


def _metric_tuple(metrics: str | tuple[str, ...]) -> tuple[str, ...]:
    return (metrics,) if isinstance(metrics, str) else tuple(metrics)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def dominates(a: dict, b: dict, metrics: str | tuple[str, ...] = PRIMARY) -> bool:
    """True when setting `a` is clearly better than `b` in total_ms and the error column(s)
    `metrics`: no slower and no less accurate in *every* one within the noise margins, and
    better beyond them in at least one.

    Margins: TIME_MARGIN (relative) on time; on an error the larger of ERROR_MARGIN_REL
    (relative) and ERROR_MARGIN_ABS[column] (absolute, the column's unit). Time: where
    both rows have the timing pass's rounds (`round_ms`), `a` is no slower only if it is
    within the margin in every round, and faster only if it is faster beyond it in every
    round, each round against the other setting's same round (`_time_ratios`); otherwise
    best against best. A column neither row has (a sweep.json from before it existed) is
    left out; one that only one row has makes them incomparable (False)."""
    ta, tb = a.get("total_ms"), b.get("total_ms")
    if not (_finite(ta) and _finite(tb)):
        return False
    slowest = max(_time_ratios(a, b))
    no_worse, better, compared = slowest <= 1 + TIME_MARGIN, slowest < 1 - TIME_MARGIN, False
    for metric in _metric_tuple(metrics):
        ea, eb = a.get(metric), b.get(metric)
        if ea is None and eb is None:
            continue
        if not (_finite(ea) and _finite(eb)):
            return False
        e_tol = max(ERROR_MARGIN_REL * abs(eb), ERROR_MARGIN_ABS.get(metric, 0.0))
        no_worse = no_worse and ea <= eb + e_tol
        better = better or ea < eb - e_tol
        compared = True
    return compared and no_worse and better


def _time_ratios(a: dict, b: dict) -> list[float]:
    """`a`'s time over `b`'s: per round of the timing pass where both rows have the same
    rounds (`round_ms`: the host's drift between rounds moves both alike, so only a
    difference that holds in every round is the settings'), else total_ms against
    total_ms. On the sweep's host one setting's ratio to the default spread over
    0.87–1.24 across three rounds, far more than TIME_MARGIN: best against best alone
    then let a setting doing strictly more work per frame dominate the default."""
    ra, rb = a.get("round_ms"), b.get("round_ms")
    if isinstance(ra, list) and isinstance(rb, list) and ra and len(ra) == len(rb):
        return [x / y for x, y in zip(ra, rb)]
    return [a["total_ms"] / b["total_ms"]]


def pareto_flags(rows: list[dict], metrics: str | tuple[str, ...] = PRIMARY,
                 by_output: bool = True) -> list[bool | None]:
    """Per row: on the front of total_ms against the error column(s) `metrics` (`dominates`)
    (None: a failed row, or no time or first-column figure; failed settings are no
    alternative, so they neither sit on a front nor push others off).

    by_output: compare only peer rows (`peers`: same output kind and camera); pin metrics
    always compare rows of one dome only."""
    first = _metric_tuple(metrics)[0]
    flags: list[bool | None] = []
    ok = [r for r in rows if r.get("status") == "ok"]
    for b in rows:
        if b.get("status") != "ok" or not (_finite(b.get("total_ms")) and _finite(b.get(first))):
            flags.append(None)
            continue
        rivals = [a for a in ok if a is not b
                  and (peers(a, b, metrics) if by_output else _same_dome_if_pins(a, b, metrics))]
        flags.append(not any(dominates(a, b, metrics) for a in rivals))
    return flags


def peers(a: dict, b: dict, metrics: str | tuple[str, ...] = PRIMARY) -> bool:
    """Whether two rows compete on the front of `metrics`: same output kind ('frames' or
    'pins') and, for frames, the same camera resolution (module docstring); for a pin
    metric (PIN_METRICS, measured against each dome's own reference) also the same dome."""
    return a["output"] == b["output"] and a.get("camera") == b.get("camera") and _same_dome_if_pins(a, b, metrics)


def _same_dome_if_pins(a: dict, b: dict, metrics: str | tuple[str, ...]) -> bool:
    """Pin metrics compare rows of one dome only (PIN_METRICS); other metrics any two rows."""
    pin = any(m in PIN_METRICS for m in _metric_tuple(metrics))
    return not pin or a.get("dome", "flex") == b.get("dome", "flex")


def dominators(rows: list[dict], row: dict, metrics: str | tuple[str, ...] = PRIMARY) -> list[str]:
    """Names of the ok peer settings (`peers`) that dominate `row` in total_ms and `metrics`."""
    return [a["setting"] for a in rows if a is not row and a.get("status") == "ok" and peers(a, row, metrics)
            and dominates(a, row, metrics)]


def run_sweep(out: Path, quick: bool = False, workers: int | None = None, cluster: str | None = None,
              settings: list[Setting] | None = None, probe: Probe | None = None, seed: int = 0,
              verbose: bool = True) -> list[dict]:
    """Run the sweep, write sweep.csv, sweep.json, sweep.md and pareto.png to `out`.

    quick: the QUICK_PROBE over quick_settings() (smoke check, < 2 min on 2 cores).
    workers / cluster: as twin.runs.parallel.map_ordered (default: all local cores); one
      accuracy job per setting. The timing pass then runs here, one setting at a time
      (`time_settings`; on a cluster too, so that every time is from the same machine).
    Returns the rows (dicts with the CSV_COLUMNS keys present).
    """

    settings = settings if settings is not None else (quick_settings() if quick else full_settings())
    probe = probe if probe is not None else (QUICK_PROBE if quick else FULL_PROBE)
    names = [s.name for s in settings]
    for dome in sorted({s.dome for s in settings}):
        if REFERENCES[dome] not in names:
            raise UserError(f"the sweep needs the {REFERENCES[dome]!r} setting: the pin error of every {dome} "
                            "setting is measured against it")
    if len(set(names)) != len(names):
        raise UserError(f"sweep settings need distinct names, got {names}")
    n_workers = 1 if cluster is None and workers == 1 else (workers or default_workers())
    wall0 = time.perf_counter()
    results: list[dict] = []
    for i, result in enumerate(map_ordered(probe_setting, [(s, probe, seed) for s in settings],
                                           workers=workers, cluster=cluster)):
        results.append(result)
        r = result["row"]
        if verbose:
            state = "ok" if r["status"] == "ok" else f"FAILED in {r['stage']}: {r['error']}"
            print(f"[{i + 1}/{len(settings)}] {r['setting']:18s} {r.get('total_ms', float('nan')):7.1f} ms/frame  "
                  f"{r['wall_s']:6.1f} s  {state}", flush=True)
    rows = [r["row"] for r in results]
    repeats = TIMING_REPEATS[1] if quick else TIMING_REPEATS[0]
    time_settings(settings, rows, probe, seed, repeats, verbose)
    wall = time.perf_counter() - wall0
    for setting, result in zip(settings, results):
        row = result["row"]
        ref_truth = results[names.index(REFERENCES[setting.dome])]["slide_truth_px"]
        pins = result["slide_pins_px"]
        if setting.pins_comparable and ref_truth is not None and pins is not None and len(pins) == len(ref_truth):
            row["pin_rms_px"] = _rms_px(pins, ref_truth)
            row["pin_physics_rms_px"] = _rms_px(result["slide_truth_px"], ref_truth)
    annotate_fronts(rows)
    meta = {
        "quick": quick, "probe": asdict(probe), "seed": seed, "workers": n_workers if cluster is None else f"ray {cluster}",
        "wall_s": wall, "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.python_version()}",
        "gl": gl.GL_BACKEND, "failures": [f"{r['setting']} ({r['stage']}): {r['error']}" for r in rows if r["status"] != "ok"],
        "reference": REFERENCE, "references": {d: r for d, r in REFERENCES.items() if r in names},
        "default": DEFAULT if DEFAULT in names else None,
        "timing": {"repeats": repeats, "orientations_deg": list(probe.slide_orientations_deg[:TIMING_ORIENTATIONS])},
        "date": time.strftime("%Y-%m-%d"),
    }
    write_outputs(rows, meta, Path(out), verbose=verbose)
    return rows


def annotate_fronts(rows: list[dict]) -> list[dict]:
    """Set on_front / on_front_theta / on_front_contour (FRONTS, per output kind),
    on_front_all (PRIMARY, all kinds together) and dominated_by (primary front) on every row,
    and the contour front's figure, contour_completed_mm: the contour error of a run that
    completed the contour (COMPLETED_STOPS), infinite for one that did not, which is no
    alternative however fast."""
    for row in rows:
        if _finite(row.get("contour_path_mean_mm")):
            completed = row.get("contour_stop") in COMPLETED_STOPS
            row["contour_completed_mm"] = row["contour_path_mean_mm"] if completed else math.inf
    for key, metrics in FRONTS:
        for row, flag in zip(rows, pareto_flags(rows, metrics)):
            row[key] = flag
    for row, flag in zip(rows, pareto_flags(rows, PRIMARY, by_output=False)):
        row["on_front_all"] = flag
    for row in rows:
        row["dominated_by"] = " ".join(dominators(rows, row)) if row.get("on_front") is False else ""
    return rows


def write_outputs(rows: list[dict], meta: dict, out: Path, verbose: bool = False) -> None:
    """Write sweep.csv, sweep.json ({"meta", "rows"}; non-finite numbers as null),
    pareto.png and sweep.md to `out`. To redraw a finished sweep (e.g. with other margins):
    data = json.load(open("sweep.json")); write_outputs(annotate_fronts(data["rows"]), data["meta"], out)."""
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / "sweep.csv")
    clean = [{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()} for r in rows]
    (out / "sweep.json").write_text(json.dumps({"meta": meta, "rows": clean}, indent=1, default=_json_default))
    plot_pareto(rows, out / "pareto.png")
    (out / "sweep.md").write_text(markdown_table(rows, meta))
    if verbose:
        print()
        print(markdown_table(rows, meta))
        print(f"wrote {out / 'sweep.csv'}, {out / 'sweep.md'}, {out / 'pareto.png'}, {out / 'sweep.json'}")


def _json_default(v):
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    return str(v)


def write_csv(rows: list[dict], path: Path) -> Path:
    """All rows with CSV_COLUMNS (blank where a row has no value)."""
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(CSV_COLUMNS), extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _csv_value(row.get(k)) for k in CSV_COLUMNS})
    return path


def _csv_value(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return v


def default_on_front(rows: list[dict]) -> bool | None:
    """Whether the default setting is on the primary front (None: no default row or no figures)."""
    row = next((r for r in rows if r["setting"] == DEFAULT), None)
    return None if row is None else row.get("on_front")


def _fmt(v, digits: int = 1) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def _dominator_text(rows: list[dict]) -> str:
    """'name (Δ ms/frame, Δ px pin error, Δ px settling error)' for each setting that
    dominates the default (no settling term when either row lacks the figure)."""
    by = {r["setting"]: r for r in rows}
    d = by[DEFAULT]
    parts = []
    for name in (d.get("dominated_by") or "").split():
        r = by[name]
        settling = ("" if not (_finite(r.get("pin_settling_rms_px")) and _finite(d.get("pin_settling_rms_px"))) else
                    f", {r['pin_settling_rms_px'] - d['pin_settling_rms_px']:+.2f} px settling error")
        parts.append(f"{name} ({r['total_ms'] - d['total_ms']:+.1f} ms/frame, "
                     f"{r['pin_rms_px'] - d['pin_rms_px']:+.2f} px pin error{settling})")
    return ", ".join(parts) or "another setting"


def _contour_cell(r: dict) -> str:
    """'mean mm (steps, how it ended)' of a row's contour run."""
    if not _finite(r.get("contour_path_mean_mm")):
        return "—"
    return f"{r['contour_path_mean_mm']:.1f} ({r.get('contour_steps')}, {r.get('contour_stop')})"


def _timing_note(meta: dict) -> str:
    """How the times were measured (a sweep.json from before the timing pass has no 'timing')."""
    timing = meta.get("timing")
    if timing is None:
        return ("Times: CPU ms per frame of the accuracy job's process over the slide and contour frames, measured "
                "beside the other parallel jobs.")
    angles = ", ".join(f"{a:g}" for a in timing["orientations_deg"])
    return ("Times: CPU ms per frame; physics (move into the frame + settle), render and tracking from the timing "
            f"pass (each setting alone on the machine after the accuracy jobs, in rounds that run every setting once, "
            f"best of {timing['repeats']} rounds after an untimed one, over the slides at θ = {angles}°), perception "
            "from the accuracy job; × default: physics + render + tracking against the default's, best against best, "
            "and in brackets the lowest and highest ratio within one round; wall-clock figures of the accuracy jobs "
            "in sweep.csv.")


def _ratio_cell(r: dict) -> str:
    """'1.21 (1.18–1.25)': the timed stages against the default's, best against best (the
    lowest–highest ratio within one round); '—' where not timed against a default."""
    if not _finite(r.get("time_x_default")):
        return "—"
    return f"{r['time_x_default']:.2f} ({r['time_x_default_min']:.2f}–{r['time_x_default_max']:.2f})"


def markdown_table(rows: list[dict], meta: dict) -> str:
    """The README's table: one line per setting, then the verdict and how it was measured."""
    head = ("| setting | knob | physics | render | tracking | perception | **total ms/frame** | × default | "
            "pin err px (phys / track) | settling err px | θ err ° | l err mm | contour err mm (steps, end) | front | "
            "contour front |")
    lines = [head, "|" + "|".join(["---"] * (head.count("|") - 1)) + "|"]
    for r in rows:
        name = f"**{r['setting']}**" if r["setting"] in (DEFAULT, *REFERENCES.values()) else r["setting"]
        if r["status"] != "ok":
            name += f" ⚠ failed in {r['stage']}"
        pin = (f"{_fmt(r.get('pin_rms_px'), 2)} ({_fmt(r.get('pin_physics_rms_px'), 2)} / "
               f"{_fmt(r.get('pin_tracking_rms_px'), 2)})")
        front = {True: "●", False: "", None: "—"}[r.get("on_front")]
        contour_front = {True: "●", False: "", None: "—"}[r.get("on_front_contour")]
        lines.append(f"| {name} | {r['knob']} | {_fmt(r.get('physics_ms'))} | {_fmt(r.get('render_ms'))} | "
                     f"{_fmt(r.get('track_ms'))} | {_fmt(r.get('perception_ms'))} | **{_fmt(r.get('total_ms'))}** | "
                     f"{_ratio_cell(r)} | {pin} | {_fmt(r.get('pin_settling_rms_px'), 2)} | {_fmt(r.get('theta_rms_deg'))} | "
                     f"{_fmt(r.get('lateral_rms_mm'), 2)} | "
                     f"{_contour_cell(r)} | {front} | {contour_front} |")
    on = default_on_front(rows)
    default_camera = next((r.get("camera") for r in rows if r["setting"] == DEFAULT), "—")
    if on is None:
        verdict = "The default was not measured (or failed), so its place on the front is unknown."
    elif on:
        verdict = ("The default lies on the Pareto front (time vs pin and settling error, frame-producing "
                   f"settings at {default_camera}).")
    else:
        verdict = ("**The default is NOT on the Pareto front** (time vs pin and settling error, frame-producing "
                   f"settings at {default_camera}): dominated by {_dominator_text(rows)}.")
    p = meta["probe"]
    failures = meta["failures"]
    notes = [
        "",
        verdict,
        f"Failures: {len(failures)}" + (": " + "; ".join(failures) if failures else "."),
        "",
        f"Measured {meta['date']} on {meta['machine']}, GL {meta['gl']}, {meta['workers']} parallel job(s) "
        f"({'quick' if meta['quick'] else 'full'} sweep, {meta['wall_s']:.0f} s). Each setting turns one knob of the "
        "default scenario (rectangle, fidelity default, contact + friction + render, 640×480, no MSAA). "
        f"Probe: {len(p['tap_orientations_deg'])} orientations × {len(p['lateral_mm'])} lateral × "
        f"{len(p['tap_depths_mm'])} depths taps train PCA + GP; {len(p['slide_orientations_deg'])} orientations × "
        f"{len(p['directions_deg'])} directions × {len(p['lateral_mm'])} samples of slides test it; contour following "
        f"of the rectangle (≤ {p['contour_max_steps']} steps). {_timing_note(meta)} Pin error: px RMS at 640×480 against the true pins "
        "of its own dome model's reference (flex: reference, compliant: compliant_reference) at the same poses (physics "
        "part: the setting's true pins; tracking part: tracked vs its own true pins); the two models' pin errors are "
        "never compared with each other. "
        "Settling error: px RMS at 640×480 of the setting's true pins against the same frames settled on to "
        "convergence (untimed): what the settle tolerance leaves, which the pin error (mostly the grid's "
        "discretisation) cannot see. "
        "θ/l error: RMS on the slide probe. Contour error: mean distance of the path from the contour. "
        "● = on the Pareto front of time vs pin error and settling error together (dominated only by a setting no "
        "slower and no worse in both, and better in one; time compared round by round: no slower and faster "
        "only if so in every round of the timing pass) among settings of the same output (rendered frames vs "
        "projected pins) and, for frames, the same camera (the resolution is the simulated camera's spec, not a "
        "fidelity knob; other resolutions show what a different camera would cost), with noise margins "
        f"({TIME_MARGIN:.0%} time; {ERROR_MARGIN_REL:.0%} or {ERROR_MARGIN_ABS['pin_rms_px']} px pin error, "
        f"{ERROR_MARGIN_ABS['pin_settling_rms_px']} px settling error) and of the same dome model. Contour front: "
        "time vs the contour error, the same peers but across both dome models (the error is against the true "
        "contour), among the runs that complete the contour (close the loop or reach its end), margin "
        f"{ERROR_MARGIN_ABS['contour_completed_mm']} mm. Full figures: sweep.csv; plot: pareto.png.",
    ]
    return "\n".join(lines + notes) + "\n"


def plot_pareto(rows: list[dict], path: Path) -> Path:
    """Accuracy against time per frame, one panel per accuracy column of FRONTS; fronts drawn
    per output kind (a line for a one-column front; the members of a several-column front,
    which no single panel can show as a line, ringed), the default starred and the
    reference squared (matplotlib, Agg)."""

    matplotlib.use("Agg")

    panels = [(metric, key, len(metrics) > 1) for key, metrics in FRONTS for metric in metrics]
    ncols = 2
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.4 * ncols, 5.2 * nrows), dpi=110, squeeze=False)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    colours = {"frames": "tab:blue", "pins": "tab:orange"}
    for ax, (metric, key, ringed) in zip(axes.ravel(), panels):
        label = METRIC_LABELS[metric]
        for output, colour in colours.items():
            pts = [r for r in rows if r["output"] == output and _finite(r.get("total_ms")) and _finite(r.get(metric))]
            bad = [r for r in pts if r["status"] != "ok"]
            pts = [r for r in pts if r["status"] == "ok"]
            if bad:  # figures measured before the failure, never on a front
                ax.scatter([r["total_ms"] for r in bad], [r[metric] for r in bad], marker="x", c="red", s=30,
                           zorder=3, label="failed (partial figures)")
                for r in bad:
                    ax.annotate(r["setting"], (r["total_ms"], r[metric]), fontsize=6, xytext=(3, 3),
                                textcoords="offset points", color="red")
            if not pts:
                continue
            for dome, marker in DOME_MARKERS.items():
                mine = [r for r in pts if r.get("dome", "flex") == dome]
                if mine:
                    ax.scatter([r["total_ms"] for r in mine], [r[metric] for r in mine], c=colour, s=22, zorder=3,
                               marker=marker, label=("rendered + tracked" if output == "frames" else "projected pins")
                               + ("" if dome == "flex" else f" ({dome} dome)"))
            # a pin metric's front is per dome model (each against its own reference), the others across both
            for dome in list(DOME_MARKERS) if metric in PIN_METRICS else [None]:
                front = sorted((r for r in pts if r.get(key) and (dome is None or r.get("dome", "flex") == dome)),
                               key=lambda r: r["total_ms"])
                if front and ringed:
                    ax.scatter([r["total_ms"] for r in front], [r[metric] for r in front], s=90, facecolor="none",
                               edgecolor=colour, lw=1.0, zorder=2, label="on the pin + settling error front")
                elif front:
                    ax.step([r["total_ms"] for r in front], [r[metric] for r in front], where="post", color=colour,
                            lw=1.0, alpha=0.7, zorder=2)
            for r in pts:
                ax.annotate(r["setting"], (r["total_ms"], r[metric]), fontsize=6, xytext=(3, 3),
                            textcoords="offset points")
                if r["setting"] == DEFAULT:
                    ax.scatter([r["total_ms"]], [r[metric]], marker="*", s=220, facecolor="none", edgecolor="red",
                               lw=1.2, zorder=4, label="default")
                if r["setting"] in REFERENCES.values():
                    ax.scatter([r["total_ms"]], [r[metric]], marker="s", s=90, facecolor="none", edgecolor="k",
                               lw=1.0, zorder=4, label="reference")
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("CPU time per frame (ms, log)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    failed = [r["setting"] for r in rows if r["status"] != "ok"]
    title = "What accuracy costs in time (lines and rings: Pareto fronts)"
    if failed:
        title += f" — {len(failed)} failed: {', '.join(failed)}"
    fig.suptitle(title, fontsize=10)
    uniq: dict = {}
    for ax in axes.ravel():
        handles, labels = ax.get_legend_handles_labels()
        uniq.update(zip(labels, handles))
    fig.legend(uniq.values(), uniq.keys(), fontsize=8, loc="lower center", ncol=len(uniq), frameon=False)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path)
    plt.close(fig)
    return path
