"""Closed-loop contour following (§III-D): perceive θ̂ and l̂ from the pins, step with the
controller, record every step, stop when the loop closes, at the spiral's end or at the
step limit; then score the run against the true contour and plot it (Figs. 7–8).
"""
from __future__ import annotations

import json
import time
from collections.abc import Iterator
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from twin.env import Environment, Observation

from twin.control import Percept, load_controller, normal_from_theta
from twin.errors import UnreachablePoseError, UserError
from twin.poses import Pose
from twin.record import RunRecorder, load_run
from twin.scenario import Scenario

#: The loop is closed (or the spiral's end reached) when the sensor comes within this
#: distance (mm) of the first contact point (the end point) after having travelled at
#: least CLOSE_MIN_TRAVEL_MM and passed within COVERAGE_RADIUS_MM of CLOSE_MIN_COVERAGE of
#: the contour (without that, a path that turns back to the start read as a closed loop).
CLOSE_RADIUS_MM = 4.0
CLOSE_MIN_TRAVEL_MM = 40.0
CLOSE_MIN_COVERAGE = 0.9
COVERAGE_RADIUS_MM = 5.0  # a contour point is covered when the path passes this close
LOST_DISTANCE_MM = 30.0  # farther than this from the contour, the run stops: contour lost


def object_to_work_xy(points_mm: np.ndarray) -> np.ndarray:
    """Object-frame (x, y) mm → work-frame (x, y) mm (work = object turned 180° about x)."""
    p = np.atleast_2d(np.asarray(points_mm, float))
    return np.column_stack([p[:, 0], -p[:, 1]])


work_to_object_xy = object_to_work_xy  # the flip is its own inverse


def object_to_work_deg(angle_deg):
    return -np.asarray(angle_deg, float)


@dataclass
class ContourStep:
    """One step of contour following: the observation, its pins and the percept labels."""

    observation: Observation
    target: Pose
    pins_px: np.ndarray
    found: np.ndarray | None
    labels: dict


def _no_clock(stage: str):
    return nullcontext()


class ContourFollower:
    """The closed loop of §III-D on any Environment: observe → track → perceive → step.

    Iterate it to get one `ContourStep` per step; afterwards `stop_reason` says why it
    stopped: loop closed, end of contour (spiral), lost the contour (farther than
    LOST_DISTANCE_MM), a target out of the arm's reach, or the step limit. `clock(stage)`
    is a context manager charged with the time of "render" (observe), "track",
    "perception" and "physics" (moves), for benchmarks.
    """

    def __init__(self, env: Environment, scenario: Scenario, model, stimulus, clock=_no_clock) -> None:
        if scenario.work_frame != "object":
            raise UserError(f"{scenario.source}: contour following needs work_frame: object")
        self.env, self.scenario, self.model, self.stimulus, self.clock = env, scenario, model, stimulus, clock
        self.controller = load_controller(scenario.protocol.controller, scenario.protocol, scenario.source_dir)
        self.stop_reason = "not started"

    def __iter__(self) -> Iterator[ContourStep]:
        from twin.runner import PinReader

        env, p, stimulus, clock = self.env, self.scenario.protocol, self.stimulus, self.clock
        start_xy = object_to_work_xy(stimulus.start_point_mm)[0]
        end_xy = None if stimulus.end_point_mm is None else object_to_work_xy(stimulus.end_point_mm)[0]
        resolution = (env.camera.width, env.camera.height)
        reader = PinReader(env.reset())
        start = Pose(start_xy[0], start_xy[1], p.depth_mm, 0.0, 0.0, p.orientation_deg)
        env.move_to(Pose(start.x, start.y, -5.0, 0.0, 0.0, p.orientation_deg), p.speed_mm_s)
        with clock("physics"):
            env.move_to(start, p.speed_mm_s)
        self.controller.reset(start)
        travelled, target = 0.0, start
        trace = object_to_work_xy(stimulus.trace_path(1.0))
        covered = np.zeros(len(trace), bool)
        self.stop_reason = "step limit"
        for step in range(p.max_steps):
            with clock("render"):
                obs = env.observe()
            with clock("track"):
                pins, found, _ = reader.read(obs)
            with clock("perception"):
                pred = self.model.predict(pins, found, resolution=resolution)
            percept = Percept(float(pred.theta_deg[0]), float(pred.lateral_mm[0]), bool(pred.ok[0]), obs.pose)
            xy = np.array([obs.pose.x, obs.pose.y])
            labels = {
                "step": step,
                "theta_hat_deg": percept.theta_deg,
                "lateral_hat_mm": percept.lateral_mm,
                "perceived_normal_deg": normal_from_theta(obs.pose.gamma, percept.theta_deg),
                "ok": percept.ok,
                "reason": pred.reason[0],
                "true_normal_deg": float(object_to_work_deg(stimulus.outward_normal_deg(work_to_object_xy(xy)))[0]),
                "true_lateral_mm": float(stimulus.signed_distance_mm(work_to_object_xy(xy))[0]),
            }
            yield ContourStep(obs, target, pins, found, labels)
            covered |= np.linalg.norm(trace - xy, axis=1) <= COVERAGE_RADIUS_MM
            around = travelled > CLOSE_MIN_TRAVEL_MM and covered.mean() >= CLOSE_MIN_COVERAGE
            if step and around and np.linalg.norm(xy - start_xy) < CLOSE_RADIUS_MM:
                self.stop_reason = "loop closed"
                break
            if end_xy is not None and around and np.linalg.norm(xy - end_xy) < CLOSE_RADIUS_MM:
                self.stop_reason = "end of contour"
                break
            if abs(labels["true_lateral_mm"]) > LOST_DISTANCE_MM:
                self.stop_reason = f"lost the contour ({labels['true_lateral_mm']:.1f} mm from it)"
                break
            target = self.controller.next_pose(percept)
            try:
                with clock("physics"):
                    env.move_to(target, p.speed_mm_s)
            except UnreachablePoseError as err:
                self.stop_reason = f"controller asked for an unreachable pose: {err}"
                break
            travelled += float(np.hypot(target.x - obs.pose.x, target.y - obs.pose.y))
        env.move_to(Pose(obs.pose.x, obs.pose.y, -5.0, 0.0, 0.0, p.orientation_deg), p.speed_mm_s)


