"""Quasi-static stepping of the TacTip dome: move the sensor, let the skin settle, check.

`SensorPhysics` moves the sensor along a straight line at the commanded speed ("arm
dynamics off": the sensor follows the commanded pose exactly). The physics scene is built
in the tool frame: the dome sits still at the world origin and the stimulus carrier
(twin.world.dome.carrier.add_stimulus_carrier, a heavy free body) is driven with a prescribed velocity
so that its pose is inv(tool2world) · stimulus2world at every step — see that function
for why. Contacts see the true sliding velocity, so friction shears the skin along the
path. `settle` then steps with the sensor at rest until the pins stop moving *as the
camera sees them* and returns a `Frame`. Poses given to and reported by this class are
lab poses (tool2world, 4×4, m).

Settling is quasi-static (DomeParams.quasi_static_settle): with the sensor at rest the
dome's velocities are zeroed before every step, so each implicit step is a damped Newton
iteration towards the equilibrium that the move left the skin near; friction keeps the
shear the path put in (the stuck contacts hold it), and a frame settles in a few steps.

Flex runs in MuJoCo can go wrong without NaN, so *every* step is checked and
any failure raises `PhysicsError` naming the scenario, the step, the pose and what failed:
  * a MuJoCo warning counter increased (mjData.warning);
  * NaN/Inf in qpos, qvel or the pin tips;
  * penetration deeper than `params.max_penetration` (contact dist < −bound);
  * net contact force above `params.max_force`;
  * a pin tip farther than `params.max_pin_excursion` from its rest position;
  * pins not settled within `params.max_settle_steps` (settle only).

Settling criterion (in camera pixels, DomeParams "Settling"): the pins are projected
through the camera model after every step; a frame is settled when over the last
`params.settle_steps` steps no pin's image moved more than `params.settle_px` (in contact)
or `params.free_settle_px` (no contact) away from where it is now; after
`params.cycle_after` steps, a contact frame cycling within `params.cycle_px` is accepted,
and one still cycling beyond it is iterated with under-relaxed steps
(`params.cycle_relaxation`).
Scale: the camera's focal length is ≈ 451 px and the pin tips lie 30–42 mm in front of
it, so 1 px ≈ 65–92 µm (≈ 75 µm) of lateral pin motion; motion along the viewing ray
(the apex pin moving in z) is nearly invisible, exactly as for the real camera. This is
what made "pins did not settle" go away at poses like x = 64, z = 4, γ = −40 on the
rectangle: the apex pin kept moving ±10 µm *in depth* (a contact-switching cycle), which
no camera sees.

A settled frame's pins are the flex's plus the sub-grid skin layer's offsets at the
commanded pose (twin.world.dome.flex.skin; `Frame.pins_tool`).

Pins are read from the state without recomputing MuJoCo's kinematics: with
``dof="trilinear"`` every flex vertex is a fixed linear combination of the grid nodes'
slide joints, so ``pins_tool = rest + J · (q_nodes − q_nodes_rest)`` with J measured once
(and verified) at construction (`PinMap`). mj_kinematics + mj_flex after every step cost
≈ 15 % of a step.

Deterministic: same model, inputs and call sequence → bit-identical pins (MuJoCo is
single-threaded here and nothing random is used).
"""

from __future__ import annotations

import math
import time
import weakref

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from twin.core.errors import PhysicsError
from twin.core.poses import invert_transform, make_transform
from twin.core.sensor import CameraModel
from twin.world.dome.base import Frame, physics_error
from twin.world.dome.flex.clearance import Clearance
from twin.world.dome.flex.grid import (
    DomeParams,
    TacTipHandles,
    apply_contact_law,
    flex_contact_geoms,
    pin_tips_tool,
    tool2world,
)
from twin.world.dome.flex.skin import SkinLayer, skin_layer

_IDENTITY = np.eye(3)


