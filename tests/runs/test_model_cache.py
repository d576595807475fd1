"""The tap-model cache shared by processes: two that miss the same model train it once."""

from __future__ import annotations

import threading

import numpy as np

from twin.core.locks import held_exclusively
from twin.core.resources import CACHE_ENV
from twin.core.scenario import scenario_from_dict
from twin.runs.training import cache_key, cached_tap_model, tap_scenario_like
from twin.sensing.perception import GPConfig, PerceptionModel, paper_training_labels, synthetic_tap_pins


def test_a_process_that_misses_a_model_another_trains_waits_and_loads_it(tmp_path, monkeypatch) -> None:
    """While another process holds a tap model's lock (training it), `cached_tap_model`
    waits; once the model is stored and the lock let go, it loads that model and records
    no tap run of its own (two `twin run`s, or two test workers, after a code change used
    to record into the same cache folder, and the second stopped with an error)."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    contour = scenario_from_dict({"name": "c", "object": {"name": "rectangle"}, "protocol": {"kind": "contour"}})
    model_path = tmp_path / "models" / f"taps_{cache_key(tap_scenario_like(contour))}.npz"
    theta, lateral, depth = paper_training_labels()
    pins = synthetic_tap_pins(theta, lateral, depth, noise_px=0.02, rng=np.random.default_rng(1))
    trained = PerceptionModel(gp=GPConfig(n_restarts=0)).fit(pins, theta, lateral, depth, np.random.default_rng(0))
    loaded: list[PerceptionModel] = []
    with held_exclusively(model_path.with_suffix(".lock")):
        waiting = threading.Thread(target=lambda: loaded.append(cached_tap_model(contour, progress=False)), daemon=True)
        waiting.start()
        waiting.join(1.0)
        assert waiting.is_alive() and not (tmp_path / "runs").exists()
        trained.save(model_path)
    waiting.join(60)
    assert not waiting.is_alive() and len(loaded) == 1
    assert loaded[0].info["path"] == str(model_path) and not (tmp_path / "runs").exists()
    np.testing.assert_array_equal(loaded[0].predict(pins[:5]).theta_deg, trained.predict(pins[:5]).theta_deg)
