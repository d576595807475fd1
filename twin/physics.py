"""Quasi-static stepping of the TacTip dome: move the sensor, let the skin settle, check.

`SensorPhysics` moves the sensor along a straight line at the commanded speed ("arm
dynamics off": the sensor follows the commanded pose exactly). The physics scene is built
in the tool frame: the dome sits still at the world origin and the stimulus carrier
(twin.dome.add_stimulus_carrier, a heavy free body) is driven with a prescribed velocity
so that its pose is inv(tool2world) · stimulus2world at every step — see that function
for why. Contacts see the true sliding velocity, so friction shears the skin along the
path. `settle` then steps with the sensor at rest until the pins stop moving and returns
a `Frame`. Poses given to and reported by this class are lab poses (tool2world).

Flex runs in MuJoCo can go wrong without NaN (DESIGN §5), so *every* step is checked and
any failure raises `PhysicsError` naming the scenario, the step, the pose and what failed:
  * a MuJoCo warning counter increased (mjData.warning);
  * NaN/Inf in qpos, qvel or the flex vertices;
  * penetration deeper than `params.max_penetration` (contact dist < −bound);
  * total contact force above `params.max_force`;
  * a pin tip farther than `params.max_pin_excursion` from its rest position;
  * pins not settled within `params.max_settle_steps` (settle only).

Settling criterion: the largest pin-tip speed in the tool frame, |Δpin|/timestep, is below
`params.settle_speed` (in contact) or `params.free_settle_speed` (no contact) for
`params.settle_steps` consecutive steps. In contact the floor is MuJoCo's soft-friction
creep (≈ 0.02 mm/s with impratio 30), so a contact frame is "settled" to ≈ 1 µm/step.

Deterministic: same model, inputs and call sequence → bit-identical pins (MuJoCo is
single-threaded here and nothing random is used).
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from twin.dome import DomeParams, TacTipHandles, pin_tips_tool, tool2world
from twin.errors import PhysicsError
from twin.poses import Pose, invert_transform, make_transform


@dataclass(frozen=True)
class Frame:
    """One settled sensor reading.

    pins_tool: (127, 3) pin tip positions in the tool frame (m), pin order of twin.tactip.
    time: simulation time (s) when the frame settled.
    contact_force: magnitude of the total contact force on the dome (N).
    contact_force_tool: (3,) total contact force on the dome in the tool frame (N).
    n_steps: physics steps since the previous frame (move + settle).
    settled: True if the settling criterion was met (always True: otherwise settle raises).
    tool2world: 4×4 pose of the tool frame at this frame (m).
    """

    pins_tool: np.ndarray
    time: float
    contact_force: float
    contact_force_tool: np.ndarray
    n_steps: int
    settled: bool
    tool2world: np.ndarray


class SensorPhysics:
    """Moves the sensor, settles the dome and checks every step.

    model, data: a compiled scene with the TacTip added to the world body
      (twin.dome.add_tactip) and the stimuli on twin.dome.add_stimulus_carrier's body;
      `handles` resolved against `model`.
    start_tool2world: the sensor's initial lab pose (4×4, m); must be out of contact.
    stimulus2world: the carrier body's lab pose (4×4, m); identity = its frame is the
      lab world frame.
    params: the DomeParams the dome was built with (settling and check bounds).
    scenario_name: named in every PhysicsError.
    work2world: 4×4 work frame in the world (m), used only to report poses in errors in
      the lab convention; world if None.
    angular_speed_deg_s: rotation speed used when a move rotates the sensor (deg/s).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        handles: TacTipHandles,
        params: DomeParams,
        scenario_name: str,
        start_tool2world: np.ndarray,
        stimulus2world: np.ndarray | None = None,
        carrier: str = "stimulus",
        work2world: np.ndarray | None = None,
        angular_speed_deg_s: float = 45.0,
    ) -> None:
        self.model = model
        self.data = data
        self.handles = handles
        self.params = params
        self.scenario_name = scenario_name
        self.world2work = np.eye(4) if work2world is None else invert_transform(np.asarray(work2world, float))
        self.angular_speed = np.radians(angular_speed_deg_s)
        body = model.body(carrier).id
        jnt = model.body_jntadr[body]
        if model.body_jntnum[body] != 1 or model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE:
            raise PhysicsError(
                f"[{scenario_name}] the stimulus carrier {carrier!r} must have exactly one free joint "
                "(twin.dome.add_stimulus_carrier)"
            )
        if handles.mount_body != 0:
            raise PhysicsError(f"[{scenario_name}] the TacTip must be added to the world body (static dome)")
        self._qadr = int(model.jnt_qposadr[jnt])
        self._vadr = int(model.jnt_dofadr[jnt])
        self.stimulus2world = np.eye(4) if stimulus2world is None else np.asarray(stimulus2world, float)
        mujoco.mj_kinematics(model, data)
        self._tool2scene = tool2world(model, data, handles)  # fixed pose of the tool frame in the scene
        self._steps = 0
        self._since_frame = 0
        self._warnings = self._warning_counts()
        self._commanded = np.asarray(start_tool2world, float)
        self._place_carrier(self._commanded, np.zeros(3), np.zeros(3))
        mujoco.mj_forward(model, data)
        self.rest_pins = pin_tips_tool(model, data, handles).copy()
        self._pins = self.rest_pins.copy()
        self._check(self._commanded)

    # ------------------------------------------------------------------ motion
    def move(self, target_tool2world: np.ndarray, speed_mm_s: float) -> int:
        """Move the tool frame to `target_tool2world` (4×4, m) along a straight line.

        Position moves at `speed_mm_s` (mm/s); orientation is slerped over the same steps
        (at most `angular_speed_deg_s`). Each physics step advances the commanded pose by
        one increment and prescribes the carrier velocity, so sliding is simulated.
        Returns the number of steps taken.
        """
        if not speed_mm_s > 0:
            raise PhysicsError(f"[{self.scenario_name}] move speed must be > 0 mm/s, got {speed_mm_s}")
        target = np.asarray(target_tool2world, float)
        start = self._commanded
        dt = self.model.opt.timestep
        delta_p = target[:3, 3] - start[:3, 3]
        rotvec = Rotation.from_matrix(start[:3, :3].T @ target[:3, :3]).as_rotvec()  # in the start tool frame
        n = int(max(1, np.ceil(np.linalg.norm(delta_p) / (speed_mm_s * 1e-3 * dt) - 1e-9),
                    np.ceil(np.linalg.norm(rotvec) / (self.angular_speed * dt) - 1e-9)))
        duration = n * dt
        v_tool = delta_p / duration  # lab frame, constant
        w_tool = start[:3, :3] @ (rotvec / duration)  # lab frame, constant (rotation axis is fixed)
        for k in range(1, n + 1):
            s = k / n
            pose = make_transform(
                start[:3, :3] @ Rotation.from_rotvec(rotvec * s).as_matrix(), start[:3, 3] + delta_p * s
            )
            self._step(pose, v_tool, w_tool)
        self._commanded = target
        return n

    def settle(self) -> Frame:
        """Step with the sensor at rest until the pins settle; return the settled Frame."""
        p = self.params
        calm = 0
        for _ in range(p.max_settle_steps):
            before = self._pins
            self._step(self._commanded, np.zeros(3), np.zeros(3))
            speed = float(np.max(np.abs(self._pins - before))) / self.model.opt.timestep
            # out of contact there is no friction creep, so hold the pins to a tighter bound
            tol = p.settle_speed if self.data.ncon else p.free_settle_speed
            calm = calm + 1 if speed < tol else 0
            if calm >= p.settle_steps:
                force_world = self.contact_force_world()  # scene frame
                frame = Frame(
                    pins_tool=self._pins.copy(),
                    time=float(self.data.time),
                    contact_force=float(np.linalg.norm(force_world)),
                    contact_force_tool=self._tool2scene[:3, :3].T @ force_world,
                    n_steps=self._since_frame,
                    settled=True,
                    tool2world=self._commanded.copy(),
                )
                self._since_frame = 0
                return frame
        self._fail(
            f"pins did not settle within {p.max_settle_steps} steps "
            f"(last max pin speed {speed * 1e3:.4g} mm/s > {p.settle_speed * 1e3:.4g} mm/s)"
        )

    # ------------------------------------------------------------------ internals
    def _carrier_pose_velocity(self, pose: np.ndarray, v_tool: np.ndarray, w_tool: np.ndarray):
        """Carrier pose in the scene and its free-joint velocity for a sensor moving at (v, ω).

        carrier2scene = tool2scene · inv(tool2world) · stimulus2world. A point fixed in the
        lab, seen from a tool frame moving with linear velocity v (of the tool origin) and
        angular velocity ω (both lab frame), moves in the tool frame with
        ṗ_tool = −Rᵀ(v + ω × (p − o)). Free joint: linear velocity of the body origin in
        the scene frame, angular velocity in the body's local frame.
        """
        carrier2world = self.stimulus2world
        world2tool = invert_transform(pose)
        carrier2scene = self._tool2scene @ world2tool @ carrier2world
        r_scene = self._tool2scene[:3, :3] @ pose[:3, :3].T  # lab → scene rotation
        origin_world = carrier2world[:3, 3]
        v_lab = -(v_tool + np.cross(w_tool, origin_world - pose[:3, 3]))
        v_scene = r_scene @ v_lab
        w_scene = -(r_scene @ w_tool)
        w_local = carrier2scene[:3, :3].T @ w_scene
        return carrier2scene, v_scene, w_local

    def _place_carrier(self, pose: np.ndarray, v_tool: np.ndarray, w_tool: np.ndarray) -> None:
        d = self.data
        carrier2scene, v, w = self._carrier_pose_velocity(pose, v_tool, w_tool)
        d.qpos[self._qadr: self._qadr + 3] = carrier2scene[:3, 3]
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(carrier2scene[:3, :3]).ravel())
        d.qpos[self._qadr + 3: self._qadr + 7] = quat
        d.qvel[self._vadr: self._vadr + 3] = v
        d.qvel[self._vadr + 3: self._vadr + 6] = w

    def _step(self, pose: np.ndarray, v_tool: np.ndarray, w_tool: np.ndarray) -> None:
        """One physics step that ends with the sensor at `pose` (tool2world), moving at (v, ω).

        The carrier's velocity is prescribed before the step (so the contacts see the
        sliding velocity) and its pose is snapped onto the commanded one after it
        (removing the ≤ nm drift contact forces impart on the heavy carrier).
        """
        m, d = self.model, self.data
        self._place_carrier(self._previous_pose(), v_tool, w_tool)
        mujoco.mj_step(m, d)
        self._place_carrier(pose, v_tool, w_tool)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_flex(m, d)
        self._last_pose = pose
        self._steps += 1
        self._since_frame += 1
        self._pins = pin_tips_tool(m, d, self.handles)
        self._check(pose)

    def _previous_pose(self) -> np.ndarray:
        return getattr(self, "_last_pose", self._commanded)

    def _check(self, pose: np.ndarray) -> None:
        d, p = self.data, self.params
        counts = self._warning_counts()
        if np.any(counts > self._warnings):
            names = [mujoco.mjtWarning(i).name for i in np.flatnonzero(counts > self._warnings)]
            self._warnings = counts
            self._fail(f"MuJoCo warning {', '.join(names)}", pose)
        if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel)) and np.all(np.isfinite(self._pins))):
            self._fail("NaN/Inf in the state (qpos, qvel or pin tips)", pose)
        if d.ncon:
            depth = -float(np.min(d.contact.dist[: d.ncon]))
            if depth > p.max_penetration:
                self._fail(f"penetration {depth * 1e3:.3f} mm > {p.max_penetration * 1e3:.3f} mm", pose)
            force = float(np.linalg.norm(self.contact_force_world()))
            if force > p.max_force:
                self._fail(f"contact force {force:.3g} N > {p.max_force:.3g} N", pose)
        excursion = float(np.max(np.linalg.norm(self._pins - self.rest_pins, axis=1)))
        if excursion > p.max_pin_excursion:
            self._fail(
                f"a pin moved {excursion * 1e3:.3f} mm from rest (> {p.max_pin_excursion * 1e3:.3f} mm)", pose
            )

    def contact_force_world(self) -> np.ndarray:
        """(3,) total force of all contacts on the dome, scene frame (N) (= tool frame if the
        TacTip was added at the scene origin)."""
        d = self.data
        total = np.zeros(3)
        if not d.ncon:
            return total
        con = d.contact
        flex = self.handles.flex
        ours = (con.flex[: d.ncon, 0] == flex) | (con.flex[: d.ncon, 1] == flex)
        for dim in (1, 3, 4, 6):
            sel = np.flatnonzero(ours & (con.dim[: d.ncon] == dim) & (con.efc_address[: d.ncon] >= 0))
            if not len(sel):
                continue
            adr = con.efc_address[sel]
            frames = con.frame[sel].reshape(-1, 3, 3)
            k = min(dim, 3)
            f_local = np.stack([d.efc_force[adr + j] for j in range(k)], axis=1)  # normal, t1, t2
            f = np.einsum("nj,nji->ni", f_local, frames[:, :k, :])
            # force on the dome: the contact frame normal points from geom1 to geom2
            sign = np.where(con.flex[sel, 1] == flex, 1.0, -1.0)
            total += (sign[:, None] * f).sum(axis=0)
        return total

    def _warning_counts(self) -> np.ndarray:
        return np.array([w.number for w in self.data.warning], dtype=np.int64)

    def _fail(self, what: str, pose: np.ndarray | None = None) -> None:
        pose = self._commanded if pose is None else pose
        lab = Pose.from_matrix(self.world2work @ pose)
        raise PhysicsError(
            f"[{self.scenario_name}] step {self._steps} (t = {self.data.time:.4f} s) at pose "
            f"x={lab.x:.3f} y={lab.y:.3f} z={lab.z:.3f} mm, α={lab.alpha:.2f} β={lab.beta:.2f} "
            f"γ={lab.gamma:.2f} deg: {what}"
        )

    @property
    def steps(self) -> int:
        """Total physics steps taken."""
        return self._steps


