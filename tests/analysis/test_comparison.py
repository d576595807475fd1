"""`twin compare` (twin.analysis.comparison) on two sim runs of one scenario at two fidelity levels."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from twin.analysis.comparison import pooled_differences
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


#: spreads of one figure over eleven lateral bins, in log units: the DigiTac fit's θ_PC23
#: turn along the edge spread from ×÷ 1.2 to ×÷ 4 by bin
SPREADS = (1.38, 0.66, 0.23, 0.32, 0.27, 0.40, 0.19, 0.16, 0.38, 0.27, 0.53)
LATERAL_MM = tuple(float(l) for l in range(-5, 6))


def _rows(turns_b: np.ndarray, spreads=SPREADS, a: float = 2.0) -> list[dict]:
    """figure_differences' rows of the along-edge turn: A's 2 deg/mm in every bin, B's the given."""
    return [
        {"figure": "theta_pc23", "lateral_mm": l, "a": a, "b": float(b), "spread": s}
        for l, b, s in zip(LATERAL_MM, turns_b, spreads)
    ]


def test_a_pooled_factor_is_the_precise_bins_and_its_error_covers_it() -> None:
    """B turns 1.25 times as far as A in every bin, each bin's measured factor scattered by
    its own spread (11 bins, ×÷ 1.2 to ×÷ 4, as measured on a real TacTip). Over 4,000
    such draws the pooled factor onto the object is unbiased, it scatters as
    1 / √Σw says (the inverse-variance mean's closed-form variance) to 10 %, its error
    covers 1.25 in 68–80 % of the draws (a standard error widened only where the bins
    scatter more than their spreads: a little above one standard deviation's 68 %; measured
    72 %), and it scatters 1.5–3 times less than the plain geometric mean over the same bins
    (measured 2.2)."""
    rng = np.random.default_rng(7)
    truth = math.log(1.25)
    onto = np.array([l < 0 for l in LATERAL_MM])
    pooled, plain, covered = [], [], 0
    for _ in range(4000):
        logs = truth + rng.normal(0.0, SPREADS)
        p = pooled_differences(_rows(2.0 * np.exp(logs)))["theta_pc23"]["onto"]
        assert p["bins"] == 5
        pooled.append(p["difference"])
        plain.append(np.mean(logs[onto]))
        covered += abs(p["difference"] - truth) <= p["error"]
    weights = np.array(SPREADS)[onto] ** -2.0
    assert np.mean(pooled) == pytest.approx(truth, abs=3 * np.std(pooled) / math.sqrt(4000))
    assert np.std(pooled) == pytest.approx(1 / math.sqrt(weights.sum()), rel=0.1)
    assert 0.68 <= covered / 4000 <= 0.80
    assert 1.5 <= np.std(plain) / np.std(pooled) <= 3.0


def test_bins_that_disagree_widen_the_pooled_error() -> None:
    """Bins each measured to ±0.05 in log units but turning B 1.5 and 1 / 1.5 times as far
    as A in turn: the pooled factor is 1 (their weights are equal) and its error is the
    spread of the bins' own factors over √bins (Birge's ratio), not the 0.05 / √bins their
    spreads alone would give; a bin without a spread (no resamples) leaves its side out."""
    logs = math.log(1.5) * np.array([1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1])
    pooled = pooled_differences(_rows(2.0 * np.exp(logs), spreads=(0.05,) * 11))["theta_pc23"]
    onto, off = pooled["onto"], pooled["off"]
    assert onto["difference"] == pytest.approx(np.mean(logs[:5]))
    assert onto["error"] == pytest.approx(np.std(logs[:5], ddof=1) / math.sqrt(5))
    assert onto["chi2_per_dof"] == pytest.approx(np.var(logs[:5], ddof=1) / 0.05**2)
    assert off["bins"] == 6 and off["difference"] == pytest.approx(0.0, abs=1e-12)
    unweighable = _rows(2.0 * np.exp(logs), spreads=(0.05,) * 10 + (0.0,))
    assert set(pooled_differences(unweighable)["theta_pc23"]) == {"onto"}


def test_the_report_prints_every_figure_compared_by_difference_as_b_minus_a() -> None:
    """The signal ratio and the shift's share (calibration_fit.figures.LINEAR) are compared
    by their difference, so their spreads and pooled errors are in their own units: a bin
    and its side pooled print as B − A ± spread, as the signal's do (a shift share of 0.30
    against 0.36 read as B / A would be "1.20 ×÷ 1.02"); θ_PC23's, compared by the log of
    B / A, as the factor ×÷ the factor of its spread."""
    from twin.analysis.calibration_fit.figures import LINEAR
    from twin.tools.edge_figures_report import _difference_cell, _pooled_cell

    assert "shift" in LINEAR  # the case is exercised
    for figure in LINEAR:
        rows = [{"figure": figure, "lateral_mm": l, "a": 0.30, "b": 0.36, "spread": 0.02} for l in LATERAL_MM]
        pooled = pooled_differences(rows)[figure]["onto"]
        assert pooled["difference"] == pytest.approx(0.06) and pooled["error"] == pytest.approx(0.02 / math.sqrt(5))
        assert _difference_cell(figure, rows[0]) == "+0.06 ± 0.02", figure
        assert _pooled_cell(figure, pooled) == "+0.06 ± 0.01", figure
    rows = _rows(np.full(len(LATERAL_MM), 2.5), spreads=(0.1,) * len(LATERAL_MM))
    assert _difference_cell("theta_pc23", rows[0]) == f"1.25 ×÷ {math.exp(0.1):.2f}"
    pooled = pooled_differences(rows)["theta_pc23"]["onto"]
    assert _pooled_cell("theta_pc23", pooled) == f"1.25 ×÷ {math.exp(0.1 / math.sqrt(5)):.2f}"