def run_contour(scenario: Scenario, out: Path, seed: int | None = None, progress: bool = True, model=None) -> Path:
    """Trace the scenario's object and record the run in `out` (with metrics.json and
    contour.png). `model` is a fitted PerceptionModel; default: scenario's `model` file,
    else the cached model trained on the tap set (twin.training)."""
    from twin.runner import make_environment
    from twin.scene import camera_model, load_scenario_stimulus

    seed = scenario.seed if seed is None else seed
    if model is None:
        from twin.training import model_for_scenario

        model = model_for_scenario(scenario)
    stimulus = load_scenario_stimulus(scenario)
    wall0 = time.perf_counter()
    env = make_environment(scenario, seed)
    follower = ContourFollower(env, scenario, model, stimulus)
    recorder = RunRecorder(out, scenario, seed, scenario.backend, camera_model(scenario),
                           extra={"model": model.info.get("path", "in memory")})
    try:
        with recorder:
            for step in tqdm(follower, desc=scenario.name, unit="step", total=scenario.protocol.max_steps,
                             disable=not progress):
                recorder.add(step.observation, step.target, step.labels, step.pins_px, step.found)
            recorder.meta["stop_reason"] = follower.stop_reason
            recorder.meta["wall_time_s"] = time.perf_counter() - wall0
    finally:
        env.close()
    metrics = contour_metrics(load_run(out), stimulus)
    (Path(out) / "metrics.json").write_text(json.dumps(metrics, indent=1))
    plot_contour(load_run(out), stimulus, Path(out) / "contour.png")
    return Path(out)


def contour_metrics(run, stimulus) -> dict:
    """The per-run metrics of a contour-following run (units in the key names)."""
    samples = run.samples
    xy_work = np.array([[s["pose"][0], s["pose"][1]] for s in samples])
    xy_obj = work_to_object_xy(xy_work)
    lab = {k: np.array([s["labels"][k] for s in samples]) for k in
           ("perceived_normal_deg", "true_normal_deg", "lateral_hat_mm", "true_lateral_mm", "ok")}
    ok = lab["ok"].astype(bool)
    d_angle = (lab["perceived_normal_deg"] - lab["true_normal_deg"] + 180.0) % 360.0 - 180.0
    path_dist = stimulus.distance_to_contour(xy_obj)
    trace = stimulus.trace_path(1.0)
    gaps = np.min(np.linalg.norm(trace[:, None, :] - xy_obj[None, :, :], axis=2), axis=1) if len(xy_obj) else np.inf
    status = run.meta.get("status")
    stop = run.meta.get("stop_reason", "")
    return {
        "object": stimulus.name,
        "completed": bool(status == "completed" and stop in ("loop closed", "end of contour")),
        "stop_reason": stop,
        "steps": len(samples),
        "orientation_rms_deg": float(np.sqrt(np.mean(d_angle[ok] ** 2))) if ok.any() else float("nan"),
        "lateral_rms_mm": float(np.sqrt(np.mean((lab["lateral_hat_mm"] - lab["true_lateral_mm"])[ok] ** 2))) if ok.any() else float("nan"),
        "path_distance_mean_mm": float(np.mean(path_dist)),
        "path_distance_max_mm": float(np.max(path_dist)),
        "coverage": float(np.mean(gaps <= COVERAGE_RADIUS_MM)),
        "sim_time_s": float(samples[-1]["time"]) if samples else 0.0,
        "wall_time_s": float(run.meta.get("wall_time_s", float("nan"))),
        "lost_contact_steps": int((~ok).sum()),
    }


def plot_contour(run, stimulus, out: Path) -> Path:
    """The paper's Figs. 7–8: the object's outline, the sensor path and the perceived
    edge normals (grey), in the object frame seen from above (mm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xy = work_to_object_xy(np.array([[s["pose"][0], s["pose"][1]] for s in run.samples]))
    normals = -np.array([s["labels"]["perceived_normal_deg"] for s in run.samples])  # work → object angle
    fig, ax = plt.subplots(figsize=(5, 5), dpi=120)
    outline = np.asarray(stimulus.outline.exterior.coords)
    ax.fill(outline[:, 0], outline[:, 1], color="0.92", zorder=0)
    ax.plot(outline[:, 0], outline[:, 1], color="0.5", lw=0.8, zorder=1)
    for (x, y), a in zip(xy, np.radians(normals)):
        ax.plot([x, x - 8 * np.cos(a)], [y, y - 8 * np.sin(a)], color="0.6", lw=0.6, zorder=2)
    ax.plot(xy[:, 0], xy[:, 1], color="tab:blue", lw=1.5, zorder=3, label="sensor path")
    ax.plot(*xy[0], "o", color="tab:green", ms=5, zorder=4, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"{stimulus.name}: contour following")
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return out
