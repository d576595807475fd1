"""The simulated rig behind the `Environment` interface (twin.core.environment)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import cv2
import mujoco
import numpy as np

from twin.core.environment import Environment, Observation
from twin.core.errors import PhysicsError, UnreachablePoseError, UserError
from twin.core.poses import Pose, invert_transform
from twin.core.scenario import DEFAULT_SPEED_MM_S, START_POSE, Scenario
from twin.runs.protocols import protocol_moves
from twin.runs.spec import SimSpec, scene_spec, sim_spec
from twin.world.arm import ArmDynamics
from twin.world.render import InsideRenderer, PinRenderer, render_overview
from twin.world.scene import TOOL2FLANGE, Scene, build_overview, build_scene, kinematics, sensor_physics
from twin.world.silhouette import SilhouetteRenderer

#: the arm's yield to the contact force: at most this many in-contact moves per commanded
#: move; how far (mm) the last may be from force × yield (friction's hysteresis leaves the
#: force a band of microns wide, not a point: any pose in it holds); and the most it may yield (mm)
YIELD_ITERATIONS = 12
YIELD_TOLERANCE_MM = 0.05
YIELD_LIMIT_MM = 5.0
#: the secant's slope of (yield × force − s) against s (–) above which a yield move takes the fixed-point step
SECANT_SLOPE_FLOOR = 0.5


class SimEnvironment(Environment):
    """MuJoCo twin of the rig. Poses in the scenario's work frame (mm/deg).

    Every commanded pose is first checked against the real arm's inverse kinematics
    (reach and joint limits) so the twin refuses what the robot could not do, whether or
    not the arm's dynamics are simulated.
    """

    def __init__(self, scenario: Scenario, seed: int | None = None, start_pose: Pose = START_POSE) -> None:
        #: the scenario resolved once (twin.runs.spec): everything below is built from it
        self.spec: SimSpec = sim_spec(scenario)
        spec = self.spec
        self.seed = spec.seed if seed is None else seed
        self.start_pose = start_pose
        self.scene: Scene = build_scene(spec.scene)
        self.camera = spec.scene.camera
        #: (127, 2) px the sensor's rest layout differs from the lattice (calibration)
        self.rest_offsets_px = spec.rest_offsets_px
        #: the dome apex relative to the commanded TCP (calibration's tcp_offset_mm), 4×4 m
        self.tcp2apex = spec.tcp2apex
        self.work_frame = Pose.from_matrix(self.scene.work2world)
        self.world2work = invert_transform(self.scene.work2world)
        self._renderer: InsideRenderer | None = None
        if spec.has("render"):
            nominal = self.camera.nominal()  # the renderers draw through the nominal pinhole (observe)
            if spec.renderer == "silhouette":
                self._renderer = SilhouetteRenderer(nominal)
            else:
                self._renderer = PinRenderer(nominal, lighting=spec.has("lighting"), msaa=spec.msaa)
        self._noise = spec.noise_std
        #: wall time (s) spent per stage since construction: physics (move + settle), render
        self.timings = {"physics": 0.0, "render": 0.0, "frames": 0}
        self._new_episode()

    def _new_episode(self) -> None:
        mujoco.mj_resetData(self.scene.model, self.scene.data)
        self.rng = np.random.default_rng(self.seed)
        start = self.scene.work2world @ self.start_pose.to_matrix()
        self._q = kinematics().inverse(start, TOOL2FLANGE)  # the start pose must be reachable too
        self._commanded = start
        self.arm = ArmDynamics(kinematics(), TOOL2FLANGE, self._q) if self.spec.has("arm_dynamics") else None
        self.physics = sensor_physics(self.scene, start @ self.tcp2apex)
        self._frame = None
        #: m: how far the arm has yielded along its yield's direction (`_yield_to_contact`)
        self._yield_m = 0.0

    @property
    def rest_pins_px(self) -> np.ndarray:
        """(127, 2) px: the undeformed pins as the camera sees them."""
        return self.pins_px_of(self.physics.rest_pins)

    @property
    def pins_tool(self) -> np.ndarray:
        """(127, 3) m: the pin tips of the last settled frame, tool frame."""
        return self.observe_frame().pins_tool

    def pins_px_of(self, pins_tool: np.ndarray) -> np.ndarray:
        """(127, 2) px: pin tips (tool frame, m) through the (calibrated) camera, plus the
        calibrated rest-layout offsets."""
        pins_px = self.camera.project_tool_points(pins_tool)
        return pins_px if self.rest_offsets_px is None else pins_px + self.rest_offsets_px

    def observe_frame(self):
        """The settled physics frame at the current pose (twin.world.dome.base.Frame)."""
        if self._frame is None:
            self._frame = self.physics.settle()
        return self._frame

    def reset(self, seed: int | None = None) -> Observation:
        """Back to the start pose with the dome at rest; `seed` reseeds the camera noise."""
        if seed is not None:
            self.seed = int(seed)
        self._new_episode()
        self._frame = self.physics.settle()
        return self.observe()

    def move_to(self, pose: Pose, speed_mm_s: float | None = None) -> None:
        target = self.scene.work2world @ pose.to_matrix()
        self._q = kinematics().inverse(target, TOOL2FLANGE, q_seed=self._q)  # raises UnreachablePoseError
        speed = speed_mm_s or DEFAULT_SPEED_MM_S
        t0 = time.perf_counter()
        if self.spec.arm_yield.any():
            self._yield_to_contact(target, pose, speed)
        else:
            self._drive(target, speed)
        self.timings["physics"] += time.perf_counter() - t0

    def _drive(self, target: np.ndarray, speed: float) -> None:
        """Move the dome's TCP to `target` (4×4 world, m) and settle there."""
        if self.arm is None:
            self.physics.move(target @ self.tcp2apex, speed)
        else:
            # the dome follows the arm's actual tool pose, one physics step per sample
            dt = self.scene.model.opt.timestep
            previous = self._commanded
            for actual in self.arm.move(self._commanded, target, speed, dt):
                step_mm_s = np.linalg.norm(actual[:3, 3] - previous[:3, 3]) * 1e3 / dt
                self.physics.move(actual @ self.tcp2apex, max(step_mm_s * (1 + 1e-9), 1e-6))
                previous = actual
        self._commanded = target
        self._frame = self.physics.settle()

    def _yield_to_contact(self, target: np.ndarray, pose: Pose, speed: float) -> None:
        """The arm's yield (calibration `arm_yield_mm_per_n`): the TCP settles a distance s
        from `target` along the yield's direction where s = |yield| × the contact's normal
        force there. The arm is a spring in series with the contact, so a move starts from
        the yield the last one settled at (0 out of contact) and carries it along: a slide
        at a steady force slides at that yield throughout, as the real arm does, and is
        only corrected at its end (driving to the unyielded target first and backing off
        from there pressed the DigiTac replay's slides 2.5 times as hard and then unloaded
        them, which rewrote their friction). The correction is found by the secant method (the
        fixed-point step s = |yield| × force where the secant's slope is not clearly
        negative) in at most YIELD_ITERATIONS in-contact moves (a skin that sticks shears by
        what the arm yields). The moves keep the root bracketed (force × yield − s falls
        with s and is ≥ 0 at the target, s = 0): a step that would leave the bracket
        bisects it, as a stiff skin's first yield from the target lands far past the root;
        where it backs the tip off the object and lands past the YIELD_LIMIT_MM, the moves
        start at that limit. Where the skin slips between two moves the force
        jumps, and the bracket can close on the jump with both ends missing by more than
        the tolerance: the end the secant's step crosses was measured before the slip and is
        dropped (back to the target, s = 0, or to no bound), and the moves go on from the
        contact after it. PhysicsError when it does not settle (an arm that yields into
        the press faster than the contact pushes back, or one whose yield is past the limit)."""
        per_newton = self.scene.work2world[:3, :3] @ self.spec.arm_yield
        compliance = float(np.linalg.norm(per_newton))  # m/N
        direction = per_newton / compliance

        def drive(s: float) -> float:
            """Drive to the target yielded by s (m); the miss there, force × yield − s (m)."""
            yielded = target.copy()
            yielded[:3, 3] += s * direction
            self._drive(yielded, speed)
            self._yield_m = s
            return compliance * self._frame.contact_force - s

        s_last = self._yield_m
        miss_last = drive(s_last)
        if abs(miss_last) < 1e-7:  # m: settled where the last move left it, or out of contact at the target
            return
        below, above = 0.0, math.inf  # m: the bracket, miss ≥ 0 at `below` (the target) and < 0 at `above`
        if miss_last > 0:
            below = s_last
        else:
            above = s_last
        s = s_last + miss_last
        if direction @ target[:3, 2] < 0 and s * 1e3 > YIELD_LIMIT_MM:
            # backing off along the tip's axis lowers the force, so the root lies nearer than
            # the first yield: start at the limit, which then brackets it if it can
            s = YIELD_LIMIT_MM * 1e-3
        if not below <= s < above:
            s = (below + above) / 2
        miss = miss_last
        moves = 0
        while moves < YIELD_ITERATIONS and abs(miss) >= 1e-7 and abs(s) * 1e3 <= YIELD_LIMIT_MM:
            miss = drive(s)
            moves += 1
            if miss == miss_last:
                break
            if miss > 0:
                below = max(below, s)
            else:
                above = min(above, s)
            slope = (miss - miss_last) / (s - s_last)
            # a yield that settles has miss falling with s (slope < 0); a slope near 0 or above is
            # the force's path dependence (a sticking skin) at the micron level, and its secant
            # step would leap: take the fixed-point step s = yield × force instead
            step = -miss / slope if slope < -SECANT_SLOPE_FLOOR else miss
            following = s + step
            if not below <= following < above and above - below < YIELD_TOLERANCE_MM * 1e-3:
                # a bracket narrower than the tolerance whose ends miss by more: the force
                # jumped inside it (the skin slipped), so the end the step crosses was
                # measured on a contact that is gone; it goes back to the target (where the
                # miss is force × yield, never negative) or to no bound
                below, above = (0.0, above) if following < below else (below, math.inf)
            if not below <= following < above:
                following = (below + above) / 2 if math.isfinite(above) else s + miss
            s, s_last, miss_last = following, s, miss
        if abs(miss) * 1e3 > YIELD_TOLERANCE_MM:
            beyond = (
                f", the next {abs(s) * 1e3:.3g} mm past the {YIELD_LIMIT_MM} mm limit"
                if abs(s) * 1e3 > YIELD_LIMIT_MM
                else ""
            )
            raise PhysicsError(
                f"[{self.spec.scene.name}] at pose {pose}: the arm's yield does not settle (it is "
                f"{abs(miss) * 1e3:.3g} mm from force × yield at a contact force of {self._frame.contact_force:.3g} N "
                f"after {moves} moves{beyond}): calibration arm_yield_mm_per_n = {self.spec.arm_yield * 1e3} mm/N"
            )

    def observe(self) -> Observation:
        frame = self.observe_frame()
        self.timings["frames"] += 1
        pins_px = self.pins_px_of(frame.pins_tool)
        pose = Pose.from_matrix(self.world2work @ frame.tool2world @ invert_transform(self.tcp2apex))  # the TCP's pose
        truth = {"pins_px": pins_px, "contact_force_n": frame.contact_force, "physics_steps": frame.n_steps}
        if self._renderer is None:
            return Observation(time=frame.time, pose=pose, pins_px=pins_px, truth=truth)
        t0 = time.perf_counter()
        shown = (
            frame.pins_tool
        )  # a calibrated camera: the nominal GL camera sees each pin where the calibrated one does
        if self.rest_offsets_px is not None or self.camera != self.camera.nominal():
            shown = self.camera.place_at_pixels(frame.pins_tool, pins_px)
        image = self._renderer.render(shown, self._noise, self.rng)
        self.timings["render"] += time.perf_counter() - t0
        return Observation(time=frame.time, pose=pose, frame=image, truth=truth)

    def converged_pins_px(self) -> np.ndarray:
        """Sim-only truth, (127, 2) px: the last frame's pins settled to convergence, to
        measure how far a frame's settling stops from its equilibrium (`twin bench sweep`).
        Call right after a move; the simulation goes on as if it had not been called."""
        return self.camera.project_tool_points(self.physics.converged_pins())

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def check_reachable(scenario: Scenario, scene: Scene) -> int:
    """Check every pose the scenario's protocol will command (contour following: its start
    pose) against the arm's reach and joint limits, as the run would, seeding each solve
    with the previous joints; returns how many were checked. UnreachablePoseError naming
    the scenario file, the protocol field and the pose otherwise."""
    poses = [START_POSE]
    if scenario.protocol.kind != "contour":
        poses += [m.pose for m in protocol_moves(scenario.protocol)]
    q = None
    for i, pose in enumerate(poses):
        try:
            q = kinematics().inverse(scene.work2world @ pose.to_matrix(), TOOL2FLANGE, q_seed=q)
        except UnreachablePoseError as err:
            where = (
                "the start pose"
                if i == 0
                else f"field protocol.poses.{i - 1}"
                if scenario.protocol.kind == "render"
                else f"move {i} of the protocol ({scenario.protocol.kind}, from its fields)"
            )
            raise UnreachablePoseError(
                f"{scenario.source}: {where}, pose {pose.as_array().round(3).tolist()} (mm, deg, work frame): {err}"
            ) from None
    return len(poses)


def first_pose(scenario: Scenario) -> Pose:
    """The first recorded pose of a scenario's protocol (for single images)."""

    if scenario.protocol.kind == "contour":
        return START_POSE
    return next(m.pose for m in protocol_moves(scenario.protocol) if m.record)


def render_scenario_view(scenario: Scenario, out: Path, view: str = "sensor") -> Path:
    """Write the inside-camera frame (`sensor`) or an overview of the rig (`scene`) at
    the scenario's first recorded pose as a PNG."""
    pose = first_pose(scenario)
    out.parent.mkdir(parents=True, exist_ok=True)
    if view == "sensor":
        with SimEnvironment(scenario.with_changes(effects=sorted(set(scenario.effects) | {"render"}))) as env:
            env.move_to(pose)
            image = env.observe().frame
    else:
        model, data = build_overview(scene_spec(scenario), pose)
        image = render_overview(model, data, lookat=np.array([0.3, 0.0, 0.15]), distance=1.3)
    if not cv2.imwrite(str(out), image[..., ::-1]):
        raise UserError(f"could not write {out}")
    return out
