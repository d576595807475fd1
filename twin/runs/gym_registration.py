"""Registers the contour-following environment with Gymnasium under `GYM_ID`.

The entry point is a string, so registering imports gymnasium but not the simulator;
`gymnasium.make(GYM_ID, scenario=…)` imports `twin.runs.gym_env` when it first builds the
environment. Reading `twin.GYM_ID` imports this module, so this works as written:

    import gymnasium, twin
    env = gymnasium.make(twin.GYM_ID, scenario="contour_flower")

Without `twin.GYM_ID`, name this module in the id: ``gymnasium.make(
"twin.runs.gym_registration:twin/ContourFollowing-v0", …)``.
"""

from __future__ import annotations

import gymnasium as gym

GYM_ID = "twin/ContourFollowing-v0"
ENTRY_POINT = "twin.runs.gym_env:ContourFollowingEnv"
#: `gymnasium.make_vec` without a mode (or vectorization_mode="vector_entry_point"): several envs per worker process
VECTOR_ENTRY_POINT = "twin.runs.vector_env:WorkerVectorEnv"


def register() -> None:
    """Register `ENTRY_POINT` and `VECTOR_ENTRY_POINT` under `GYM_ID` unless it already is
    (imports nothing of the twin)."""
    if GYM_ID not in gym.registry:
        gym.register(id=GYM_ID, entry_point=ENTRY_POINT, vector_entry_point=VECTOR_ENTRY_POINT)


register()
