"""Step the contour-following Gymnasium env as a vector of N envs (gymnasium.make_vec):
seeded random steps, no learning, 10,000 frames by default; prints the steps per second of
the vector against one env's, measured in the same run.

    MUJOCO_GL=egl .venv/bin/python docs/examples/vector_steps.py --envs 2 --frames 10000

--mode async runs each env in its own process (forkserver: the parent may hold a GL
context), sync runs them one after another in this one. Envs are seeded per env: reset
with seed s seeds env i with s + i.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import twin
from twin.runs.parallel import one_blas_thread


def steps_per_second(envs: gym.vector.VectorEnv, frames: int, seed: int) -> float:
    """Frames stepped per second over `frames` frames (all envs together), after 5 untimed
    steps (each env's first frames fill caches). Every env gets the same seeded random
    steps of up to 0.3 × max_step_mm, so each does the same work whatever the vector's size."""
    steps = -(-frames // envs.num_envs)
    actions = np.random.default_rng(seed).uniform(-0.3, 0.3, (steps + 5, 1, 2)).astype(np.float32)
    actions = np.repeat(actions, envs.num_envs, axis=1)
    envs.reset(seed=seed)
    for action in actions[:5]:
        envs.step(action)
    t0 = time.perf_counter()
    for action in actions[5:]:
        envs.step(action)
    return steps * envs.num_envs / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=2, help="envs in the vector (one per core)")
    parser.add_argument("--frames", type=int, default=10_000, help="frames to step, all envs together")
    parser.add_argument("--mode", choices=("async", "sync"), default="async")
    parser.add_argument("--scenario", default="contour_rectangle", help="a shipped contour scenario or a file")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    # one BLAS thread here and in the env processes (they inherit it): a second one only
    # spin-waits beside the physics and takes the other env's core
    one_blas_thread()

    def make(n: int, mode: str) -> gym.vector.VectorEnv:
        kwargs = {"context": "forkserver"} if mode == "async" else {}
        return gym.make_vec(
            twin.GYM_ID, num_envs=n, vectorization_mode=mode, vector_kwargs=kwargs, scenario=args.scenario
        )

    one = make(1, "sync")
    try:
        single = steps_per_second(one, max(args.frames // args.envs, 1), args.seed)
    finally:
        one.close()
    envs = make(args.envs, args.mode)
    try:
        vector = steps_per_second(envs, args.frames, args.seed)
    finally:
        envs.close()
    print(
        f"{args.scenario}: 1 env {single:.1f} steps/s; {args.envs} envs ({args.mode}) {vector:.1f} steps/s "
        f"= {vector / single:.2f}x one env ({np.round(vector / single / args.envs, 2)} of {args.envs}x)"
    )


if __name__ == "__main__":
    main()
