"""Step the contour-following Gymnasium env as a vector of N envs (gymnasium.make_vec):
seeded random steps, no learning, 10,000 frames by default; prints the vector's steps per
second against one env's, measured in the same run.

    MUJOCO_GL=egl .venv/bin/python docs/examples/vector_steps.py --envs 2 --frames 10000

--mode async runs each env in its own process (forkserver: the parent may hold a GL
context), sync runs them one after another in this one, workers (`make_vec` without a
mode: twin.runs.vector_env) runs them in --workers processes (default: one per core),
several envs each. Envs are seeded per env: reset
with seed s seeds env i with s + i. Each env steps its own random actions, as a learning
policy's would be (--same-actions: all envs the same ones).

The baseline is one env stepped the same way (async and workers: in its own process, so
it pays the same transfers) with env 0's actions, in rounds that alternate with the vector's, so
drift and other processes' load reach both. Also printed: the lockstep (each vector step
waits for its slowest env: the mean env step against the mean slowest one, timed in the
env processes, in CPU time, which other processes' load barely moves, and in wall time)
and the share of the cores that other processes took meanwhile (Linux).
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numpy as np

import twin
from twin.runs.parallel import default_workers, one_blas_thread, one_render_thread


class StepTime(gym.Wrapper):
    """Adds the wall time and the CPU time of its process (s) of each env step to its
    info, as `step_s` and `step_cpu_s`."""

    def step(self, action):
        t0, cpu0 = time.perf_counter(), time.process_time()
        obs, reward, terminated, truncated, info = self.env.step(action)
        times = {"step_s": time.perf_counter() - t0, "step_cpu_s": time.process_time() - cpu0}
        return obs, reward, terminated, truncated, {**info, **times}


def busy_ticks(pids: list[int]) -> tuple[int, int]:
    """(all cores' busy clock ticks, those of the processes `pids`) since boot; (0, 0) off Linux."""
    try:
        with open("/proc/stat") as f:
            user, nice, system, _idle, _iowait, irq, softirq = map(int, f.readline().split()[1:8])
        ours = 0
        for pid in pids:
            with open(f"/proc/{pid}/stat") as f:
                ours += sum(int(t) for t in f.read().rsplit(")", 1)[1].split()[11:13])
    except OSError:
        return 0, 0
    return user + nice + system + irq + softirq, ours


def run_round(envs: gym.vector.VectorEnv, actions: np.ndarray, seed: int) -> tuple[float, float, list]:
    """Step `envs` through actions (steps, envs, 2) after a reset and 5 untimed steps; returns
    (frames per second, cores other processes took, per step the env steps' wall and CPU
    times (s) when every env stepped, not reset)."""
    envs.reset(seed=seed)
    for action in actions[:5]:
        envs.step(action)
    pids = [os.getpid()] + [p.pid for p in getattr(envs, "processes", [])]
    busy0, ours0 = busy_ticks(pids)
    step_times = []
    t0 = time.perf_counter()
    for action in actions[5:]:
        info = envs.step(action)[4]
        if np.all(info.get("_step_s", False)):
            step_times.append((info["step_s"], info["step_cpu_s"]))
    seconds = time.perf_counter() - t0
    busy1, ours1 = busy_ticks(pids)
    # clock ticks are counted per process, so a quiet host can read a tick below zero
    others = max(0.0, (busy1 - busy0 - (ours1 - ours0)) / os.sysconf("SC_CLK_TCK") / seconds)
    return (len(actions) - 5) * envs.num_envs / seconds, others, step_times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=2, help="envs in the vector (one per core)")
    parser.add_argument("--frames", type=int, default=10_000, help="frames the vector steps, all envs together")
    parser.add_argument("--rounds", type=int, default=5, help="alternating rounds of one env and the vector")
    parser.add_argument("--mode", choices=("async", "sync", "workers"), default="async")
    parser.add_argument(
        "--workers", type=int, default=None, help="worker processes of --mode workers (default: one per core)"
    )
    parser.add_argument("--same-actions", action="store_true", help="every env steps the same actions")
    parser.add_argument("--scenario", default="contour_rectangle", help="a shipped contour scenario or a file")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    # one BLAS thread and no rasterizer threads here and in the env processes (they inherit
    # both): a second BLAS thread only spin-waits beside the physics and takes the other
    # env's core, and llvmpipe would start a rasterizer thread per CPU in every env process
    one_blas_thread()
    one_render_thread()

    def make(n: int) -> gym.vector.VectorEnv:
        if args.mode == "workers":  # the registered vector entry point; it takes no wrappers
            return gym.make_vec(twin.GYM_ID, num_envs=n, workers=args.workers, scenario=args.scenario)
        return gym.make_vec(
            twin.GYM_ID,
            num_envs=n,
            vectorization_mode=args.mode,
            vector_kwargs={"context": "forkserver"} if args.mode == "async" else {},
            wrappers=[StepTime],
            scenario=args.scenario,
        )

    one, vector = make(1), make(args.envs)
    steps = max(-(-args.frames // (args.envs * args.rounds)), 1)
    single, many, others, step_times = [], [], [], []
    try:
        for r in range(args.rounds):
            rng = np.random.default_rng(args.seed + r)
            actions = rng.uniform(-0.3, 0.3, (steps + 5, 1 if args.same_actions else args.envs, 2))
            actions = np.broadcast_to(actions, (steps + 5, args.envs, 2)).astype(np.float32)
            fps, load, _ = run_round(one, actions[:, :1], args.seed + r)
            single.append(fps)
            others.append(load)
            fps, load, times = run_round(vector, actions, args.seed + r)
            many.append(fps)
            others.append(load)
            step_times += times
    finally:
        one.close()
        vector.close()
    single_fps, vector_fps = np.mean(single), np.mean(many)
    ratio = vector_fps / single_fps
    # one env per core at most: async envs are processes, sync ones take turns in this one
    processes = {"async": args.envs, "sync": 1, "workers": min(args.envs, args.workers or default_workers())}[args.mode]
    ideal = min(processes, default_workers())
    allow = "one process" if processes == 1 else f"{ideal} processes on {default_workers()} cores"
    print(
        f"{args.scenario}: {args.rounds} rounds, {args.envs * steps} frames each, "
        f"{'the same' if args.same_actions else 'its own'} random actions per env\n"
        f"  1 env {single_fps:.1f} steps/s; {args.envs} envs ({args.mode}) {vector_fps:.1f} steps/s "
        f"= {ratio:.2f}x one env ({ratio / ideal:.2f} of the {ideal}x that {allow} allow); "
        f"by round {' '.join(f'{m / s:.2f}' for s, m in zip(single, many))}"
    )
    if args.mode == "async" and step_times:
        wall, cpu = np.moveaxis(np.array(step_times), 1, 0)  # (steps, envs) each
        print(
            f"  lockstep: the mean env step is {cpu.mean() / cpu.max(axis=1).mean():.2f} of the slowest env's "
            f"in CPU time ({1e3 * cpu.mean():.1f} against {1e3 * cpu.max(axis=1).mean():.1f} ms), "
            f"{wall.mean() / wall.max(axis=1).mean():.2f} in wall time"
        )
    print(
        f"  other processes took {np.mean(others):.2f} of {default_workers()} cores meanwhile (at most {max(others):.2f})"
    )


if __name__ == "__main__":
    main()
