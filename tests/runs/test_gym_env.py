"""The Gymnasium wrapper: the standard API (check_env, no warnings), registration, a reward
that measures progress, and seeds that reach the simulator."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

import twin
from twin.core.scenario import scenario_from_dict
from twin.runs.gym_env import ContourFollowingEnv

SCENARIO = {
    "name": "gym_circle",
    "object": {"name": "small_circle"},
    "fidelity": "fast",
    "effects": ["contact"],
    "protocol": {"kind": "contour", "max_steps": 5},
}
NOISY = {
    **SCENARIO,
    "name": "gym_noisy",
    "effects": ["contact", "render", "camera_noise"],
    "sensor": {"camera": {"width": 320, "height": 240, "noise_std": 4}},
}


def test_check_env_passes_without_warnings() -> None:
    env = ContourFollowingEnv(scenario_from_dict(SCENARIO))
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env, skip_render_check=True)
        assert not caught, [f"{w.category.__name__}: {w.message}" for w in caught]
    finally:
        env.close()


def test_reward_measures_progress_and_episode_truncates() -> None:
    env = ContourFollowingEnv(scenario_from_dict(SCENARIO))
    try:
        obs, info = env.reset(seed=0)
        assert obs.shape == (254,) and np.all(np.isfinite(obs))
        assert np.abs(obs).max() > 0.5  # pressing on the edge moves pins
        # Start is the lowest point of the circle (object frame): counter-clockwise is +x,
        # which is +x in the work frame too. Actions are fractions of max_step_mm (5 mm).
        _, r_forward, *_ = env.step(np.array([0.6, 0.0], dtype=np.float32))
        _, r_back, *_ = env.step(np.array([-0.6, 0.0], dtype=np.float32))
        assert r_forward > 0 > r_back
        truncated = False
        for _ in range(5):
            *_, terminated, truncated, _ = env.step(np.zeros(2, dtype=np.float32))
        assert truncated
    finally:
        env.close()


def test_registered_id_makes_the_env() -> None:
    env = gym.make(twin.GYM_ID, scenario=scenario_from_dict(SCENARIO))
    try:
        assert isinstance(env.unwrapped, ContourFollowingEnv)
    finally:
        env.close()


def test_seed_reaches_the_simulator() -> None:
    """With camera noise on, two seeds give different observations and one seed the same
    ones (the wrapper's np_random seeds the backend)."""
    env = ContourFollowingEnv(scenario_from_dict(NOISY))
    try:
        first = [env.reset(seed=1)[0], env.step(np.array([0.5, 0.0], dtype=np.float32))[0]]
        again = [env.reset(seed=1)[0], env.step(np.array([0.5, 0.0], dtype=np.float32))[0]]
        other = [env.reset(seed=2)[0], env.step(np.array([0.5, 0.0], dtype=np.float32))[0]]
    finally:
        env.close()
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)
    assert all(np.abs(a - c).max() > 1e-3 for a, c in zip(first, other))


def test_vector_envs_sync_and_async_are_seeded_per_env() -> None:
    """gymnasium.make_vec over the registered env, in this process and in worker processes:
    reset(seed=s) seeds env i with s + i (different camera noise), and the two modes give
    the same observations for the same seed."""
    steps = {}
    for mode in ("sync", "async"):
        envs = gym.make_vec(
            twin.GYM_ID,
            num_envs=2,
            vectorization_mode=mode,
            vector_kwargs={"context": "forkserver"} if mode == "async" else {},
            scenario=scenario_from_dict(NOISY),
        )
        try:
            first, _ = envs.reset(seed=5)
            after, *_ = envs.step(np.full((2, 2), 0.5, dtype=np.float32))
        finally:
            envs.close()
        assert first.shape == (2, 254) and np.all(np.isfinite(after))
        assert np.abs(first[0] - first[1]).max() > 1e-3  # each env its own seed
        steps[mode] = (first, after)
    for a, b in zip(steps["sync"], steps["async"]):
        np.testing.assert_array_equal(a, b)


