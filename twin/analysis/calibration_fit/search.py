"""The search over a calibration's physics parameters: CMA-ES, or a BracketSearch for one
parameter, the camera solved per candidate; its stop rule, and the checkpoint and history
that let a calibration started again resume."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import cma
import numpy as np
from tqdm import tqdm

from twin.analysis.calibration_fit.evaluator import Evaluator
from twin.analysis.calibration_fit.settings import CalibrationSettings
from twin.core.errors import UserError
from twin.core.files import replace_file
from twin.core.scenario import Scenario


def search_key(runs: list[Path], scenario: Scenario, settings: CalibrationSettings) -> str:
    fixed = settings.model_dump(mode="json")
    fixed["optimiser"].pop("max_generations")  # raising it continues a calibration that ran out of generations
    text = json.dumps(
        [[str(Path(r).resolve()) for r in runs], scenario.model_dump(mode="json"), fixed], sort_keys=True, default=str
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


#: The checkpoint: JSON (never pickle, which runs code when it is read). The search itself
#: is not stored: it is rebuilt from its settings and replayed through the generations'
#: candidates ("asked", unit cube) and their χ² ("told"), which reproduces its state.
CHECKPOINT = "checkpoint.json"
CHECKPOINT_FORMAT = "twin calibration checkpoint 1"


def _save_checkpoint(out: Path, state: dict) -> None:
    """Write the state (all but the search object) under a temporary name, then rename."""
    replace_file(
        out / CHECKPOINT, json.dumps({"format": CHECKPOINT_FORMAT, **{k: v for k, v in state.items() if k != "es"}})
    )


def _load_checkpoint(path: Path) -> dict:
    """A checkpoint written by `_save_checkpoint`, checked field by field; UserError naming
    the file and field otherwise (its contents are never quoted)."""
    try:
        data = json.loads(path.read_bytes())
    except (OSError, ValueError, RecursionError):
        raise UserError(f"{path}: not a calibration checkpoint (unreadable JSON); delete it to start again") from None

    def numbers(v) -> bool:
        return isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)

    checks = {
        "format": lambda v: v == CHECKPOINT_FORMAT,
        "key": lambda v: isinstance(v, str),
        "generation": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0,
        "best": lambda v: isinstance(v, dict) and numbers(list(v.values())),
        "best_chi2": lambda v: numbers([v]),
        "start_chi2": lambda v: numbers([v]),
        "trace": numbers,
        "converged": lambda v: isinstance(v, bool),
        "stop": lambda v: v is None or isinstance(v, str),
        "asked": lambda v: isinstance(v, list) and all(isinstance(g, list) and all(numbers(u) for u in g) for g in v),
        "told": lambda v: isinstance(v, list) and all(numbers(g) for g in v),
    }
    if not isinstance(data, dict):
        raise UserError(f"{path}: not a calibration checkpoint (a JSON object); delete it to start again")
    for field, ok in checks.items():
        if field not in data or not ok(data[field]):
            raise UserError(
                f"{path}: field {field!r} missing or of the wrong type; delete the checkpoint to start again"
            )
    if len(data["asked"]) != data["generation"] or [len(g) for g in data["asked"]] != [len(g) for g in data["told"]]:
        raise UserError(f"{path}: fields 'asked' and 'told' do not hold one entry per generation")
    data.pop("format")
    return data


def _new_search(names: list[str], space, opt, best_chi2: float):
    """The search of `names` from the defaults: a BracketSearch for one parameter, else CMA-ES."""
    popsize = opt.popsize or 4 + int(3 * np.log(max(len(names), 2)))
    if len(names) == 1:  # pycma does not run in 1-D (CMA-ES/pycma#86, #302)
        return BracketSearch(popsize, float(space.to_unit(names, space.defaults)[0]), best_chi2, opt.tol_bracket)
    return cma.CMAEvolutionStrategy(
        space.to_unit(names, space.defaults),
        opt.sigma0,
        {"bounds": [0.0, 1.0], "popsize": popsize, "seed": opt.seed, "verbose": -9, "tolfun": 0.0, "tolflatfitness": 3},
    )


def _replayed_search(names: list[str], space, opt, state: dict):
    """The search as it was after the checkpoint's generations: built again and told each
    generation's candidates and χ² in order (each asked first, which advances its sampler)."""
    es = _new_search(names, space, opt, state["start_chi2"])
    for units, chi2 in zip(state["asked"], state["told"]):
        es.ask()
        es.tell([np.asarray(u, float) for u in units], list(chi2))
    return es


