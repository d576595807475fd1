"""Training perception models from recorded tap runs, and the model cache.

A contour scenario names its model file, or gets the model trained on the tap set of
the same fidelity, effects and camera — run and trained on the first use, then loaded
from the cache (`$TWIN_CACHE`, default `cache/` in the repository).
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from twin.errors import UserError
from twin.perception import PerceptionModel
from twin.record import Run, load_run
from twin.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[1]
TAP_SCENARIO = ROOT / "scenarios" / "taps_rectangle.yaml"


def cache_dir() -> Path:
    return Path(os.environ.get("TWIN_CACHE", ROOT / "cache"))


def train_from_run(run: Run, method: str = "pca", seed: int = 0) -> PerceptionModel:
    """Fit the paper's model (or the baseline) on a recorded tap run."""
    pins = run.pins_px
    theta, lateral, depth = run.label("theta_deg"), run.label("lateral_mm"), run.label("depth_mm")
    if not np.all(np.isfinite(theta)) or not np.all(np.isfinite(lateral)):
        raise UserError(f"{run.path}: not a tap run (samples need theta_deg and lateral_mm labels)")
    model = PerceptionModel(method=method)
    model.fit(pins, theta, lateral, depth, np.random.default_rng(seed), resolution=run.resolution,
              source="real" if run.meta.get("backend") == "hardware" else "sim")
    model.info["trained_on"] = str(run.path)
    return model


def tap_scenario_like(scenario: Scenario) -> Scenario:
    """The tap training scenario with the given scenario's fidelity, effects and sensor."""
    taps = load_scenario(TAP_SCENARIO)
    return taps.with_changes(fidelity=scenario.fidelity, effects=list(scenario.effects),
                             sensor=scenario.sensor.model_dump(), seed=scenario.seed)


def code_fingerprint() -> str:
    """Hash of the twin's source: a cached model is retrained when the code changes."""
    digest = hashlib.sha256()
    for path in sorted((ROOT / "twin").glob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _cache_key(taps: Scenario) -> str:
    from twin.record import package_versions

    payload = json.dumps({"scenario": taps.model_dump(), "versions": package_versions(), "code": code_fingerprint()},
                         sort_keys=True)
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


def cached_tap_model(scenario: Scenario, progress: bool = True) -> PerceptionModel:
    """The PCA+GP model trained on the tap set matching `scenario` (cached)."""
    from twin.runner import run_scenario

    taps = tap_scenario_like(scenario)
    key = _cache_key(taps)
    model_path = cache_dir() / "models" / f"taps_{key}.npz"
    if model_path.exists():
        model = PerceptionModel.load(model_path)
    else:
        run_dir = cache_dir() / "runs" / f"taps_{key}"
        if not (run_dir / "run.json").exists() or load_run(run_dir).meta.get("status") != "completed":
            import shutil

            shutil.rmtree(run_dir, ignore_errors=True)
            run_scenario(taps, run_dir, progress=progress)
        model = train_from_run(load_run(run_dir))
        model_path.parent.mkdir(parents=True, exist_ok=True)
        model.save(model_path)
    model.info["path"] = str(model_path)
    return model


def model_for_scenario(scenario: Scenario) -> PerceptionModel:
    """The model a contour scenario asks for: its `model` file, else the cached tap model."""
    name = scenario.protocol.model
    if name is None:
        return cached_tap_model(scenario)
    path = scenario.resolve(name)
    if not path.is_file():
        raise UserError(f"{scenario.source}: field 'protocol.model': no such model file {path}")
    model = PerceptionModel.load(path)
    model.info["path"] = str(path)
    return model