def test_worker_vector_steps_as_the_sync_vector_does() -> None:
    """gymnasium.make_vec without a mode: the registered vector entry point
    (twin.runs.vector_env), 3 envs in 2 worker processes. Over 7 steps with each env's own
    actions, a truncation after the scenario's 5 steps and the next-step autoreset, it
    gives what gymnasium's own sync vector gives, bit for bit: observations, rewards,
    flags, rendered frames; reset(seed=s) seeds env i with s + i; set_attr and get_attr
    reach each env."""
    actions = np.random.default_rng(0).uniform(-0.5, 0.5, (7, 3, 2)).astype(np.float32)
    runs = {}
    for mode, options in (("sync", {}), (None, {"workers": 2})):
        envs = gym.make_vec(
            twin.GYM_ID, num_envs=3, vectorization_mode=mode, scenario=scenario_from_dict(NOISY), **options
        )
        try:
            runs[mode] = [(envs.reset(seed=11)[0],)] + [envs.step(a)[:4] for a in actions] + [envs.render()]
            envs.set_attr("max_step_mm", [1.0, 2.0, 3.0])
            assert envs.get_attr("max_step_mm") == (1.0, 2.0, 3.0)
        finally:
            envs.close()
        if mode is None:
            assert type(envs.unwrapped).__name__ == "WorkerVectorEnv" and envs.unwrapped.env_groups == [(0, 2), (2, 1)]
    (first,) = runs[None][0]
    assert first.shape == (3, 254) and np.abs(first[0] - first[1]).max() > 1e-3  # each env its own seed
    truncated = [step[3] for step in runs[None][1:-1]]
    assert truncated[4].all() and not truncated[5].any()  # the 5th step truncates, the 6th resets
    assert np.all(runs[None][6][1] == 0.0)  # a reset step earns nothing
    for ours, theirs in zip(runs[None], runs["sync"]):
        for a, b in zip(ours, theirs):
            np.testing.assert_array_equal(a, b)


def test_worker_vector_names_the_env_that_failed() -> None:
    """An env that cannot be built in a worker raises in the caller, naming the env and why."""
    scenario = scenario_from_dict(
        {**SCENARIO, "protocol": {"kind": "taps", "orientations_deg": [0], "lateral_mm": [0], "depths_mm": [1]}}
    )
    try:
        gym.make_vec(twin.GYM_ID, num_envs=2, workers=1, scenario=scenario)
    except RuntimeError as err:
        assert "env 0 of the vector failed: ValueError" in str(err) and "contour protocol" in str(err)
    else:
        raise AssertionError("a vector of envs without a contour protocol was built")


def test_the_vector_example_steps_both_modes() -> None:
    """docs/examples/vector_steps.py, the docs' example of stepping a vector of envs, runs
    as a user runs it (a few frames instead of 10,000)."""
    example = Path(__file__).parents[2] / "docs" / "examples" / "vector_steps.py"
    for mode in ("sync", "async", "workers"):
        done = subprocess.run(
            [sys.executable, str(example), "--envs", "2", "--frames", "12", "--rounds", "2", "--mode", mode],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr[-2000:]
        assert f"2 envs ({mode})" in done.stdout and "steps/s" in done.stdout and "other processes took" in done.stdout
        assert ("lockstep:" in done.stdout) == (mode == "async")  # each env's step times, from its process


def test_one_render_thread_draws_the_same_frames_without_rasterizer_threads() -> None:
    """twin.runs.parallel.one_render_thread, which the vector example calls before it starts
    the env processes: the same frames bit for bit, and no llvmpipe threads in the process
    (Mesa starts one per CPU by default). Fresh processes: Mesa reads the setting when a
    process first opens a GL display."""
    code = (
        "import hashlib, os, sys, numpy as np\n"
        "from twin.runs.parallel import one_render_thread\n"
        "if sys.argv[1] == 'one': one_render_thread()\n"
        "from twin.core.scenario import scenario_from_dict\n"
        "from twin.runs.gym_env import ContourFollowingEnv\n"
        f"env = ContourFollowingEnv(scenario_from_dict({NOISY!r}))\n"
        "env.reset(seed=3); env.step(np.array([0.5, 0.2], dtype=np.float32))\n"
        "names = [open(f'/proc/self/task/{t}/comm').read() for t in os.listdir('/proc/self/task')]\n"
        "print(hashlib.sha256(env.render().tobytes()).hexdigest(), sum(n.startswith('llvmpipe') for n in names))\n"
        "env.close()\n"
    )

    def frame_and_threads(which: str) -> tuple[str, int]:
        done = subprocess.run([sys.executable, "-c", code, which], capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        frame, threads = done.stdout.split()
        return frame, int(threads)

    default, one = frame_and_threads("default"), frame_and_threads("one")
    assert one[0] == default[0]
    assert one[1] == 0, default[1]