class BracketSearch:
    """The search of one physics parameter (unit interval), with CMA-ES's ask / tell / stop.

    Each generation evaluates `points` values evenly spaced inside the bracket, as one
    batch (in parallel); the next bracket spans the best value so far and its two grid
    neighbours, so it shrinks by (points + 1) / 2 per generation. It looks at its whole
    bracket each time, so the small steps in χ² where the skin's lattice gains a node do
    not trap it, and it stops when the bracket is narrower than `tol_unit` of the range."""

    def __init__(self, points: int, start_unit: float, start_value: float, tol_unit: float) -> None:
        self.points, self.tol_unit = points, tol_unit
        self.low, self.high = 0.0, 1.0
        self.best_unit, self.best_value = start_unit, start_value

    @property
    def step(self) -> float:
        """The grid's spacing inside the bracket (unit)."""
        return (self.high - self.low) / (self.points + 1)

    def ask(self) -> list[np.ndarray]:
        return [np.array([self.low + k * self.step]) for k in range(1, self.points + 1)]

    def tell(self, units: list[np.ndarray], values: list[float]) -> None:
        k = int(np.argmin(values))
        if values[k] < self.best_value:
            self.best_unit, self.best_value = float(units[k][0]), float(values[k])
        step = self.step
        self.low, self.high = max(0.0, self.best_unit - step), min(1.0, self.best_unit + step)

    def stop(self) -> dict[str, float]:
        width = self.high - self.low
        return {f"bracket {width:.2g} of the range, below {self.tol_unit:g}": width} if width < self.tol_unit else {}


def optimise(ev: Evaluator, out: Path, key: str, progress: bool) -> dict:
    """CMA-ES over the physics parameters, or a BracketSearch where there is one (camera
    solved per candidate); returns the state: best values, χ², generations, stop reason,
    converged."""
    space, opt = ev.space, ev.space.settings.optimiser
    names = space.physics
    history_file = out / "history.jsonl"
    checkpoint = out / CHECKPOINT
    if checkpoint.exists():
        state = _load_checkpoint(checkpoint)
        if state["key"] != key:
            raise UserError(
                f"{out}: holds a checkpoint of another calibration (other runs, scenario or settings); "
                "choose another --out"
            )
        state["es"] = _replayed_search(names, space, opt, state) if names else None
    else:
        start = {n: space.defaults[n] for n in space.fitted}
        tips = ev.simulate_one({n: space.defaults[n] for n in names}, "the twin as the scenario has it")
        best = ev.solve_camera(tips, {n: space.defaults[n] for n in names}, start)
        chi2_0 = ev.chi2(tips, best)
        state = {
            "key": key,
            "es": None,
            "generation": 0,
            "best": best,
            "best_chi2": chi2_0,
            "start_chi2": chi2_0,
            "trace": [],
            "asked": [],
            "told": [],
            "converged": not names,
            "stop": "no physics parameters: camera solved by least squares" if not names else None,
        }
        history_file.write_text(json.dumps({"generation": 0, "values": best, "chi2": state["best_chi2"]}) + "\n")
        if names:
            state["es"] = _new_search(names, space, opt, chi2_0)
        _save_checkpoint(out, state)
    es = state["es"]
    bar = tqdm(
        total=opt.max_generations,
        initial=state["generation"],
        desc="calibrate",
        unit="gen",
        disable=not progress or es is None,
    )
    while es is not None and not state["converged"] and state["generation"] < opt.max_generations:
        units = es.ask()
        physics = [space.from_unit(names, np.asarray(u)) for u in units]
        tips_all = ev.simulate(physics)
        fitted = [p if t is None else ev.solve_camera(t, p, state["best"]) for t, p in zip(tips_all, physics)]
        chi2 = [None if t is None else ev.chi2(t, v) for t, v in zip(tips_all, fitted)]
        # a candidate the physics could not simulate is infeasible: ranked below every other
        worst = 10.0 * max([c for c in chi2 if c is not None] + [state["best_chi2"], state["start_chi2"]])
        failed = [c is None for c in chi2]
        chi2 = [worst if c is None else c for c in chi2]
        es.tell(units, chi2)
        state["asked"].append([np.asarray(u, float).tolist() for u in units])
        state["told"].append([float(c) for c in chi2])
        state["generation"] += 1
        k = int(np.argmin(chi2))
        if chi2[k] < state["best_chi2"]:
            state["best"], state["best_chi2"] = fitted[k], chi2[k]
        state["trace"].append(state["best_chi2"])
        with history_file.open("a") as f:
            for v, c, bad in zip(fitted, chi2, failed):
                row = {"generation": state["generation"], "values": v, "chi2": c}
                f.write(json.dumps({**row, "failed": True} if bad else row) + "\n")
        trace = state["trace"]
        if (
            len(trace) > opt.patience
            and trace[-1 - opt.patience] - trace[-1] <= opt.tol_relative * trace[-1 - opt.patience]
        ):
            state["converged"] = True
            state["stop"] = (
                f"best χ² improved by less than {opt.tol_relative:g} (relative) over {opt.patience} generations"
            )
        elif es.stop():
            state["converged"] = True
            state["stop"] = f"{type(es).__name__} stop: {', '.join(es.stop())}"
        _save_checkpoint(out, state)
        bar.update(1)
        bar.set_postfix(chi2=f"{state['best_chi2']:.4g}")
    bar.close()
    if not state["converged"] and state["stop"] is None:
        state["stop"] = f"max_generations ({opt.max_generations}) reached before the stop rule was met"
    return state
