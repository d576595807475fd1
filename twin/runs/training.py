"""Training perception models from recorded tap runs, and the model cache.

A contour scenario names its model file, or gets the model trained on the tap set of
the same fidelity, effects and camera — run and trained on the first use, then loaded
from the cache (twin.core.resources.cache_dir: `$TWIN_CACHE` or the user cache
directory). A cached model is keyed on what it depends on: the tap scenario, the dome
parameters it was simulated with, the package version and the code of the layers that
simulate, track and train (`model_code_digest`), so that a changed dome or tracker in a
source checkout trains again instead of loading a model of the old one.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
import sys
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from twin.core.errors import UserError
from twin.core.locks import held_exclusively
from twin.core.resources import cache_dir, code_digest, package_version, scenario_path
from twin.core.scenario import Scenario, load_scenario
from twin.runs.record import Run, load_run
from twin.runs.runner import record_protocol
from twin.runs.spec import dome_params
from twin.sensing.perception import PerceptionModel


def train_from_run(run: Run, method: str = "pca", seed: int = 0, pins_px: np.ndarray | None = None) -> PerceptionModel:
    """Fit the paper's model (or the baseline) on a recorded tap run; `pins_px` (N, 127, 2)
    px: its frames' pins as given instead of as recorded (e.g. without their uniform shift)."""
    pins = run.pins_px if pins_px is None else pins_px
    theta, lateral, depth = run.label("theta_deg"), run.label("lateral_mm"), run.label("depth_mm")
    if not np.all(np.isfinite(theta)) or not np.all(np.isfinite(lateral)):
        raise UserError(f"{run.path}: not a tap run (samples need theta_deg and lateral_mm labels)")
    model = PerceptionModel(method=method)
    model.fit(
        pins,
        theta,
        lateral,
        depth,
        np.random.default_rng(seed),
        resolution=run.resolution,
        source="real" if run.meta.get("backend") == "hardware" else "sim",
    )
    model.info["trained_on"] = str(run.path)
    return model


def tap_scenario_like(scenario: Scenario) -> Scenario:
    """The tap training scenario with the given scenario's dome model, fidelity, physics,
    effects and sensor (its calibration inline: a file named relative to `scenario` would
    otherwise be looked for beside the shipped tap scenario)."""
    taps = load_scenario(scenario_path("taps_rectangle"))
    sensor = scenario.sensor.model_dump()
    sensor["calibration"] = scenario.calibration()
    return taps.with_changes(
        dome=scenario.dome,
        fidelity=scenario.fidelity,
        physics=dict(scenario.physics),
        effects=list(scenario.effects),
        sensor=sensor,
        seed=scenario.seed,
    )


#: the layers whose code a tap model depends on (the controller and the tools above them do not count)
MODEL_CODE_LAYERS = ("core", "world", "sensing", "runs")


def model_code_digest() -> str:
    """`code_digest` of the package's layers in MODEL_CODE_LAYERS."""
    package = Path(__file__).resolve().parents[1]
    return code_digest(*(package / layer for layer in MODEL_CODE_LAYERS))


def cache_key(taps: Scenario) -> str:
    """What a cached tap model depends on: the tap scenario (protocol, sensor, effects,
    fidelity, seed), the dome parameters it simulates, the package version and the code
    (`model_code_digest`). The sensor's calibration counts by its contents, not by the
    file that holds them: editing the file changes the key, another file with the same
    contents does not."""
    scenario = taps.model_dump(mode="json")
    calibration = taps.calibration()
    scenario["sensor"]["calibration"] = None if calibration is None else calibration.model_dump(mode="json")
    payload = json.dumps(
        {
            "scenario": scenario,
            "dome": dataclasses.asdict(dome_params(taps)),
            "version": package_version(),
            "code": model_code_digest(),
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


def cached_tap_model(scenario: Scenario, progress: bool = True) -> PerceptionModel:
    """The PCA+GP model trained on the tap set matching `scenario` (cached). Processes
    that miss the same model at once train it once: the others wait, then load it."""
    taps = tap_scenario_like(scenario)
    model_path = cache_dir() / "models" / f"taps_{cache_key(taps)}.npz"

    def say_waiting() -> None:
        if progress:
            tqdm.write(f"waiting for another twin process that trains this tap model ({model_path})", file=sys.stderr)

    with held_exclusively(model_path.with_suffix(".lock"), on_wait=say_waiting):
        model = _load_or_train(taps, model_path, progress)
    model.info["path"] = str(model_path)
    return model


def _load_or_train(taps: Scenario, model_path: Path, progress: bool) -> PerceptionModel:
    """The model stored at `model_path`, or the one trained on `taps` (recorded into the
    cache's runs folder, or that folder's completed run) and stored there."""
    if model_path.exists():
        try:
            return PerceptionModel.load(model_path)
        except UserError as err:  # a damaged cache entry (cut by a kill, a full disk) is trained again
            warnings.warn(f"{err}; training it again", stacklevel=3)
    run_dir = cache_dir() / "runs" / model_path.stem
    if not _completed_run(run_dir):
        shutil.rmtree(run_dir, ignore_errors=True)
        record_protocol(taps, run_dir, progress=progress)
    model = train_from_run(load_run(run_dir))
    try:
        model.save(model_path)
    except OSError as err:
        warnings.warn(f"{model_path}: could not store the trained model in the cache ({err.strerror})", stacklevel=3)
    return model


def _completed_run(run_dir: Path) -> bool:
    """True if `run_dir` holds a readable, completed run (a damaged one is recorded again)."""
    try:
        return (run_dir / "run.json").exists() and load_run(run_dir).meta.get("status") == "completed"
    except UserError:
        return False


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
