"""The Gymnasium wrapper follows the standard API and its reward measures progress."""
from __future__ import annotations

import numpy as np
from gymnasium.utils.env_checker import check_env

from twin.runs.gym_env import ContourFollowingEnv
from twin.core.scenario import scenario_from_dict

SCENARIO = {"name": "gym_circle", "object": {"name": "small_circle"}, "fidelity": "fast",
            "effects": ["contact"], "protocol": {"kind": "contour", "max_steps": 5}}


def test_gym_api_and_reward() -> None:
    env = ContourFollowingEnv(scenario_from_dict(SCENARIO))
    try:
        check_env(env, skip_render_check=True)
        obs, info = env.reset(seed=0)
        assert obs.shape == (254,) and np.all(np.isfinite(obs))
        assert np.abs(obs).max() > 0.5  # pressing on the edge moves pins
        # Start is the lowest point of the circle (object frame): counter-clockwise is +x,
        # which is +x in the work frame too.
        _, r_forward, *_ = env.step(np.array([3.0, 0.0], dtype=np.float32))
        _, r_back, *_ = env.step(np.array([-3.0, 0.0], dtype=np.float32))
        assert r_forward > 0 > r_back
        truncated = False
        for _ in range(5):
            *_, terminated, truncated, _ = env.step(np.zeros(2, dtype=np.float32))
        assert truncated
    finally:
        env.close()