def edge_scene(params: DomeParams, friction: bool = True, object_friction: float = 1.0, scenario: str = "edge",
               start_tool2world: np.ndarray | None = None):
    """A minimal scene for tests and benchmarks: a 60 × 60 × 20 mm box whose top face is
    z = 0 with a straight edge along y at x = 0 (box at x < 0), and the TacTip pointing
    down (tool z = −world z). Returns (model, data, handles, SensorPhysics)."""
    from twin.dome import add_stimulus_carrier, add_tactip
    from twin.tactip import TacTipGeometry

    spec = mujoco.MjSpec()
    carrier = add_stimulus_carrier(spec)
    carrier.add_geom(name="rectangle", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.03, 0.01],
                     pos=[-0.03, 0.0, -0.01], friction=[object_friction, 0.005, 0.0001])
    handles = add_tactip(spec, spec.worldbody, TacTipGeometry(), params, friction)
    model = spec.compile()
    data = mujoco.MjData(model)
    handles = handles.resolve(model)
    start = sensor_down(0.0, 0.0, -2.0) if start_tool2world is None else start_tool2world
    return model, data, handles, SensorPhysics(model, data, handles, params, scenario, start)


def sensor_down(x_mm: float, y_mm: float, depth_mm: float, gamma_deg: float = 0.0) -> np.ndarray:
    """tool2world of a sensor pointing straight down (tool z = −world z), apex at
    (x, y, −depth) mm, rotated by γ about its own axis (deg)."""
    down = np.diag([1.0, -1.0, -1.0])
    rot = down @ Rotation.from_euler("z", gamma_deg, degrees=True).as_matrix()
    return make_transform(rot, np.array([x_mm, y_mm, -depth_mm]) * 1e-3)


