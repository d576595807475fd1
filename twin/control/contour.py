"""The closed contour-following loop (§III-D) on any Environment: observe → read pins →
perceive θ̂ and l̂ → step with the controller; it stops when the loop closes, at the
spiral's end, when the contour is lost or at the step limit. Recording, scoring and
plotting a run, and building the loop from a scenario: twin.runs.contour_run.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np

from twin.control.controllers import Controller, Percept, normal_from_theta
from twin.core.environment import Environment, Observation
from twin.core.errors import UnreachablePoseError, UserError
from twin.core.poses import Pose, object_to_work_deg, object_to_work_xy, work_to_object_xy
from twin.core.scenario import ContourProtocol, hover_over
from twin.sensing.pins import PinReader
from twin.world.stimuli import Stimulus

#: The loop is closed (or the spiral's end reached) when the sensor comes within this
#: distance (mm) of the first contact point (the end point) after having travelled at
#: least CLOSE_MIN_TRAVEL_MM and passed within COVERAGE_RADIUS_MM of CLOSE_MIN_COVERAGE of
#: the contour (without that, a path that turns back to the start read as a closed loop).
CLOSE_RADIUS_MM = 4.0
CLOSE_MIN_TRAVEL_MM = 40.0
CLOSE_MIN_COVERAGE = 0.9
COVERAGE_RADIUS_MM = 5.0  # a contour point is covered when the path passes this close
LOST_DISTANCE_MM = 30.0  # farther than this from the contour, the run stops: contour lost


def _finite(pose: Pose) -> bool:
    """True if every coordinate of `pose` is a finite number."""
    try:
        return bool(np.all(np.isfinite(np.asarray(pose.as_array(), float))))
    except (TypeError, ValueError):
        return False


@dataclass
class ContourStep:
    """One step of contour following: the observation, its pins and the percept labels."""

    observation: Observation
    target: Pose
    pins_px: np.ndarray
    found: np.ndarray | None
    labels: dict


def no_clock(stage: str):
    """A stage clock that measures nothing (the default of every timed loop)."""
    return nullcontext()


class ContourFollower:
    """The closed loop of §III-D on any Environment: observe → track → perceive → step.

    Iterate it to get one `ContourStep` per step; afterwards `stop_reason` says why it
    stopped: loop closed, end of contour (spiral), lost the contour (farther than
    LOST_DISTANCE_MM), a target out of the arm's reach, or the step limit. `clock(stage)`
    is a context manager charged with the time of "render" (observe), "track",
    "perception" and "physics" (moves), for benchmarks.

    env: its work frame is the object frame (`stimulus`'s, seen from above, z into the
    object). protocol: depth, speed, start orientation and step budget. model: a fitted
    PerceptionModel. controller: twin.control.controllers.load_controller's.
    """

    def __init__(
        self,
        env: Environment,
        protocol: ContourProtocol,
        model,
        stimulus: Stimulus,
        controller: Controller,
        clock=no_clock,
        controller_name: str | None = None,
    ) -> None:
        self.env, self.protocol, self.model, self.stimulus, self.clock = env, protocol, model, stimulus, clock
        self.controller = controller
        #: how errors name the controller: its name in the scenario, else its class
        self._controller_name = controller_name or type(controller).__name__
        self.stop_reason = "not started"
        #: (127, 2) px: the pins at rest (the tracker's reference), once iteration has begun
        self.rest_pins_px: np.ndarray | None = None

    def _ask_controller(self, method: str, argument):
        """The controller's `method`(argument); a controller that raises (or calls
        sys.exit), or whose next_pose returns anything but a finite Pose, is a UserError
        naming it (the run stops, its samples kept)."""
        try:
            answer = getattr(self.controller, method)(argument)
        except (Exception, SystemExit) as err:  # noqa: BLE001  (a plug-in is the user's code: its faults are named)
            text = str(err).splitlines()[0][:120] if str(err).strip() else ""
            raise UserError(
                f"controller {self._controller_name!r}: {method}() raised {type(err).__name__}"
                f"{': ' + text if text else ''}"
            ) from None
        if method == "next_pose" and not (isinstance(answer, Pose) and _finite(answer)):
            got = type(answer).__name__ if not isinstance(answer, Pose) else "a Pose with NaN or ±inf"
            raise UserError(f"controller {self._controller_name!r}: next_pose() must return a finite Pose, got {got}")
        return answer

    def __iter__(self) -> Iterator[ContourStep]:
        env, p, stimulus, clock = self.env, self.protocol, self.stimulus, self.clock
        start_xy = object_to_work_xy(stimulus.start_point_mm)[0]
        end_xy = None if stimulus.end_point_mm is None else object_to_work_xy(stimulus.end_point_mm)[0]
        resolution = (env.camera.width, env.camera.height)
        reader = PinReader(env.reset())
        self.rest_pins_px = reader.rest_px
        start = Pose(start_xy[0], start_xy[1], p.depth_mm, 0.0, 0.0, p.orientation_deg)
        env.move_to(hover_over(start.x, start.y, p.orientation_deg), p.speed_mm_s)
        with clock("physics"):
            env.move_to(start, p.speed_mm_s)
        self._ask_controller("reset", start)
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
            target = self._ask_controller("next_pose", percept)
            try:
                with clock("physics"):
                    env.move_to(target, p.speed_mm_s)
            except UnreachablePoseError as err:
                self.stop_reason = f"controller asked for an unreachable pose: {err}"
                break
            travelled += float(np.hypot(target.x - obs.pose.x, target.y - obs.pose.y))
        env.move_to(hover_over(obs.pose.x, obs.pose.y, p.orientation_deg), p.speed_mm_s)
