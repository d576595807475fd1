"""The fit behind `twin calibrate`: the twin's parameters from recorded runs of one sensor.

    twin calibrate RUN [RUN…] --scenario S --out DIR [--settings F] [--workers N | --cluster ADDR]

The model of a recorded pin (px) in sample i, pin k:

    pin_ik = camera(θ_cam).project(tip_ik(θ_phys)) + rest_k

* tip_ik(θ_phys): the simulated pin tip (tool frame) at the sample's target pose, reached
  along the run's own path (twin.runs.replay), for the physics parameters θ_phys: dome
  material, skin–stimulus friction, TCP offset. Every evaluation re-simulates the runs
  (projected pins, no rendering), in parallel over chunks and candidates.
* camera(θ_cam): intrinsics, distortion, pose in the tool (twin.core.sensor.CameraModel).
* camera start: with settings.camera_from_rest, those camera parameters are first fitted to
  the no-contact frames' pins as the lattice projected (no rest offsets; their priors
  apply), and the values start the fit (a camera unlike the twin's: another crop, roll or
  distance, whose layout the ≤ 50 px rest offsets cannot absorb); fitted or not later,
  they are reported with their Gauss–Newton errors. With settings.camera_tied_to_rest those
  not fitted are fitted to those frames again wherever the fit moves the fitted camera
  parameters (Evaluator.camera_values): a camera distance, which the frames at rest leave
  nearly free, is then fitted on the taps among the cameras that meet the rest frames.
* rest_k: the rest layout's offset from the lattice, in closed form: the weighted mean,
  over the no-contact frames (target z ≤ 0 in the work frame), of recorded minus projected
  pins (the least-squares solution for given θ). Without no-contact frames it stays 0 and
  the report says so.

Objective: χ² = Σ w_i |pin_ik − recorded_ik|² / σ² + w_e Σ_f miss_f² + Σ ((θ − θ_default)/prior_std)²,
with σ = settings.noise_px, per-frame weights w by group (rest, contact, sliding), and
w_e = weights.edge_figures: on sheared-tap runs, the misses of the edge figures of the
twin's predicted pins against the recorded ones, each over its tolerance and the recorded
figure's spread (twin.analysis.calibration_fit.figures; a frame of zero weight still
counts there), taken at the camera the pins solve; with settings edge_signal: still the
twin's signal ratios onto the object come from its replay of the same taps without their
slides, and with edge_figure_bins: pooled there is one miss per figure and side of the
edge, its bins weighted by their recorded spread. A
pin-level misfit shared by every frame (the camera's, or the model's) can outweigh what
the physics parameters do to the edge; with the contact weights at 0 the camera is fitted
to the no-contact frames and the physics to the figures alone. The
expensive, noisy physics parameters are searched by CMA-ES (`cma`; one alone, which pycma
cannot search, by a shrinking grid: BracketSearch); for each candidate the cheap, smooth
camera parameters are solved by least squares (scipy, trust region) — a separable
("variable projection") problem, so the search covers only the few physics dimensions.
Stop rule: the best χ² improved by less than `tol_relative` over `patience` generations
(converged) or `max_generations` reached (not converged: the command exits 1, best point kept).
Each generation is checkpointed (DIR/checkpoint.json, DIR/history.jsonl); a calibration
started again with the same runs, scenario and settings resumes from it.

Uncertainty: J is the Jacobian of the whitened residuals at the optimum (central
differences; physics columns by simulation). Each parameter's standard error is the larger
of the Gauss–Newton s²(JᵀJ)⁻¹ (s² the reduced χ²) and the cluster-robust sandwich with the
samples as clusters (a frame's pins share their errors). A parameter is identifiable from
these runs when that error is below `identifiable_fraction` of its bounds' range, its
whole range moves the pins by more than the fit's pin RMS, and its Jacobian column is not
nearly in the span of the others (variance inflation ≤ `max_variance_inflation`); one that
is not is reported as such, with the reasons, and left at its default in the calibration
file, not silently fitted (twin.analysis.calibration_fit.uncertainty says why each test).

Held-out runs (`held_out`) are not fitted: their pins are predicted with the twin as the
scenario has it (before) and with the fitted values and the fit's rest layout (after), and
the pin RMS of both is reported beside the fitted runs'.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from twin.analysis.calibration_fit.data import GROUPS, load_data
from twin.analysis.calibration_fit.evaluator import Evaluator
from twin.analysis.calibration_fit.search import CHECKPOINT, optimise, search_key
from twin.analysis.calibration_fit.settings import CalibrationSettings
from twin.analysis.calibration_fit.space import Space
from twin.analysis.calibration_fit.uncertainty import uncertainty
from twin.core.calibration import REST_OFFSET_LIMIT_PX, write_calibration
from twin.core.errors import UserError, WorkerLostError
from twin.core.scenario import Scenario
from twin.runs.lab_recording import nominal_depth_mm
from twin.runs.parallel import WorkerPool


def calibrate(
    run_dirs: list[Path],
    scenario: Scenario,
    out: Path,
    settings: CalibrationSettings,
    workers: int | None = None,
    cluster: str | None = None,
    progress: bool = True,
    held_out: list[Path] | None = None,
) -> dict:
    """Fit the twin to the runs (module docstring); `held_out` runs are not fitted, only
    predicted before and after (the fit's rest layout, not their own); writes DIR/calibration.yaml (converged) or
    DIR/best_calibration.yaml (not: the result's status says so), the report data
    report.json (the returned result), history.jsonl and checkpoint.json. The command
    (twin.tools.calibration_report.calibrate_and_report) adds report.md and residuals.png.
    workers / cluster: as twin.runs.parallel.WorkerPool, one pool for all the simulations."""
    try:
        with WorkerPool(workers, cluster) as pool:
            return _calibrate(run_dirs, scenario, out, settings, pool, progress, [Path(r) for r in held_out or []])
    except WorkerLostError as lost:  # a transient loss (the out-of-memory killer): the fit can go on
        raise lost.going_on(
            f"{out / CHECKPOINT} keeps every finished generation: the same twin calibrate goes on from there"
        ) from lost


def _camera_from_rest(ev: Evaluator, tips: np.ndarray) -> dict | None:
    """The camera start from the no-contact frames (settings.camera_from_rest), made the
    parameters' defaults; None when the settings name none."""
    names = ev.space.settings.camera_from_rest
    if not names:
        return None
    if not ev.rest.any():
        raise UserError(
            "calibration settings: field 'camera_from_rest' needs no-contact frames (target z <= 0) in the runs; "
            "there are none"
        )
    estimate = ev.solve_rest_camera(tips, list(names), ev.space.defaults)
    estimate["twin"] = {n: ev.space.defaults[n] for n in names}
    ev.space.defaults.update(estimate["values"])
    # the pins with this camera, the rest layout fitted and the twin's physics: what the camera alone does
    alone = ev.rms(tips, dict(ev.space.defaults))
    estimate["pin_rms_px"] = {"overall": alone["overall"], "groups": alone["groups"]}
    tied = ev.space.settings.tied
    estimate["tied"] = tied
    if tied:
        ev.tie(tied, estimate["values"], estimate["twin"])
    return estimate


def _predicted_elsewhere(
    runs: list[Path], space: Space, pool: WorkerPool, before: dict, after: dict, offsets: np.ndarray | None
) -> dict:
    """Pin RMS on runs the fit did not see, before (the scenario's twin) and after (the
    fitted values and the fit's rest layout)."""
    data = load_data(runs, space.scenario, space.settings.weights)
    ev = Evaluator(space, data, pool)
    ev.fit_rest = False
    tips_before = ev.simulate_one(before, "the twin as the scenario has it, on the held-out runs,")
    tips_after = ev.simulate_one(after, "the fitted point, on the held-out runs,")
    rms_before = ev.rms(tips_before, before)
    ev.fixed_offsets = offsets
    rms_after = ev.rms(tips_after, after)
    keep = ("overall", "groups", "runs")
    return {
        "runs": [str(r) for r in runs],
        "samples": int(len(data.pins)),
        "before": {k: rms_before[k] for k in keep},
        "after": {k: rms_after[k] for k in keep},
    }


def _calibrate(
    run_dirs: list[Path],
    scenario: Scenario,
    out: Path,
    settings: CalibrationSettings,
    pool: WorkerPool,
    progress: bool,
    held_out: list[Path],
) -> dict:
    wall = time.perf_counter()
    if scenario.backend != "sim":
        scenario = scenario.with_changes(backend="sim")
    still = settings.edge_signal == "still" and settings.weights.edge_figures > 0
    data = load_data([Path(r) for r in run_dirs], scenario, settings.weights, still_replays=still)
    space = Space(scenario, settings)
    out.mkdir(parents=True, exist_ok=True)
    ev = Evaluator(space, data, pool)
    before_tips = ev.simulate_one(space.defaults, "the twin as the scenario has it")
    before_values = dict(space.defaults)
    # "before" is the twin as the scenario has it: its rest layout, not one fitted to these runs
    ev.fit_rest, fit_rest = False, ev.fit_rest
    before = ev.rms(before_tips, before_values)
    figures_before = ev.figure_table(before_tips, before_values)
    ev.fit_rest = fit_rest
    rest_camera = _camera_from_rest(ev, before_tips)
    state = optimise(ev, out, search_key(run_dirs, scenario, settings), progress)
    best = state["best"]
    best_tips = ev.simulate_one(best, "the best point")
    errors = uncertainty(ev, best, best_tips)
    # what the data cannot identify goes back to its default, and the camera is solved again without it
    final = dict(best)
    dropped = [n for n, u in errors["parameters"].items() if not u["identifiable"]]
    for n in dropped:
        final[n] = space.defaults[n]
    final_tips = best_tips
    if any(n in space.physics for n in dropped):
        final_tips = ev.simulate_one(final, "the fitted point (what the runs do not identify at its default)")
    if dropped and space.camera:
        keep = [n for n in space.camera if n not in dropped]
        space.camera = keep
        final = ev.solve_camera(final_tips, {n: v for n, v in final.items() if n not in keep}, final)
    # tied camera parameters: their values at the fitted camera, written with the others
    final = ev.camera_values(final_tips, final)
    if rest_camera is not None and rest_camera["tied"]:
        rest_camera["at_fit"] = {n: final[n] for n in ev.tied}
        # the cameras that meet the no-contact frames end at a bound there: that frame no longer holds the lens
        rest_camera["at_fit_at_bound"] = [n for n in ev.tied if space.at_bound(n, final[n])]
    _, offsets = ev.predict(final_tips, final)
    if ev.fit_rest and np.abs(offsets).max() > REST_OFFSET_LIMIT_PX:
        raise UserError(
            f"the runs' rest pins lie {np.abs(offsets).max():.1f} px from the fitted camera's (a calibration "
            f"holds at most {REST_OFFSET_LIMIT_PX:.0f} px): the camera's bounds in the calibration settings "
            f"do not reach this sensor's camera; widen them (--settings) and fit again"
        )
    calibration = space.calibration(final, offsets if ev.fit_rest else None)
    after = ev.rms(final_tips, final)
    figures_after = ev.figure_table(final_tips, final)
    elsewhere = (
        _predicted_elsewhere(held_out, space, pool, before_values, final, offsets if ev.fit_rest else None)
        if held_out
        else None
    )
    name = "calibration.yaml" if state["converged"] else "best_calibration.yaml"
    write_calibration(calibration, out / name)
    result = {
        "status": "converged" if state["converged"] else "not converged",
        "stop_reason": state["stop"],
        "runs": [str(r) for r in run_dirs],
        # the depth a sheared-taps run's taps are offsets from (an imported recording's: the nominal it was
        # imported at, which the lab does not record): the fitted depth offset is from it
        "nominal_depth_mm": {
            str(r): d for r, run in zip(run_dirs, data.records) if (d := nominal_depth_mm(run)) is not None
        },
        "scenario": scenario.source,
        "calibration_file": str(out / name),
        "samples": int(len(data.pins)),
        "samples_per_group": {g: int((data.group == k).sum()) for k, g in enumerate(GROUPS)},
        "fitted": space.fitted,
        "not_identifiable": dropped,
        "rest_pins": f"fitted from {int(ev.rest.sum())} no-contact frames"
        if ev.fit_rest
        else (
            "not fitted: no no-contact frames (target z <= 0) in the runs"
            if settings.rest_pins
            else "not fitted (settings)"
        ),
        "frame_px": [scenario.sensor.camera.width, scenario.sensor.camera.height],
        # where the recorded pins are: their mean over the no-contact frames (all frames without one)
        "pin_positions_px": np.nanmean(data.pins[ev.rest] if ev.rest.any() else data.pins, axis=0).tolist(),
        "before": before,
        "after": after,
        "camera_from_rest": rest_camera,
        "edge_figures": None
        if figures_after is None
        else {
            "weight": settings.weights.edge_figures,
            "signal_from": settings.edge_signal,
            "signal_shift": settings.edge_signal_shift,
            "theta_plane": settings.edge_theta_plane,
            "bins": settings.edge_figure_bins,
            "before": figures_before,
            "after": figures_after,
        },
        "held_out": elsewhere,
        "uncertainty": errors,
        "generations": state["generation"],
        "best_chi2": state["best_chi2"],
        "simulations": ev.simulations,
        "failed_simulations": ev.failures,
        "simulated_frames_per_s": ev.simulations * len(data.pins) / max(ev.sim_seconds, 1e-9),
        "evaluations_per_s": ev.simulations / max(ev.sim_seconds, 1e-9),
        "wall_time_s": time.perf_counter() - wall,
        "workers": pool.workers,
        "cluster": pool.cluster,
        "unfinished": data.unfinished,
        "without_pins": data.without_pins,
    }
    (out / "report.json").write_text(json.dumps(result, indent=1, default=float))
    return result