class PinMap:
    """Pin tips (tool frame, m) as an affine function of the flex nodes' joint positions.

    For an interpolated flex (``dof="trilinear"``) a vertex is Σ wᵢ·nodeᵢ and a node is
    its body position plus its slide joints' qpos, so pins = p0 + J·(q − q0) exactly.
    J is measured by unit perturbations of each node coordinate (exact for a linear map)
    and checked on a random configuration; if the check fails (a flex that is not
    interpolated), `exact` is False and callers recompute kinematics instead. The map
    belongs to the compiled model: `pin_map` measures it once per model.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles) -> None:
        qadr = []
        for b in handles.node_bodies:
            for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
                if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_SLIDE:
                    raise PhysicsError(f"flex node body {model.body(b).name!r} has a non-slide joint")
                qadr.append(model.jnt_qposadr[j])
        self.qadr = np.array(qadr, dtype=int)
        scratch = mujoco.MjData(model)
        scratch.qpos[:] = data.qpos
        self.q0 = scratch.qpos[self.qadr].copy()
        self.p0 = _pins_by_kinematics(model, scratch, handles)
        self.jacobian = np.zeros((self.p0.size, len(self.qadr)))
        step = 1e-3  # m; the map is linear, so the size only sets the rounding (≈ 1e-16 m)
        for k, a in enumerate(self.qadr):
            scratch.qpos[a] += step
            self.jacobian[:, k] = (_pins_by_kinematics(model, scratch, handles) - self.p0).ravel() / step
            scratch.qpos[a] -= step
        rng = np.random.default_rng(0)
        scratch.qpos[self.qadr] = self.q0 + rng.normal(0.0, 2e-3, len(self.qadr))
        err = np.max(np.abs(_pins_by_kinematics(model, scratch, handles) - self(scratch.qpos)))
        self.exact = bool(err < 1e-9)

    def __call__(self, qpos: np.ndarray) -> np.ndarray:
        """(127, 3) pin tips in the tool frame (m) for the full qpos vector."""
        return self.p0 + (self.jacobian @ (qpos[self.qadr] - self.q0)).reshape(self.p0.shape)


def _pins_by_kinematics(model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles) -> np.ndarray:
    """(127, 3) pin tips in the tool frame (m) of `data`'s qpos, by MuJoCo's kinematics."""
    mujoco.mj_kinematics(model, data)
    mujoco.mj_flex(model, data)
    return pin_tips_tool(model, data, handles)


#: each compiled model's PinMap, measured from its first state (≈ 2 ms; every episode
#: builds a SensorPhysics): the map is affine, so any state of the model gives the same one
_PIN_MAPS: weakref.WeakKeyDictionary[mujoco.MjModel, tuple[str, PinMap]] = weakref.WeakKeyDictionary()


def pin_map(model: mujoco.MjModel, data: mujoco.MjData, handles: TacTipHandles) -> PinMap:
    """The PinMap of the TacTip `handles` names in `model`, measured at `data`'s state the
    first time this model asks."""
    known = _PIN_MAPS.get(model)
    if known is None or known[0] != handles.prefix:
        known = _PIN_MAPS[model] = (handles.prefix, PinMap(model, data, handles))
    return known[1]


class SensorPhysics:
    """Moves the sensor, settles the dome and checks every step.

    model, data: a compiled scene with the TacTip added to the world body
      (twin.world.dome.flex.add_tactip) and the stimuli on twin.world.dome.carrier.add_stimulus_carrier's body;
      `handles` resolved against `model`. The dome's contact law (solref, solimp, margin)
      is written into `model` for every geom that can touch the dome
      (twin.world.dome.flex.grid.apply_contact_law), so it holds whichever side wins MuJoCo's priority mix.
    start_tool2world: the sensor's initial lab pose (4×4, m); must be out of contact.
    stimulus2world: the carrier body's lab pose (4×4, m); identity = its frame is the
      lab world frame.
    params: the DomeParams the dome was built with (settling and check bounds).
    scenario_name: named in every PhysicsError.
    work2world: 4×4 work frame in the world (m), used only to report poses in errors in
      the lab convention; world if None.
    angular_speed_deg_s: rotation speed used when a move rotates the sensor (deg/s).
    camera: the camera model whose pixels the settling criterion is expressed in
      (default: the paper's 640×480 camera, twin.core.sensor.CameraModel()).
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
        camera: CameraModel | None = None,
    ) -> None:
        self.model = model
        self.data = data
        self.handles = handles
        self.params = params
        self.scenario_name = scenario_name
        self.camera = CameraModel() if camera is None else camera
        self.world2work = np.eye(4) if work2world is None else invert_transform(np.asarray(work2world, float))
        self.angular_speed = np.radians(angular_speed_deg_s)
        body = model.body(carrier).id
        jnt = model.body_jntadr[body]
        if model.body_jntnum[body] != 1 or model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE:
            raise PhysicsError(
                f"[{scenario_name}] the stimulus carrier {carrier!r} must have exactly one free joint "
                "(twin.world.dome.carrier.add_stimulus_carrier)"
            )
        if handles.mount_body != 0:
            raise PhysicsError(f"[{scenario_name}] the TacTip must be added to the world body (static dome)")
        apply_contact_law(model, handles, params)
        self._qadr = int(model.jnt_qposadr[jnt])
        self._vadr = int(model.jnt_dofadr[jnt])
        #: dofs of the flex's grid nodes (zeroed by quasi-static settling)
        self._dome_dofs = np.concatenate(
            [np.arange(model.body_dofadr[b], model.body_dofadr[b] + model.body_dofnum[b]) for b in handles.node_bodies]
        ).astype(int)
        self.stimulus2world = np.eye(4) if stimulus2world is None else np.asarray(stimulus2world, float)
        mujoco.mj_kinematics(model, data)
        self._tool2scene = tool2world(model, data, handles)  # fixed pose of the tool frame in the scene
        self._steps = 0
        self._since_frame = 0
        self._warnings = data.warning.number.copy()
        self._commanded = np.asarray(start_tool2world, float)
        self._pin_map = pin_map(model, data, handles)
        #: the sub-grid skin (twin.world.dome.flex.skin); None when it is off or nothing can touch the dome
        self.skin: SkinLayer | None = None
        if params.skin_spacing > 0 and len(flex_contact_geoms(model, handles)):
            self.skin = skin_layer(self.camera.geometry, params.skin_spacing, params.skin_extent_deg)
        self.skin_seconds = 0.0  # wall time spent in the skin layer (s), for benchmarks
        self._skin_pressed: np.ndarray | None = None  # the skin nodes the last frame pressed
        self._saved_data: mujoco.MjData | None = None  # converged_pins' snapshot, allocated once
        self._quat_memo: dict[bytes, np.ndarray] = {}  # _quats_xyzw's last single rotations
        self._set_carrier(self._carrier_state(self._commanded, np.zeros(3), np.zeros(3)))
        mujoco.mj_forward(model, data)
        #: which stretches of a move need no stepping (DomeParams.jump_clear_moves)
        self._clearance = Clearance(model, data, handles, body) if params.jump_clear_moves else None
        self.rest_pins = pin_tips_tool(model, data, handles).copy()
        self._pins = self._read_pins()
        self._projected: np.ndarray | None = None  # _pins_px, once asked for
        self.step_seconds = 0.0  # wall time spent in physics steps (s), for benchmarks
        self._check(self._commanded)

    # ------------------------------------------------------------------ motion
    def move(self, target_tool2world: np.ndarray, speed_mm_s: float) -> int:
        """Move the tool frame to `target_tool2world` (4×4, m) along a straight line.

        Position moves at `speed_mm_s` (mm/s); orientation is slerped over the same steps
        (at most `angular_speed_deg_s`). Each physics step advances the commanded pose by
        one increment and prescribes the carrier velocity, so sliding is simulated.
        Returns the number of physics steps simulated: a level with
        DomeParams.jump_clear_moves carries the objects over the move's clear stretches at
        its start and end without stepping.
        """
        if not speed_mm_s > 0:
            raise PhysicsError(f"[{self.scenario_name}] move speed must be > 0 mm/s, got {speed_mm_s}")
        target = np.asarray(target_tool2world, float)
        start = self._commanded
        dt = self.model.opt.timestep
        delta_p = target[:3, 3] - start[:3, 3]
        relative = start[:3, :3].T @ target[:3, :3]
        turns = not bool((np.abs(relative - _IDENTITY) <= 1e-12).all())  # np.allclose(rtol=0) at a tenth the cost
        rotvec = Rotation.from_matrix(relative).as_rotvec() if turns else np.zeros(3)  # in the start tool frame
        n = int(
            max(
                1,
                np.ceil(np.linalg.norm(delta_p) / (speed_mm_s * 1e-3 * dt) - 1e-9),
                np.ceil(np.linalg.norm(rotvec) / (self.angular_speed * dt) - 1e-9),
            )
        )
        duration = n * dt
        v_tool = delta_p / duration  # lab frame, constant
        w_tool = start[:3, :3] @ (rotvec / duration)  # lab frame, constant (rotation axis is fixed)
        s = np.arange(0, n + 1) / n  # the start pose, then one pose per step
        if turns:
            rotations = start[:3, :3] @ Rotation.from_rotvec(rotvec[None, :] * s[:, None]).as_matrix()
        else:
            rotations = start[None, :3, :3]  # broadcast over the steps
        positions = start[:3, 3] + delta_p * s[:, None]
        qpos, qvel, carrier_rotations = self._carrier_states(rotations, positions, v_tool, w_tool)
        start_clear_to, end_clear_from = self._clear_ends(qpos[:, :3], carrier_rotations)
        k = 0
        if start_clear_to > 0:
            k = self._jump(qpos, qvel, 0, start_clear_to)  # a clear start: the skin is at rest
        steps = 0
        while k < n:
            self._set_carrier_velocity(qvel[k])  # the carrier is at pose k moving towards pose k + 1
            self._advance()
            k += 1
            steps += 1
            self._set_carrier((qpos[k], qvel[k]))  # snap onto the commanded path (removes ≤ nm drift)
            self._after_step_at(rotations[k if turns else 0], positions[k])
            if end_clear_from <= k < n and not self.data.ncon:
                k = self._jump(qpos, qvel, k, n)  # clear to the end: settling finishes the skin's spring-back
        self._commanded = target
        return steps

    def settle(self) -> Frame:
        """Step with the sensor at rest until the pins settle; return the settled Frame.

        Settled = over the last `settle_steps` steps no pin's image moved more than the
        tolerance (px, in u or in v) away from where it is now: `settle_px` in contact,
        `free_settle_px` without contact; after `cycle_after` steps `cycle_px` in contact
        (DomeParams "Settling").
        """
        p = self.params
        window = max(1, p.settle_steps)
        rest = self._carrier_state(self._commanded, np.zeros(3), np.zeros(3))
        history = [self._pins_px]
        band = np.inf
        relax = False  # under-relaxed steps once a contact frame cycles on (DomeParams.cycle_relaxation)
        nodes = self._pin_map.qadr
        for k in range(1, p.max_settle_steps + 1):
            self._set_carrier(rest)
            if relax:
                before = self.data.qpos[nodes]
            self._advance(still=True)
            if relax:
                self.data.qpos[nodes] = before + p.cycle_relaxation * (self.data.qpos[nodes] - before)
            self._set_carrier(rest)
            self._after_step(self._commanded)
            history.append(self._pins_px)
            if len(history) > window + 1:
                history.pop(0)
            if len(history) <= window:
                continue
            band = max(float(np.max(np.abs(self._pins_px - past))) for past in history[:-1])
            if relax:
                band /= p.cycle_relaxation  # the motion a full step would have made
            # out of contact there is no friction to hold a sheared skin, and the no-contact
            # frame is the tracker's reference: hold it to a tighter bound
            tol = p.settle_px if self.data.ncon else p.free_settle_px
            if k >= p.cycle_after and self.data.ncon:
                tol = max(tol, p.cycle_px)  # a stationary contact-switching cycle (DomeParams)
            if band < tol:
                force_world = self.contact_force_world()  # scene frame
                frame = Frame(
                    pins_tool=self._pins + self._skin_offsets(),
                    time=float(self.data.time),
                    contact_force=float(np.linalg.norm(force_world)),
                    contact_force_tool=self._tool2scene[:3, :3].T @ force_world,
                    n_steps=self._since_frame,
                    settled=True,
                    tool2world=self._commanded.copy(),
                    settle_steps=k,
                    last_motion_px=band,
                )
                self._since_frame = 0
                return frame
            relax = relax or (p.cycle_relaxation < 1 and k >= p.cycle_after and bool(self.data.ncon))
        self._fail(
            f"pins did not settle within {p.max_settle_steps} steps (over the last {window} steps a pin "
            f"moved {band:.4g} px; tolerance {p.settle_px:.4g} px in contact, {p.free_settle_px:.4g} px free)"
        )

    # ------------------------------------------------------------------ internals
    def _clear_ends(self, positions: np.ndarray, rotations: np.ndarray) -> tuple[int, int]:
        """For a move's carrier poses (positions (n + 1, 3), rotations (n + 1, 3, 3), scene
        frame, as `_carrier_states` gives them): the last pose of its clear start
        (0: none to jump; only out of contact, where the skin is at rest) and the first
        pose of its clear end (n + 1: none), clear as twin.world.dome.flex.clearance has
        it; (0, n + 1) when the level steps every move (DomeParams.jump_clear_moves)."""
        none = (0, len(positions))
        if self._clearance is None:
            return none
        in_contact = bool(self.data.ncon)
        # in contact only a clear end can be jumped, and the last pose, tested with no travel
        # (a smaller gap), tells cheaply when there is none: slides in contact skip the rest
        if in_contact and not self._clearance.poses_clear(self.data, positions[-1:], rotations[-1:])[0]:
            return none
        blocked = np.flatnonzero(~self._clearance.poses_clear(self.data, positions, rotations))
        if not len(blocked):  # the whole move is clear
            return (0, 0) if in_contact else (len(positions) - 1, 0)
        return (0 if in_contact else int(blocked[0]) - 1, int(blocked[-1]) + 1)

    def _jump(self, qpos: np.ndarray, qvel: np.ndarray, start: int, stop: int) -> int:
        """Carry the objects from pose `start` to pose `stop` of a move without stepping
        (the clock advances as if it had); returns `stop`."""
        self._set_carrier((qpos[stop], qvel[stop]))
        self.data.time += (stop - start) * self.model.opt.timestep
        return stop

    def _skin_offsets(self) -> np.ndarray:
        """(127, 3) pin-tip offsets (m, tool frame) from the skin layer at the commanded pose.

        Rays see the geoms where the last step left them: at rest, the commanded pose."""
        if self.skin is None:
            return np.zeros_like(self._pins)
        t0 = time.perf_counter()
        delta = self.skin.penetration(self.model, self.data, self._tool2scene, self.handles.dome_body)
        if self.skin.rim_in_contact(delta):
            self._fail(
                f"the contact reaches the rim of the skin layer's {self.skin.extent_deg:g}° cap "
                "(DomeParams.skin_extent_deg)"
            )
        try:
            pressures = self.skin.pressures(delta, self._skin_pressed)
        except PhysicsError as err:
            self._fail(str(err))
        self._skin_pressed = pressures > 0  # the next frame's guess: contacts move little between frames
        offsets = self.skin.pin_offsets(delta, pressures)
        self.skin_seconds += time.perf_counter() - t0
        return offsets

    def _carrier_state(self, pose: np.ndarray, v_tool: np.ndarray, w_tool: np.ndarray):
        """Carrier (qpos (7,), qvel (6,)) for a sensor at `pose` (4×4) moving at (v, ω)."""
        qpos, qvel, _ = self._carrier_states(pose[None, :3, :3], pose[None, :3, 3], v_tool, w_tool)
        return qpos[0], qvel[0]

    def _carrier_states(
        self, rotations: np.ndarray, positions: np.ndarray, v_tool: np.ndarray, w_tool: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Carrier qpos (n, 7), qvel (n, 6) and rotation matrices (n, 3, 3; scene frame) for
        sensor poses (rotations (n,3,3), or (1,3,3) for all, positions (n,3) m, lab frame)
        moving at linear velocity v and angular velocity ω (lab frame).

        carrier2scene = tool2scene · inv(tool2world) · stimulus2world. A point fixed in the
        lab, seen from a tool frame moving with linear velocity v (of the tool origin) and
        angular velocity ω (both lab frame), moves in the tool frame with
        ṗ_tool = −Rᵀ(v + ω × (p − o)). Free joint: linear velocity of the body origin in
        the scene frame, angular velocity in the body's local frame.
        """
        c2w_r, c2w_p = self.stimulus2world[:3, :3], self.stimulus2world[:3, 3]
        t2s_r, t2s_p = self._tool2scene[:3, :3], self._tool2scene[:3, 3]
        n = len(positions)
        r_scene = np.einsum("ij,nkj->nik", t2s_r, rotations)  # lab → scene rotations: T2S·Rᵀ
        c2s_r = r_scene @ c2w_r
        quat = self._quats_xyzw(c2s_r)
        r_scene, c2s_r, quat = (np.broadcast_to(a, (n,) + a.shape[1:]) for a in (r_scene, c2s_r, quat))
        c2s_p = np.einsum("nij,nj->ni", r_scene, c2w_p - positions) + t2s_p
        # ω × r of the lab point about the tool origin (np.cross costs ≈ 13 µs: skipped for translations)
        swept = np.cross(w_tool, c2w_p - positions) if w_tool.any() else np.zeros_like(positions)
        v_lab = -(v_tool + swept)
        v_scene = np.einsum("nij,nj->ni", r_scene, v_lab)
        w_scene = -(r_scene @ w_tool)
        w_local = np.einsum("nji,nj->ni", c2s_r, w_scene)
        qpos = np.column_stack([c2s_p, quat[:, 3], quat[:, :3]])
        return qpos, np.column_stack([v_scene, w_local]), c2s_r

    def _quats_xyzw(self, rotations: np.ndarray) -> np.ndarray:
        """(n, 4) scipy quaternions (x, y, z, w) of (n, 3, 3) rotations. A single rotation's
        is kept for the next call: a move at one orientation and the settle after it ask
        for the same one (Rotation.from_matrix costs ≈ 0.2 ms a call)."""
        if len(rotations) != 1:
            return Rotation.from_matrix(rotations).as_quat()
        key = rotations.tobytes()
        quat = self._quat_memo.get(key)
        if quat is None:
            if len(self._quat_memo) >= 4:
                self._quat_memo.clear()
            quat = self._quat_memo[key] = Rotation.from_matrix(rotations).as_quat()
        return quat

    def _set_carrier(self, state) -> None:
        self.data.qpos[self._qadr : self._qadr + 7] = state[0]
        self.data.qvel[self._vadr : self._vadr + 6] = state[1]

    def _set_carrier_velocity(self, qvel: np.ndarray) -> None:
        self.data.qvel[self._vadr : self._vadr + 6] = qvel

    def _advance(self, still: bool = False) -> None:
        """One mj_step; `still` (sensor at rest): zero the dome's velocities first when
        settling quasi-statically (DomeParams.quasi_static_settle)."""
        t0 = time.perf_counter()
        if still and self.params.quasi_static_settle:
            self.data.qvel[self._dome_dofs] = 0.0
        mujoco.mj_step(self.model, self.data)
        self.step_seconds += time.perf_counter() - t0

    def _read_pins(self) -> np.ndarray:
        if self._pin_map.exact:
            return self._pin_map(self.data.qpos)
        return _pins_by_kinematics(self.model, self.data, self.handles)

    def _after_step(self, pose: np.ndarray) -> None:
        self._read_step()
        self._check(pose)

    def _after_step_at(self, rotation: np.ndarray, position: np.ndarray) -> None:
        self._read_step()
        self._check(None, (rotation, position))

    def _read_step(self) -> None:
        """Count the step and read the pins (m, tool frame); their images follow when asked
        for (`_pins_px`)."""
        self._steps += 1
        self._since_frame += 1
        self._pins = self._read_pins()
        self._projected = None

    @property
    def _pins_px(self) -> np.ndarray:
        """(127, 2) px: the current pins through the camera, projected when first asked for
        (settling asks after every step, a move only after its last)."""
        if self._projected is None:
            self._projected = self.camera.project_tool_points(self._pins)
        return self._projected

    def _check(self, pose: np.ndarray | None, at: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Per-step sanity checks (module docstring); `pose` (4×4) or `at` (R, p) names the
        commanded pose in an error."""
        d, p = self.data, self.params
        where = (lambda: pose) if pose is not None else (lambda: make_transform(*at))
        counts = d.warning.number
        if (counts > self._warnings).any():
            names = [mujoco.mjtWarning(i).name for i in np.flatnonzero(counts > self._warnings)]
            self._warnings = counts.copy()
            self._fail(f"MuJoCo warning {', '.join(names)}", where())
        if not math.isfinite(d.qpos.sum() + d.qvel.sum() + self._pins.sum()):  # a NaN/Inf anywhere propagates
            self._fail("NaN/Inf in the state (qpos, qvel or pin tips)", where())
        if d.ncon:
            depth = -float(d.contact.dist[: d.ncon].min())
            if depth > p.max_penetration:
                self._fail(f"penetration {depth * 1e3:.3f} mm > {p.max_penetration * 1e3:.3f} mm", where())
            # net contact force on the object = constraint force on the carrier's free joint
            force = math.hypot(*d.qfrc_constraint[self._vadr : self._vadr + 3])
            if force > p.max_force:
                self._fail(f"contact force {force:.3g} N > {p.max_force:.3g} N", where())
        moved = self._pins - self.rest_pins
        excursion2 = float(np.einsum("ij,ij->i", moved, moved).max())
        if excursion2 > p.max_pin_excursion**2:
            self._fail(
                f"a pin moved {math.sqrt(excursion2) * 1e3:.3f} mm from rest (> {p.max_pin_excursion * 1e3:.3f} mm)",
                where(),
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

    def _fail(self, what: str, pose: np.ndarray | None = None) -> None:
        raise physics_error(
            self.scenario_name,
            f"step {self._steps}",
            self.data.time,
            self.world2work,
            self._commanded if pose is None else pose,
            what,
        )

    @property
    def steps(self) -> int:
        """Total physics steps taken."""
        return self._steps

    def converged_pins(self, settle_px: float | None = None, max_steps: int = 400) -> np.ndarray:
        """(127, 3) pin tips in the tool frame (m), the kind `settle` returns, of the state
        the current frame was settling towards; the simulation is left exactly as it was.
        "How far is this frame from its equilibrium?" (twin.analysis.sweep's settling error).

        Call right after `settle`: settles on at the commanded pose with `settle` itself
        (same stepping and checks, the stationary-cycle rule included) until a step moves
        no pin's image more than `settle_px` (px per step). Default: params.settle_px / 20,
        at least params.free_settle_px and 0.5 px/s × timestep. Friction contacts creep
        on for as long as one steps (≈ 0.1–0.3 px/s of pin motion on the sweep's slide
        frames at every time step, measured), so a tighter band is never met. Then all of
        mjData and the bookkeeping (step counters, pins, warnings, step_seconds,
        skin_seconds, the skin's pressed nodes) are restored: what follows is
        bit-identical to a run without this call. Raises PhysicsError if not settled
        within `max_steps` steps.
        """
        p = self.params
        creep_px = 0.5 * self.model.opt.timestep
        band = max(p.settle_px / 20.0, p.free_settle_px, creep_px) if settle_px is None else float(settle_px)
        if self._saved_data is None:
            self._saved_data = mujoco.MjData(self.model)
        saved_data = self._saved_data
        mujoco.mj_copyData(saved_data, self.model, self.data)
        saved = (
            self._steps,
            self._since_frame,
            self._pins,
            self._projected,
            self._warnings.copy(),
            self.step_seconds,
            self.skin_seconds,
            self._skin_pressed,
        )
        self.params = p.with_(
            settle_px=band, free_settle_px=min(p.free_settle_px, band), settle_steps=1, max_settle_steps=max_steps
        )
        try:
            pins = self.settle().pins_tool
        finally:
            self.params = p
            mujoco.mj_copyData(self.data, self.model, saved_data)
            (
                self._steps,
                self._since_frame,
                self._pins,
                self._projected,
                self._warnings,
                self.step_seconds,
                self.skin_seconds,
                self._skin_pressed,
            ) = saved
        return pins
