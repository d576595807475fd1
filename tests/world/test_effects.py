"""Effects: each changes what is simulated, and an effect that is off is not
built and costs nothing — checked on the compiled model and on the constraint rows MuJoCo
actually creates (mjData.ncon / nefc) for the flex dome, whose contact MuJoCo solves (the
compliant dome's own: tests/world/test_dome_compliant.py::test_no_contact_effect_solves_nothing),
never with timing asserts.

Scenes through twin.runs.sim_env.SimEnvironment on the rectangle's +x edge (work x = 60).
"""

from __future__ import annotations

import numpy as np
import pytest

from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.sim_env import SimEnvironment
from twin.sensing.tracker import PinTracker


def _env(
    effects: list[str], fidelity: str = "default", start: Pose = Pose(54, 0, -5, 0, 0, 0), dome: str = "compliant"
) -> SimEnvironment:
    scenario = scenario_from_dict(
        {
            "name": f"effects_{'_'.join(effects) or 'none'}",
            "object": {"name": "rectangle"},
            "fidelity": fidelity,
            "effects": effects,
            "dome": dome,
        }
    )
    return SimEnvironment(scenario, start_pose=start)


def _record_steps(env: SimEnvironment) -> list[tuple[int, int, np.ndarray]]:
    """Hook the physics so every step's (ncon, nefc, contact dims) is recorded."""
    physics, data, log = env.physics, env.scene.data, []
    inner = physics._check

    def check(*args, **kwargs):
        log.append((int(data.ncon), int(data.nefc), data.contact.dim[: data.ncon].copy()))
        return inner(*args, **kwargs)

    physics._check = check
    return log


@pytest.mark.parametrize("fidelity", ["fast", "default", "reference"])
def test_friction_off_gives_no_shear(fidelity):
    """Frictionless: a slide along the edge ends where a static press at the end pose does."""
    env = _env(["contact"], fidelity)
    env.reset()
    env.move_to(Pose(54, -6, 3, 0, 0, 0))
    for y in (-3.0, 0.0, 3.0, 6.0):
        env.move_to(Pose(54, y, 3, 0, 0, 0))
    slid = env.observe().pins_px
    env.reset()
    env.move_to(Pose(54, 6, -5, 0, 0, 0))
    env.move_to(Pose(54, 6, 3, 0, 0, 0))
    static = env.observe().pins_px
    assert np.max(np.linalg.norm(slid - static, axis=1)) < 0.3  # px

    # with friction the same slide leaves the skin sheared: ≫ the frictionless 0.3 px
    env = _env(["contact", "friction"], fidelity)
    env.reset()
    env.move_to(Pose(54, -6, 3, 0, 0, 0))
    for y in (-3.0, 0.0, 3.0, 6.0):
        env.move_to(Pose(54, y, 3, 0, 0, 0))
    assert np.mean(np.linalg.norm(env.observe().pins_px - static, axis=1)) > 1.5


def test_friction_off_builds_no_friction_rows():
    off = _env(["contact"], dome="flex")
    on = _env(["contact", "friction"], dome="flex")
    flex = off.scene.dome_handles.flex
    assert off.scene.model.flex_condim[flex] == 1 and on.scene.model.flex_condim[flex] == 3
    logs = {}
    for name, env in (("off", off), ("on", on)):
        env.reset()
        logs[name] = _record_steps(env)
        env.move_to(Pose(54, 0, 3, 0, 0, 0))
        env.move_to(Pose(54, 3, 3, 0, 0, 0))
    contact_steps = {k: [s for s in v if s[0] > 0] for k, v in logs.items()}
    assert contact_steps["off"] and contact_steps["on"]
    # frictionless: one constraint row per contact (normal only), every contact dim 1
    assert all(nefc == ncon and np.all(dims == 1) for ncon, nefc, dims in contact_steps["off"])
    # frictional (elliptic cone, condim 3): three rows per contact
    assert all(nefc == 3 * ncon and np.all(dims == 3) for ncon, nefc, dims in contact_steps["on"])


def test_contact_off_builds_no_collisions_and_no_constraints():
    env = _env([], dome="flex")
    model = env.scene.model
    carrier = model.body("stimulus").id
    object_geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == carrier]
    assert object_geoms
    assert all(model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0 for g in object_geoms)
    rest = env.reset().pins_px
    log = _record_steps(env)
    env.move_to(Pose(54, 0, 4, 0, 0, 0))  # "pressing" 4 mm into an object that is not there
    env.move_to(Pose(54, 6, 4, 0, 0, 0))
    assert log and all(ncon == 0 and nefc == 0 for ncon, nefc, _ in log)
    obs = env.observe()
    assert obs.truth["contact_force_n"] == 0.0
    assert np.max(np.linalg.norm(obs.pins_px - rest, axis=1)) < 0.05


def test_render_off_gives_projected_pins_and_no_frame():
    env = _env(["contact", "friction"])
    assert env._renderer is None  # nothing to render with: not built
    obs = env.reset()
    assert obs.frame is None
    assert obs.pins_px.shape == (127, 2)
    np.testing.assert_array_equal(obs.pins_px, obs.truth["pins_px"])


def test_render_on_tracked_pins_agree_with_projected_pins():
    """Pins tracked from rendered frames (twin.sensing.tracker) vs the projected truth: ≤ 1 px RMS."""
    env = _env(["contact", "friction", "render"])
    try:
        reference = env.reset()
        assert reference.frame is not None and reference.pins_px is None
        tracker = PinTracker(reference.frame)
        poses = [Pose(60, 0, 2, 0, 0, 0), Pose(60, 0, 4, 0, 0, 0), Pose(57, 3, 3, 0, 0, 30), Pose(57, 6, 3, 0, 0, 30)]
        errors, moved = [], []
        for pose in poses:
            env.move_to(pose)
            obs = env.observe()
            assert obs.frame.shape == (env.camera.height, env.camera.width, 3)
            truth = obs.truth["pins_px"]
            result = tracker.track(obs.frame)
            found = result.found
            assert found.sum() >= 120
            errors.append(np.sqrt(np.mean(np.sum((result.pins_px[found] - truth[found]) ** 2, axis=1))))
            moved.append(np.max(np.linalg.norm(truth - reference.truth["pins_px"], axis=1)))
        assert max(errors) < 1.0, errors
        assert min(moved) > 3.0  # these are real contact frames, not near-rest ones
    finally:
        env.close()
