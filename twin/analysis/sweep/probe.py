"""What every setting of the sweep runs, in one process (one job of the sweep): a tap probe
that trains the paper's PCA + GP, a slide probe that gives the pin, settling and
perception errors, and a contour run; timed per stage and frame (CPU and wall ms)."""

from __future__ import annotations

import time
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.analysis.sweep.knobs import Setting
from twin.core.sensor import CameraModel
from twin.runs.contour_metrics import contour_metrics
from twin.runs.contour_run import ScenarioFollower
from twin.runs.protocols import protocol_moves
from twin.runs.record import Run
from twin.runs.runner import chunk_moves, chunk_samples
from twin.runs.sim_env import SimEnvironment
from twin.runs.spec import dome_builder, dome_params, inside_renderer, load_scenario_stimulus
from twin.sensing.perception import GPConfig, PerceptionModel, angle_error_deg

#: Reference camera resolution (W, H) px: pin errors are expressed at this resolution.
REFERENCE_RESOLUTION = (640, 480)


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
        return {
            "kind": "taps",
            "orientations_deg": list(self.tap_orientations_deg),
            "lateral_mm": list(self.lateral_mm),
            "depths_mm": list(self.tap_depths_mm),
            "edge_point_mm": [60, 0],
            "edge_normal_deg": 0,
        }

    def slides(self) -> dict:
        return {
            "kind": "slides",
            "orientations_deg": list(self.slide_orientations_deg),
            "directions_deg": list(self.directions_deg),
            "lateral_mm": list(self.lateral_mm),
            "depth_mm": self.slide_depth_mm,
            "edge_point_mm": [60, 0],
            "edge_normal_deg": 0,
        }

    def contour(self) -> dict:
        return {
            "kind": "contour",
            "depth_mm": 3,
            "step_mm": 3,
            "gain": 0.35,
            "lateral_target_mm": 0,
            "orientation_deg": 0,
            "max_steps": self.contour_max_steps,
            "controller": "paper",
        }


#: Full sweep: θ every 40° (9 orientations): 144 taps, 288 slide frames, the whole loop.
FULL_PROBE = Probe(
    tap_orientations_deg=tuple(float(a) for a in range(-160, 181, 40)),
    slide_orientations_deg=tuple(float(a) for a in range(-160, 181, 40)),
)
#: Quick sweep (smoke check): θ every 90° for training (64 taps), 2 of them for testing
#: (64 slide frames), 20 contour steps (60 mm along the first edge).
QUICK_PROBE = Probe(
    tap_orientations_deg=(-90.0, 0.0, 90.0, 180.0),
    slide_orientations_deg=(0.0, 90.0),
    contour_max_steps=20,
    gp_restarts=0,
)


def rescale_pins(pins_px: np.ndarray, width: int, height: int) -> np.ndarray:
    """Pins (px) in a `width` × `height` frame → px at REFERENCE_RESOLUTION (pixel centres at
    integers; another shape by its short side, twin.core.sensor.CameraModel.rescale_px)."""
    if (int(width), int(height)) == REFERENCE_RESOLUTION:
        return np.asarray(pins_px, float)
    return CameraModel(*REFERENCE_RESOLUTION).rescale_px(pins_px, width, height)


STAGES: tuple[str, ...] = ("physics", "render", "track", "perception")


class Stages:
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


class _NoClock(Stages):
    """Stages that are not timed (the tap probe)."""

    @contextmanager
    def clock(self, stage: str) -> Iterator[None]:
        yield


def open_loop(env, moves, stages: Stages, settling: bool = False) -> dict:
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
    return {
        "pins": np.array(pins),
        "truth": np.array(truth),
        "found": np.array(found),
        "labels": labels,
        "converged": np.array(converged) if settling else None,
    }


def _contour(env, scenario, model, stages: Stages) -> dict:
    """Contour following of the scenario's object with twin.runs.contour_run.ScenarioFollower (the
    same loop and stop rules as `twin run`, without the recorder); returns
    twin.runs.contour_metrics.contour_metrics of the steps."""

    stimulus = load_scenario_stimulus(scenario)
    follower = ScenarioFollower(env, scenario, model, stimulus, clock=stages.clock)
    samples = [
        {
            "pose": [float(v) for v in step.observation.pose.as_array()],
            "time": float(step.observation.time),
            "labels": step.labels,
        }
        for step in follower
    ]
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
    row: dict = {
        "setting": setting.name,
        "knob": setting.knob,
        "output": setting.output,
        "dome": setting.dome,
        "fidelity": setting.fidelity,
        "effects": "+".join(setting.effects),
        "status": "ok",
        "stage": "",
        "error": "",
        "note": setting.note,
    }
    out: dict = {"row": row, "slide_pins_px": None, "slide_truth_px": None}
    stage = "build"
    env = None
    stages = Stages()
    try:
        scenario = setting.scenario(probe.contour(), seed)
        params = dome_params(scenario)
        cam = scenario.sensor.camera
        resolution = dome_builder(scenario).resolution(params)
        row.update(
            {
                **resolution,
                "camera": f"{cam.width}x{cam.height}" if setting.renders else "—",
                "msaa": cam.msaa if setting.renders else 0,
                "renderer": inside_renderer(scenario) if setting.renders else "—",
                "effects": "+".join(scenario.effects),
            }
        )
        env = SimEnvironment(scenario, seed=seed)
        stage = "taps"
        taps = open_loop(env, protocol_moves(setting.scenario(probe.taps(), seed).protocol), _NoClock())
        row["n_taps"] = len(taps["labels"])
        stage = "train"
        t0 = time.perf_counter()
        lab = {k: np.array([x[k] for x in taps["labels"]], float) for k in ("theta_deg", "lateral_mm", "depth_mm")}
        model = PerceptionModel(gp=GPConfig(n_restarts=probe.gp_restarts))
        model.fit(
            taps["pins"],
            lab["theta_deg"],
            lab["lateral_mm"],
            lab["depth_mm"],
            np.random.default_rng(seed),
            resolution=(cam.width, cam.height),
        )
        row["train_s"] = time.perf_counter() - t0
        stage = "slides"
        slides = open_loop(
            env,
            protocol_moves(setting.scenario(probe.slides(), seed).protocol),
            stages,
            settling=scenario.has("contact"),
        )
        row["n_slide_frames"] = len(slides["labels"])
        out["slide_pins_px"] = rescale_pins(slides["pins"], cam.width, cam.height)
        out["slide_truth_px"] = rescale_pins(slides["truth"], cam.width, cam.height)
        row["pin_tracking_rms_px"] = rms_px(out["slide_pins_px"], out["slide_truth_px"])
        if slides["converged"] is not None:
            row["pin_settling_rms_px"] = rms_px(
                out["slide_truth_px"], rescale_pins(slides["converged"], cam.width, cam.height)
            )
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


def rms_px(a: np.ndarray, b: np.ndarray) -> float:
    """RMS pin distance (px) over all frames and pins of two (N, 127, 2) arrays."""
    return float(np.sqrt(np.mean(np.sum((np.asarray(a) - np.asarray(b)) ** 2, axis=-1))))