def benchmark_physics(levels: list[str] | None = None, repeats: int = 3, speed_mm_s: float = 15.0,
                      verbose: bool = True) -> list[dict]:
    """ms of physics per settled frame for each fidelity level, best of `repeats`.

    Contour-following-like sequence on the edge scene: press to 3 mm at the edge, then
    five 3 mm slide steps along the edge (frames every e = 3 mm) at `speed_mm_s`, then
    lift off. Each frame = move + settle. Returns one dict per level: level, ms_per_frame
    (best), steps_per_frame (mean), ms_per_step.
    """
    import time

    from twin.dome import FIDELITY_LEVELS

    rows = []
    for level in levels or list(FIDELITY_LEVELS):
        params = FIDELITY_LEVELS[level]
        best = np.inf
        for _ in range(repeats):
            model, data, handles, physics = edge_scene(params, scenario=f"benchmark-{level}")
            poses = [sensor_down(0, 0, 3)] + [sensor_down(0, 3 * k, 3) for k in range(1, 6)] + [sensor_down(0, 15, -2)]
            t0 = time.perf_counter()
            for pose in poses:
                physics.move(pose, speed_mm_s)
                physics.settle()
            elapsed = time.perf_counter() - t0
            if elapsed < best:
                best, steps = elapsed, physics.steps
        row = {
            "level": level,
            "ms_per_frame": 1e3 * best / len(poses),
            "steps_per_frame": steps / len(poses),
            "ms_per_step": 1e3 * best / steps,
        }
        rows.append(row)
        if verbose:
            print(f"{level:10s} {row['ms_per_frame']:7.1f} ms/frame  {row['steps_per_frame']:5.1f} steps/frame  "
                  f"{row['ms_per_step']:.3f} ms/step")
    return rows


if __name__ == "__main__":
    benchmark_physics()
