"""`twin compare` (twin.analysis.comparison) on two sim runs of one scenario at two fidelity levels."""

from __future__ import annotations

import json

from twin.core.scenario import scenario_from_dict
from twin.runs.record import load_run
from twin.runs.run import run_scenario
from twin.runs.training import train_from_run
from twin.tools.cli import main

SCENARIO = {
    "name": "compare_taps",
    "object": {"name": "rectangle"},
    "effects": ["contact", "friction", "render"],
    "protocol": {"kind": "taps", "orientations_deg": [0, 90], "lateral_mm": [9.9, 2, -2], "depths_mm": [3]},
}


def test_compare_two_fidelity_levels(tmp_path, capsys) -> None:
    a = run_scenario(scenario_from_dict({**SCENARIO, "fidelity": "fast"}), tmp_path / "fast", workers=1, progress=False)
    b = run_scenario(
        scenario_from_dict({**SCENARIO, "fidelity": "default"}), tmp_path / "default", workers=1, progress=False
    )
    model = train_from_run(load_run(b)).save(tmp_path / "model.npz")
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "cmp"), "--model", str(model)]) == 0
    result = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert result["n_pairs"] == 6 and result["pairing"] == "by target pose"
    assert 0.0 < result["pin_rms_difference_px"] < 5.0  # close but not identical physics
    assert result["pin_displacement_correlation"]["mean"] > 0.8
    assert 0.5 < result["ssim"]["mean"] <= 1.0 and result["ssim"]["frames"] == 6
    assert (tmp_path / "cmp" / "comparison.png").exists()
    for tag in ("a", "b"):
        perception = result[f"perception_{tag}"]
        assert 0 <= perception["orientation_rms_deg"] <= 180 and perception["lateral_rms_mm"] >= 0
    # each run's orientation signal: more with the edge 2 mm from the centre than at the rim 9.9 mm off (2.17 / 2.13
    # px against 0.62 / 0.29 px, fast / default)
    assert "run A: orientation signal" in capsys.readouterr().out
    for tag in ("a", "b"):
        signal = result["orientation_signal_px"][tag]["3.0"]
        assert signal["2.0"] > 2.0 * signal["9.9"], signal
    assert main(["compare", str(a), str(tmp_path / "nope"), "--out", str(tmp_path / "x")]) == 2


def test_targets_pair_across_a_rounding_boundary(tmp_path) -> None:
    """A record keeps 7 significant digits: its 41.3795° and the replayed 41.37949958° pair
    (rounded to 1e-3 they read 41.380 and 41.379); a target 2e-3 away does not, and each
    target pairs once, in order."""
    from twin.analysis.comparison import pair_samples
    from twin.runs.record import Run

    recorded = Run(tmp_path, {}, [{"target": [64.59777, 0, 3.063105, 0, 0, 41.3795]}, {"target": [1, 2, 3, 0, 0, 5]}])
    replayed = Run(
        tmp_path,
        {},
        [
            {"target": [1, 2, 3, 0, 0, 5.002]},
            {"target": [64.59777022, 0, 3.0631052, 0, 0, 41.37949958]},
            {"target": [64.59777022, 0, 3.0631052, 0, 0, 41.37949958]},
        ],
    )
    assert pair_samples(recorded, replayed) == [(0, 1)]
    assert pair_samples(replayed, recorded) == [(1, 0)]
