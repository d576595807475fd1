"""`twin calibrate` with the edge figures in its objective (settings weights.edge_figures):
the misses' tolerances, a friction recovered from the figures alone on sheared taps
rendered with camera noise and tracked, and what it refuses (exit 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from twin.analysis.calibration_fit.figures import (
    FACTOR_TOLERANCE,
    MISSING_MISS,
    SIGNAL_TOLERANCE,
    figure_spread,
    figure_values,
    miss,
)
from twin.analysis.calibration_fit.settings import load_settings
from twin.core.scenario import scenario_from_dict
from twin.runs.record import load_run
from twin.runs.run import run_scenario
from twin.tools.calibration_report import calibrate_and_report
from twin.tools.cli import main

TWIN = {
    "name": "figures_twin",
    "object": {"name": "rectangle"},
    "fidelity": "fast",
    "seed": 0,
    "effects": ["contact", "friction"],
    # 90 taps over three lateral bins (-1, 0, +1 mm): each has the 20 frames a bin's fit needs
    "protocol": {"kind": "sheared_taps", "depth_mm": 3.0, "taps": 90, "seed": 2, "lateral_range_mm": [-1.5, 1.5]},
}
#: the "real" sensor: friction 0.3, rendered with camera noise and tracked, another seed
REAL = {
    **TWIN,
    "name": "figures_real",
    "sensor": {"calibration": {"friction": 0.3}},
    "seed": 5,
    "effects": ["contact", "friction", "render", "camera_noise"],
}
#: friction from the figures alone: the contact frames' pins are not weighed
FIGURES_ONLY = {
    "parameters": {
        "camera.focal_px": {"fit": False},
        "camera.k1": {"fit": False},
        "material.young_kpa": {"fit": False},
        "tcp.z_mm": {"fit": False},
        "friction": {"fit": True, "lower": 0.1, "upper": 1.2},
    },
    "weights": {"contact": 0.0, "edge_figures": 1.0},
    "optimiser": {"popsize": 6, "max_generations": 6, "tol_bracket": 0.02, "seed": 3},
}


def test_a_miss_is_counted_in_tolerances() -> None:
    """A signal ratio or a shift share 0.1 off is one tolerance; a factor of 4/3 either way is
    one; a figure below its floor counts as the floor; one the twin lacks is MISSING_MISS."""
    assert miss("signal", 0.75, 0.65) == pytest.approx(0.1 / SIGNAL_TOLERANCE)
    assert miss("shift", 0.55, 0.05) == pytest.approx(5.0)
    assert miss("signal", 0.55, 0.65) == pytest.approx(-1.0)
    assert miss("theta_pc23", 4.0 * 4 / 3, 4.0) == pytest.approx(1.0)
    assert miss("drag/signal", 3.0, 3.0 * FACTOR_TOLERANCE**2) == pytest.approx(-2.0)
    assert miss("theta_pc23", 0.0, 0.05) == 0.0  # both below the 0.1 deg/mm floor
    assert miss("theta_pc23", 0.4, 0.0) == pytest.approx(math.log(4.0) / math.log(FACTOR_TOLERANCE))
    assert miss("theta_pc23", None, 2.0) == MISSING_MISS
    # a recorded figure's spread widens the tolerance in quadrature: √(0.1² + 0.03) = 0.2
    assert miss("signal", 0.75, 0.65, math.sqrt(0.03)) == pytest.approx(0.5)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("figures")
    (root / "twin.yaml").write_text(yaml.safe_dump(TWIN))
    real = run_scenario(scenario_from_dict(REAL), root / "real", workers=1, progress=False)
    return {"root": root, "real": real, "scenario": scenario_from_dict(TWIN, str(root / "twin.yaml"))}


def test_the_figures_alone_recover_the_friction(recorded, tmp_path) -> None:
    """The twin starts at friction 0.7 against a "real" 0.3: the drag's share of the pins
    grows with friction (drag / signal 0.5–0.8 at 0.15, 1.8–2.8 at 0.7 on these taps), so
    the figures pin it down although no contact frame's pins are fitted (0.299 when
    written; held to 0.05)."""
    (tmp_path / "settings.yaml").write_text(yaml.safe_dump(FIGURES_ONLY))
    r = calibrate_and_report(
        [recorded["real"]],
        recorded["scenario"],
        tmp_path / "cal",
        load_settings(tmp_path / "settings.yaml"),
        workers=1,
        progress=False,
    )
    assert r["status"] == "converged"
    u = r["uncertainty"]["parameters"]["friction"]
    assert abs(u["value"] - 0.3) < 0.05, u
    assert u["identifiable"], u
    figures = r["edge_figures"]
    assert figures["weight"] == 1.0
    assert {row["figure"] for row in figures["after"]} == {"signal", "drag/signal", "theta_pc23", "theta_pc23_across"}
    before = sum(row["miss"] ** 2 for row in figures["before"])
    after = sum(row["miss"] ** 2 for row in figures["after"])
    assert after < before / 4, (before, after)
    assert "| 0 | drag/signal | -1 |" in (tmp_path / "cal" / "report.md").read_text()


def test_the_turn_read_in_the_recorded_plane_ignores_what_lies_outside_it(recorded) -> None:
    """settings edge_theta_plane: a replay that is the recording plus a pattern outside the
    recording's first three PCs, of a size that varies from tap to tap, has that pattern as
    its own first PC: read in its own PC2–PC3 its turn of θ_PC23 moves, read in the
    recorded taps' plane it is the recording's own replay's (the pattern projects to nothing)."""
    from twin.analysis.calibration_fit.figures import EdgeFigureTarget
    from twin.analysis.edge_imprint import tap_pcs

    real = load_run(recorded["real"])
    components = tap_pcs(real).components
    rng = np.random.default_rng(7)
    pattern = rng.normal(size=components.shape[1])
    pattern -= components.T @ (components @ pattern)
    pattern *= 10.0 / np.sqrt(np.mean(pattern**2))  # 10 px RMS over the pins per unit size
    tapped = np.array([not s["labels"].get("no_contact") for s in real.samples])
    size = np.where(tapped, rng.normal(size=len(real.samples)), 0.0)
    patterned = real.pins_px + size[:, None, None] * pattern.reshape(-1, 2)
    rows = np.zeros(len(real.samples), dtype=int)

    def turns(pins: np.ndarray, recorded_plane: bool) -> dict[float, float]:
        target = EdgeFigureTarget.of([real], rows, 1.0, 0, 0, theta_in_recorded_plane=recorded_plane)
        return {r["lateral_mm"]: r["twin"] for r in target.table(pins) if r["figure"] == "theta_pc23"}

    in_recorded, own = turns(real.pins_px, True), turns(real.pins_px, False)
    assert len(in_recorded) == 3 and all(v > 0 for v in in_recorded.values())
    assert turns(patterned, True) == pytest.approx(in_recorded, rel=1e-6)
    moved = turns(patterned, False)
    assert max(abs(math.log(moved[l] / own[l])) for l in own) > math.log(FACTOR_TOLERANCE), (moved, own)


