"""A vector of envs in a few worker processes, several envs each (``vectorization_mode=
"vector_entry_point"``, or `make_vec` without a mode).

Gymnasium's async vector runs one process per env, and every vector step waits for the
slowest env. The twin's env steps vary in cost (the physics steps a contact takes to
settle: 9 ± 4 a frame under random actions), so with one env per core the cores idle
while the slowest env finishes: 2 envs on 2 cores ran 1.67× one env, not 2×. Here each
of `workers` processes (default: one per core) steps its share of the envs one after the
other, so a vector step waits for the slowest *sum* of a few env steps, which varies
relatively less; envs per core is what buys it.

Semantics are Gymnasium's vector API: batched observations, rewards and flags, info
dicts with `_key` masks, next-step autoreset, ``reset(seed=s)`` seeds env i with s + i
(the same observations as the sync and async modes for the same seed); `call`,
`get_attr`, `set_attr` and `render` reach every env as in gymnasium's own vectors. A
worker that fails raises its error in this process, naming the env.
"""

from __future__ import annotations

import multiprocessing as mp
import traceback
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from twin.runs.gym_registration import GYM_ID
from twin.runs.parallel import default_workers, one_blas_thread, one_render_thread


def _answer(env: gym.Env, command: str, item: Any, shared: Any) -> Any:
    """One env's answer to a command of the parent: `item` is this env's part (a seed, an
    (action, autoreset) pair, a value), `shared` the part every env gets."""
    if command == "reset":
        obs, info = env.reset(seed=item, options=shared)
        return obs, 0.0, False, False, info
    if command == "step":
        action, again = item
        if again:  # next-step autoreset: this step only resets the env
            obs, info = env.reset()
            return obs, 0.0, False, False, info
        return env.step(action)
    if command == "call":  # a method called, or an attribute read
        name, args, kwargs = shared
        value = env.get_wrapper_attr(name)
        return value(*args, **kwargs) if callable(value) else value
    env.set_wrapper_attr(shared, item)  # "set"
    return None


def _serve(conn, env_kwargs: dict, first: int, count: int) -> None:
    """Worker loop: build envs `first` … `first + count − 1`, send their spaces, then answer
    the parent's (command, items: one per env or None, shared) until ("close", None, None)."""
    envs: list[gym.Env] = []
    current = first
    try:
        one_blas_thread()
        one_render_thread()
        for i in range(count):
            current = first + i
            envs.append(gym.make(GYM_ID, **env_kwargs))
        conn.send(("ok", [(envs[0].observation_space, envs[0].action_space)]))
        while True:
            command, items, shared = conn.recv()
            if command == "close":
                break
            results = []
            for i, (env, item) in enumerate(zip(envs, items or [None] * count)):
                current = first + i
                results.append(_answer(env, command, item, shared))
            conn.send(("ok", results))
    except (KeyboardInterrupt, EOFError):
        pass
    except Exception as err:  # noqa: BLE001 - any env error goes back to the parent, named
        conn.send(("error", (current, f"{type(err).__name__}: {err}", traceback.format_exc())))
    finally:
        for env in envs:
            env.close()
        conn.close()


class WorkerVectorEnv(VectorEnv):
    """`num_envs` envs of `twin.GYM_ID` (keyword arguments as for `gymnasium.make`) in
    `workers` processes (default: one per core, at most one per env), the envs split
    evenly in env order. `context`: the multiprocessing start method (forkserver: the
    parent may hold a GL context)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int, workers: int | None = None, context: str = "forkserver", **env_kwargs: Any):
        if num_envs < 1:
            raise ValueError(f"num_envs must be ≥ 1, got {num_envs}")
        self.num_envs = num_envs
        n_workers = max(1, min(workers or default_workers(), num_envs))
        sizes = [num_envs // n_workers + (w < num_envs % n_workers) for w in range(n_workers)]
        self.env_groups = [(sum(sizes[:w]), size) for w, size in enumerate(sizes)]
        self._autoreset = np.zeros(num_envs, bool)
        ctx = mp.get_context(context)
        self._pipes, self.processes = [], []
        for first, size in self.env_groups:
            parent, child = ctx.Pipe()
            process = ctx.Process(target=_serve, args=(child, env_kwargs, first, size), daemon=True)
            process.start()
            child.close()
            self._pipes.append(parent)
            self.processes.append(process)
        self.single_observation_space, self.single_action_space = self._gather()[0]
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)

    def _gather(self) -> list:
        """Every worker's answer (its list of results, in env order, joined); a worker's
        error raised here."""
        results, failure = [], None
        for pipe in self._pipes:
            try:
                status, payload = pipe.recv()
            except EOFError:
                status, payload = "error", (None, "its worker process ended", "")
            if status == "error" and failure is None:
                failure = payload
            elif status == "ok":
                results += payload
        if failure is not None:
            env, message, trace = failure
            self.close()
            who = "a worker" if env is None else f"env {env}"
            raise RuntimeError(f"{who} of the vector failed: {message}\n{trace}")
        return results

    def _ask(self, command: str, items: list | None = None, shared: Any = None) -> list:
        """Send a command to every worker, each its envs' share of `items` (one per env),
        and gather the answers in env order."""
        for pipe, (first, size) in zip(self._pipes, self.env_groups):
            pipe.send((command, None if items is None else list(items[first : first + size]), shared))
        return self._gather()

    def _batch(self, results: list) -> tuple:
        obs, rewards, terminated, truncated, infos = zip(*results)
        batch_infos: dict = {}
        for i, info in enumerate(infos):
            batch_infos = self._add_info(batch_infos, info, i)
        return (
            np.stack(obs).astype(self.single_observation_space.dtype, copy=False),
            np.array(rewards, dtype=np.float64),
            np.array(terminated, dtype=bool),
            np.array(truncated, dtype=bool),
            batch_infos,
        )

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """(observations, infos); seed s seeds env i with s + i, a list seeds each env."""
        if seed is None or isinstance(seed, int):
            seeds = [None if seed is None else seed + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"reset got {len(seeds)} seeds for {self.num_envs} envs")
        obs, _, _, _, infos = self._batch(self._ask("reset", seeds, options))
        self._autoreset[:] = False
        return obs, infos

    def step(self, actions):
        """(observations, rewards, terminations, truncations, infos) of every env; an env
        that ended at the previous step is reset instead (reward 0)."""
        actions = np.asarray(actions)
        if len(actions) != self.num_envs:
            raise ValueError(f"step got {len(actions)} actions for {self.num_envs} envs")
        batch = self._batch(self._ask("step", list(zip(actions, self._autoreset.tolist()))))
        self._autoreset = batch[2] | batch[3]
        return batch

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each env's method `name` called with these arguments, or its attribute `name`,
        in env order (as gymnasium's own vectors do)."""
        return tuple(self._ask("call", shared=(name, args, kwargs)))

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Each env's attribute `name`, in env order."""
        return self.call(name)

    def set_attr(self, name: str, values: Any) -> None:
        """Set each env's attribute `name`: one value for all, or a list or tuple of one per env."""
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(f"set_attr got {len(values)} values for {self.num_envs} envs")
        self._ask("set", values, name)

    def render(self) -> tuple[Any, ...]:
        """Each env's last frame (RGB, H × W × 3 uint8; None without the render effect)."""
        return self.call("render")

    def close_extras(self, **kwargs: Any) -> None:
        for pipe in self._pipes:
            try:
                pipe.send(("close", None, None))
            except (BrokenPipeError, OSError):
                pass
        for process in self.processes:
            process.join(timeout=30)
            if process.is_alive():
                process.terminate()
        for pipe in self._pipes:
            pipe.close()