def test_the_recorded_spread_is_seeded_and_off_at_zero_resamples(recorded) -> None:
    """The bootstrap spread of a run's figures: the same seed gives the same spread, every
    figure has one, and without resamples it is 0 (the tolerance alone)."""
    run = load_run(recorded["real"])
    spread = figure_spread(run, 8, seed=4)
    assert spread == figure_spread(run, 8, seed=4)
    assert set(spread) == set(figure_values(run)) and all(v > 0 for v in spread.values())
    assert set(figure_spread(run, 0, seed=4).values()) == {0.0}


def test_figures_off_cost_nothing_and_need_sheared_taps(recorded, tmp_path, capsys) -> None:
    """With weights.edge_figures at 0 (the shipped settings) no figure is computed or
    reported; weighted on a run that is not sheared taps, calibrate exits 2 naming the
    field and the run's protocol."""
    from twin.analysis.calibration_fit.data import load_data
    from twin.analysis.calibration_fit.evaluator import Evaluator
    from twin.analysis.calibration_fit.space import Space
    from twin.runs.parallel import WorkerPool

    settings = load_settings(None)
    assert settings.weights.edge_figures == 0.0
    data = load_data([recorded["real"]], recorded["scenario"], settings.weights)
    with WorkerPool(1) as pool:
        assert Evaluator(Space(recorded["scenario"], settings), data, pool).figures is None

    taps = {**TWIN, "name": "plain_taps", "protocol": {"kind": "taps", "lateral_mm": [0], "depths_mm": [2]}}
    (tmp_path / "taps.yaml").write_text(yaml.safe_dump(taps))
    run = run_scenario(scenario_from_dict(taps), tmp_path / "taps", workers=1, progress=False)
    (tmp_path / "settings.yaml").write_text(yaml.safe_dump(FIGURES_ONLY))
    args = ["calibrate", str(run), "--scenario", str(tmp_path / "taps.yaml"), "--out", str(tmp_path / "cal")]
    assert main([*args, "--settings", str(tmp_path / "settings.yaml"), "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "weights.edge_figures' needs sheared-tap runs" in err and "'taps'" in err


def test_the_jacobian_stays_inside_the_bounds(recorded, tmp_path) -> None:
    """At a parameter's bound the uncertainty's difference is one-sided: no candidate is
    simulated beyond it (a bending modulus stepped below its least would not even load)."""
    from twin.analysis.calibration_fit.data import load_data
    from twin.analysis.calibration_fit.evaluator import Evaluator
    from twin.analysis.calibration_fit.space import Space
    from twin.analysis.calibration_fit.uncertainty import jacobian
    from twin.runs.parallel import WorkerPool

    bounded = {**FIGURES_ONLY["parameters"], "friction": {"fit": True, "lower": 0.3, "upper": 1.2}}
    (tmp_path / "settings.yaml").write_text(yaml.safe_dump({**FIGURES_ONLY, "parameters": bounded}))
    settings = load_settings(tmp_path / "settings.yaml")
    data = load_data([recorded["real"]], recorded["scenario"], settings.weights)
    with WorkerPool(1) as pool:
        ev = Evaluator(Space(recorded["scenario"], settings), data, pool)
        at_bound = {"friction": 0.3}
        column = jacobian(ev, at_bound, ev.simulate_one(at_bound, "the test point"))
        simulated = sorted(dict(k)["friction"] for k in ev._cache)
    assert simulated == [0.3, pytest.approx(0.3 + 0.05 * 0.9)]
    assert column.shape == (len(ev.row_sample), 1) and np.abs(column).max() > 0


def test_the_still_signal_is_the_replay_without_slides(recorded) -> None:
    """With settings edge_signal: still the twin's signal onto the object (l < 0) is that of
    the recorded taps replayed at their poses without their slides and twists (as `twin
    run` records them with the protocol's slides off), on the recorded run's usable frames;
    off the object, and the other figures, are the sheared replay's, as without it."""
    from twin.analysis.calibration_fit.data import load_data
    from twin.analysis.calibration_fit.evaluator import Evaluator
    from twin.analysis.calibration_fit.space import Space
    from twin.analysis.edge_imprint import signal_profile, signal_shift_share, usable
    from twin.runs.parallel import WorkerPool
    from twin.runs.record import Run

    settings = load_settings(None).model_copy(update={"edge_signal": "still"})
    settings = settings.model_copy(update={"weights": settings.weights.model_copy(update={"edge_figures": 1.0})})
    scenario = recorded["scenario"]
    tables = {}
    for still, shift in ((False, "kept"), (True, "kept"), (True, "apart")):
        data = load_data([recorded["real"]], scenario, settings.weights, still_replays=still)
        with WorkerPool(1) as pool:
            ev = Evaluator(Space(scenario, settings.model_copy(update={"edge_signal_shift": shift})), data, pool)
            values = dict(ev.space.defaults)
            tips = ev.simulate_one(values, "the twin as the scenario has it")
            rows = ev.figure_table(tips, values)
            tables[still if shift == "kept" else shift] = {(r["figure"], r["lateral_mm"]): r["twin"] for r in rows}
        assert data.still_of == ([0] if still else []) and len(tips) == (2 if still else 1) * len(data.pins)

    protocol = scenario.protocol.without_slides().model_dump()
    still_dir = run_scenario(
        scenario.with_changes(protocol=protocol), recorded["root"] / "still", workers=1, progress=False
    )
    still_run = load_run(still_dir)
    assert np.all(still_run.label("slide_along_mm")[1:] == 0.0) and np.all(still_run.label("twist_deg")[1:] == 0.0)
    real = load_run(recorded["real"])
    np.testing.assert_allclose(still_run.label("lateral_mm"), real.label("lateral_mm"))
    keep = usable(real) | np.array([bool(s["labels"].get("no_contact")) for s in real.samples])
    (expected,) = signal_profile(
        Run(still_run.path, still_run.meta, [s for s, k in zip(still_run.samples, keep) if k])
    ).values()
    onto = {l: v for (f, l), v in tables[True].items() if f == "signal" and l < 0}
    assert onto and onto == pytest.approx({l: v for l, v in expected.items() if l < 0}, abs=1e-6)
    assert onto != pytest.approx({l: v for (f, l), v in tables[False].items() if f == "signal" and l < 0}, abs=1e-3)
    others = {k: v for k, v in tables[True].items() if not (k[0] == "signal" and k[1] < 0)}
    assert ("signal", 1.0) in others
    assert others == pytest.approx({k: v for k, v in tables[False].items() if not (k[0] == "signal" and k[1] < 0)})
    # apart: onto the object the still replay's signal without its shift, and its shift's share
    still_used = Run(still_run.path, still_run.meta, [s for s, k in zip(still_run.samples, keep) if k])
    (without,) = signal_profile(still_used, without_shift=True).values()
    (shares,) = signal_shift_share(still_used).values()
    apart = tables["apart"]
    assert {l: v for (f, l), v in apart.items() if f == "signal" and l < 0} == pytest.approx(
        {l: v for l, v in without.items() if l < 0}, abs=1e-6
    )
    assert {l: v for (f, l), v in apart.items() if f == "shift" and l < 0} == pytest.approx(
        {l: v for l, v in shares.items() if l < 0}, abs=1e-6
    )
    assert {k for k in apart if k[0] == "shift"} == {("shift", l) for (f, l) in apart if f == "signal"} | {
        ("shift", 0.0)
    }
    assert {k: v for k, v in apart.items() if k[0] not in ("signal", "shift")} == pytest.approx(
        {k: v for k, v in tables[True].items() if k[0] != "signal"}
    )


def test_pooled_misses_weigh_each_bin_by_its_recorded_spread() -> None:
    """settings edge_figure_bins: pooled: one miss per figure and side of the edge. Three bins
    onto the object, recorded to ±0.05, ±0.10 and ±0.10 in the ratio, the twin 0.2, 0.0 and
    −0.2 above them: weights 400, 100, 100, so the pooled difference is (80 − 20) / 600 =
    0.1, its error 1 / √600, and the miss 0.1 / √(0.1² + 1 / 600). The bins scatter more
    than their spreads allow, and the miss is not widened for it (that would reward a twin
    that scatters). Off the object the twin lacks one of two bins: the other alone is
    pooled; a side the twin lacks entirely misses by MISSING_MISS."""
    from twin.analysis.calibration_fit.figures import pooled_rows

    def row(figure: str, l: float, recorded: float, spread: float, twin: float | None) -> dict:
        return {"run": 0, "figure": figure, "lateral_mm": l, "recorded": recorded, "spread": spread, "twin": twin}

    rows = [
        row("signal", -3.0, 0.60, 0.05, 0.80),
        row("signal", -2.0, 0.70, 0.10, 0.70),
        row("signal", -1.0, 0.90, 0.10, 0.70),
        row("signal", 1.0, 1.10, 0.05, 1.00),
        row("signal", 2.0, 1.20, 0.05, None),
        row("theta_pc23", -2.0, 4.0, 0.2, None),
        row("theta_pc23", 1.0, 0.5, 0.1, 0.5 * 1.5),
    ]
    pooled = {(r["figure"], r["side"]): r for r in pooled_rows(rows)}
    assert set(pooled) == {("signal", "onto"), ("signal", "off"), ("theta_pc23", "onto"), ("theta_pc23", "off")}
    onto = pooled["signal", "onto"]
    assert onto["bins"] == 3 and onto["recorded"] == pytest.approx((240 + 70 + 90) / 600)
    assert onto["twin"] - onto["recorded"] == pytest.approx(0.1)
    assert onto["spread"] == pytest.approx(600**-0.5)
    assert onto["miss"] == pytest.approx(0.1 / math.hypot(SIGNAL_TOLERANCE, 600**-0.5))
    assert onto["miss_tolerance"] == pytest.approx(1.0)
    off = pooled["signal", "off"]
    assert off["bins"] == 1 and off["miss"] == pytest.approx(miss("signal", 1.00, 1.10, 0.05))
    assert pooled["theta_pc23", "onto"]["miss"] == MISSING_MISS and pooled["theta_pc23", "onto"]["twin"] is None
    assert pooled["theta_pc23", "off"]["miss"] == pytest.approx(miss("theta_pc23", 0.75, 0.5, 0.1))


def test_pooled_figures_in_a_calibration(recorded, tmp_path, capsys) -> None:
    """The target pooled: a miss per figure and side, as many residuals as the evaluator
    counts for the uncertainty's clusters; a side of one bin misses as that bin does, and a
    side of two by their spread-weighted mean. Pooling without resamples (no spreads to
    weigh by) is refused by name, exit 2."""
    from twin.analysis.calibration_fit.data import load_data
    from twin.analysis.calibration_fit.evaluator import Evaluator
    from twin.analysis.calibration_fit.figures import difference
    from twin.analysis.calibration_fit.space import Space
    from twin.runs.parallel import WorkerPool

    base = load_settings(None)
    weights = base.weights.model_copy(update={"edge_figures": 1.0})
    data = load_data([recorded["real"]], recorded["scenario"], weights)
    tables, lengths = {}, {}
    with WorkerPool(1) as pool:
        for bins in ("each", "pooled"):
            settings = base.model_copy(update={"weights": weights, "edge_figure_bins": bins})
            ev = Evaluator(Space(recorded["scenario"], settings), data, pool)
            values = dict(ev.space.defaults)
            tips = ev.simulate_one(values, "the twin as the scenario has it")
            tables[bins] = ev.figure_table(tips, values)
            lengths[bins] = (len(ev.residuals(tips, values, priors=False)), len(ev.row_sample))
    assert lengths["pooled"][0] == lengths["pooled"][1] and lengths["each"][0] == lengths["each"][1]
    each = {(r["figure"], r["lateral_mm"]): r for r in tables["each"]}
    pooled = {(r["figure"], r["side"]): r for r in tables["pooled"]}
    assert lengths["each"][0] - lengths["pooled"][0] == len(each) - len(pooled) > 0
    assert pooled["signal", "onto"]["miss"] == pytest.approx(each["signal", -1.0]["miss"])
    two = [each["drag/signal", 0.0], each["drag/signal", 1.0]]
    assert pooled["drag/signal", "off"]["bins"] == 2
    w = np.array([r["spread"] for r in two]) ** -2
    d = np.sum(w * [difference("drag/signal", r["recorded"], r["twin"]) for r in two]) / w.sum()
    assert pooled["drag/signal", "off"]["miss"] == pytest.approx(
        d / math.hypot(math.log(FACTOR_TOLERANCE), w.sum() ** -0.5)
    )

    (tmp_path / "settings.yaml").write_text(
        yaml.safe_dump({**FIGURES_ONLY, "edge_figure_bins": "pooled", "edge_figure_resamples": 0})
    )
    args = ["calibrate", str(recorded["real"]), "--scenario", str(recorded["root"] / "twin.yaml")]
    assert main([*args, "--out", str(tmp_path / "cal"), "--settings", str(tmp_path / "settings.yaml")]) == 2
    err = capsys.readouterr().err
    assert "edge_figure_resamples must be 2 or more" in err and "settings.yaml" in err
