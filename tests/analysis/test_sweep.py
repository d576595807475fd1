"""`twin bench sweep`: what accuracy costs in time. The quick sweep is the smoke check
(run as the CLI in its own process, as a user would); no timing asserts, only that the
outputs exist and make sense. The Pareto rules and the failure reporting are checked on
small inputs, the settling error's reference (SensorPhysics.converged_pins) on the edge scene."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.sweep.fronts import annotate_fronts, dominates, dominators, pareto_flags, peers
from twin.analysis.sweep.knobs import COMPLIANT_REFERENCE, DEFAULT, REFERENCE, Setting, quick_settings
from twin.analysis.sweep.probe import Probe
from twin.core.errors import PhysicsError, UserError
from twin.tools.sweep_report import CSV_COLUMNS, markdown_table, sweep_and_report
from twin.world.dome.compliant import PLAIN_SOLID
from twin.world.dome.flex import FIDELITY_LEVELS
from twin.world.dome.testbed import edge_scene, sensor_down

ROOT = Path(__file__).resolve().parents[2]


def _read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _f(v: str) -> float:
    return float(v) if v not in ("", None) else float("nan")


@pytest.mark.slow
def test_quick_sweep_writes_a_consistent_table(tmp_path) -> None:
    out = tmp_path / "bench"
    proc = subprocess.run(
        [sys.executable, "-m", "twin.tools.cli", "bench", "sweep", "--quick", "--out", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    for name in ("sweep.csv", "sweep.md", "sweep.json", "pareto.png"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert (out / "pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    rows = _read_csv(out / "sweep.csv")
    assert set(CSV_COLUMNS) <= set(rows[0]), set(CSV_COLUMNS) - set(rows[0])
    by = {r["setting"]: r for r in rows}
    assert list(by) == [s.name for s in quick_settings()]
    assert all(r["status"] == "ok" for r in rows), [(r["setting"], r["error"]) for r in rows]

    ref = by[REFERENCE]
    assert _f(ref["pin_rms_px"]) < 1e-6 and _f(ref["pin_physics_rms_px"]) < 1e-6  # the reference against itself
    for r in rows:
        for stage in ("physics_ms", "perception_ms", "total_ms", "physics_wall_ms", "total_wall_ms"):
            assert _f(r[stage]) > 0, (r["setting"], stage, r[stage])
        assert _f(r["total_ms"]) >= _f(r["physics_ms"])
        assert int(r["n_timed_frames"]) > 0 and int(r["n_slide_frames"]) > 0 and int(r["contour_steps"]) > 0
        for ratio in ("time", "physics"):  # best against best lies within the rounds' own ratios
            low, best, high = (_f(r[f"{ratio}_x_default{end}"]) for end in ("_min", "", "_max"))
            assert 0 < low <= best <= high, (r["setting"], ratio, low, best, high)
        assert np.isfinite(_f(r["pin_rms_px"])) and np.isfinite(_f(r["theta_rms_deg"]))
        assert np.isfinite(_f(r["lateral_rms_mm"])) and np.isfinite(_f(r["contour_path_mean_mm"]))
        assert _f(r["pin_settling_rms_px"]) > 0, r  # every quick setting has contact: measured, never exact
        if r["output"] == "frames":
            assert _f(r["render_ms"]) > 0 and _f(r["track_ms"]) > 0
            assert 0 < _f(r["pin_tracking_rms_px"]) < 1.0, r  # the tracker finds the rendered pins to < 1 px
        else:
            assert _f(r["pin_tracking_rms_px"]) == 0.0  # projected pins are the true pins
    # render changes how pins are read, never the physics: identical true pins
    assert by["render_off"]["pin_physics_rms_px"] == by[DEFAULT]["pin_physics_rms_px"]
    assert (
        by["render_off"]["pin_settling_rms_px"]
        == by[DEFAULT]["pin_settling_rms_px"]
        == by["msaa_4"]["pin_settling_rms_px"]
    )
    assert _f(by[DEFAULT]["pin_physics_rms_px"]) > 0  # the default grid is coarser than the reference's
    assert all(
        _f(by[DEFAULT][f"{ratio}_x_default{end}"]) == 1.0
        for ratio in ("time", "physics")
        for end in ("", "_min", "_max")
    )
    # every ok row is flagged on or off the front, the default included
    assert all(r["on_front"] in ("True", "False") for r in rows)
    md = (out / "sweep.md").read_text()
    assert "settling err px" in md
    verdict = "lies on the Pareto front" if by[DEFAULT]["on_front"] == "True" else "NOT on the Pareto front"
    assert verdict in md and "Failures: 0." in md
    assert sum(line.startswith("| ") for line in md.splitlines()) == len(rows) + 1  # header + one per setting
    meta = json.loads((out / "sweep.json").read_text())["meta"]
    assert meta["quick"] is True and meta["failures"] == []
    assert meta["timing"]["repeats"] >= 2 and meta["timing"]["orientations_deg"]  # the serial timing pass ran


def test_failed_setting_is_recorded_counted_and_kept_off_the_front(tmp_path) -> None:
    tiny = Probe(
        tap_orientations_deg=(0.0, 180.0),
        slide_orientations_deg=(0.0,),
        directions_deg=(0.0,),
        lateral_mm=(9.9, 4.0, 0.0, -4.0),
        tap_depths_mm=(2.0, 4.0),
        contour_max_steps=3,
        gp_restarts=0,
    )
    settings = [
        Setting(REFERENCE, "reference", "fast", effects=("contact", "friction")),
        Setting("bad_timestep", "time step", physics={"timestep_s": 1.0}),
    ]
    rows = sweep_and_report(tmp_path, settings=settings, probe=tiny, workers=1, verbose=False)
    ok, bad = rows
    assert ok["status"] == "ok" and ok["pin_rms_px"] == 0.0 and ok["on_front"] is True
    assert bad["status"] == "failed" and bad["stage"] == "build" and "timestep_s" in bad["error"]
    assert bad["on_front"] is None
    md = (tmp_path / "sweep.md").read_text()
    assert "Failures: 1" in md and "bad_timestep" in md and "failed in build" in md
    csv_rows = _read_csv(tmp_path / "sweep.csv")
    assert csv_rows[1]["status"] == "failed" and "timestep_s" in csv_rows[1]["error"]


def _row(
    name: str, ms: float, err: float, output: str = "frames", status: str = "ok", settling: float | None = None
) -> dict:
    row = {"setting": name, "output": output, "status": status, "total_ms": ms, "pin_rms_px": err}
    if settling is not None:
        row["pin_settling_rms_px"] = settling
    return row


def test_pareto_front_with_noise_margins() -> None:
    rows = [
        _row("slow_exact", 100.0, 0.0),
        _row("mid", 40.0, 3.0),
        _row("fast_rough", 20.0, 6.0),
        _row("dominated", 60.0, 4.0),
        _row("noise_twin", 41.0, 3.01),
        _row("pins", 10.0, 3.0, output="pins"),
        _row("broken", 1.0, 0.0, status="failed"),
    ]
    flags = dict(zip([r["setting"] for r in rows], pareto_flags(rows, "pin_rms_px")))
    assert flags == {
        "slow_exact": True,
        "mid": True,
        "fast_rough": True,
        "dominated": False,
        "noise_twin": True,
        "pins": True,
        "broken": None,
    }
    # across output kinds the projected-pin setting dominates the rendered one of equal error
    assert dominates(rows[5], rows[1], "pin_rms_px")
    assert pareto_flags(rows, "pin_rms_px", by_output=False)[1] is False
    # a difference within the noise margins is no domination either way
    assert not dominates(rows[4], rows[1], "pin_rms_px") and not dominates(rows[1], rows[4], "pin_rms_px")


def test_markdown_reports_a_default_off_the_front() -> None:
    rows = [
        dict(_row(REFERENCE, 100.0, 0.0, output="pins"), knob="reference", on_front=True),
        dict(_row(DEFAULT, 50.0, 4.0), knob="default", on_front=False),
        dict(_row("better", 30.0, 3.0), knob="x", on_front=True),
    ]
    meta = {
        "probe": {
            "tap_orientations_deg": [0],
            "lateral_mm": [0],
            "tap_depths_mm": [2],
            "slide_orientations_deg": [0],
            "directions_deg": [0],
            "contour_max_steps": 1,
        },
        "failures": [],
        "date": "today",
        "machine": "m",
        "gl": "egl",
        "workers": 1,
        "quick": True,
        "wall_s": 1.0,
    }
    md = markdown_table(rows, meta)
    assert "**The default is NOT on the Pareto front**" in md and "Failures: 0." in md


def test_primary_front_weighs_pin_and_settling_error() -> None:
    # the settle tolerance case: ×2 looser is faster at the same pin error (the grid's
    # discretisation hides the settling) but settles worse, so it must not push the default off
    default = _row(DEFAULT, 21.5, 4.03, settling=0.09)
    loose = _row("settle_x2", 18.8, 4.08, settling=0.24)
    assert dominates(loose, default, "pin_rms_px")  # what the pin error alone would say
    assert not dominates(loose, default) and not dominates(default, loose)
    assert pareto_flags([default, loose]) == [True, True]
    assert dominators([default, loose], default) == []
    # faster and better in both errors: dominates; within the settling margin (0.01 px) counts as equal
    better = _row("better", 18.8, 4.0, settling=0.05)
    noise = _row("noise_twin", 18.8, 4.03, settling=0.095)
    assert dominates(better, default) and dominates(noise, default)
    assert pareto_flags([default, loose, better]) == [False, False, True]  # it beats the loose one too
    assert dominators([default, loose, better, noise], default) == ["better", "noise_twin"]
    # a figure neither row has (an older sweep.json) is left out; one only one row has is no comparison
    assert dominates(_row("a", 10.0, 4.0), _row("b", 20.0, 4.0))
    assert not dominates(_row("a", 10.0, 4.0), default) and not dominates(better, _row("b", 30.0, 5.0))


def test_time_is_compared_round_by_round() -> None:
    """Host noise: in one sweep the settle tolerance halved (strictly more work per frame)
    timed 0.92× the default best against best, 0.92–1.24× round by round, and so pushed
    the default off the front on its smaller settling error. Compared round by round it
    is faster in one round and slower in another: no domination. A setting faster in
    every round by more than the margin still dominates, and rows without rounds (an older
    sweep.json) are compared best against best."""
    default = dict(_row(DEFAULT, 21.0, 4.0, settling=0.09), round_ms=[20.0, 18.0, 22.0])
    tighter = dict(_row("settle_x0.5", 19.4, 4.0, settling=0.03), round_ms=[18.4, 22.3, 20.5])
    assert dominates({k: v for k, v in tighter.items() if k != "round_ms"}, default)  # best against best
    assert not dominates(tighter, default) and not dominates(default, tighter)
    assert pareto_flags([default, tighter]) == [True, True]
    faster = dict(_row("faster", 17.2, 4.0, settling=0.09), round_ms=[18.0, 16.2, 19.8])
    assert dominates(faster, default) and pareto_flags([default, faster]) == [False, True]
    # rounds of another count (another --quick setting) are no pairs: best against best
    assert dominates(dict(faster, round_ms=[16.2, 17.0]), default)


def test_converged_pins_are_near_the_frame_and_leave_the_simulation_untouched() -> None:
    params = FIDELITY_LEVELS["default"]

    def run(converge: bool):
        _, data, _, physics = edge_scene(params, start_tool2world=sensor_down(0, 0, -1.0))
        physics.move(sensor_down(0, 0, 3), 15.0)
        frame = physics.settle()
        converged = None
        if converge:
            steps, seconds = physics.steps, physics.step_seconds
            converged = physics.converged_pins()
            assert physics.steps == steps and physics.step_seconds == seconds  # extra steps are not counted
            with pytest.raises(PhysicsError, match="did not settle within 2 steps"):
                physics.converged_pins(settle_px=1e-9, max_steps=2)
        physics.move(sensor_down(0, 3, 3), 15.0)
        return frame, converged, physics.settle(), physics, data

    frame, converged, after, physics, data = run(True)
    px = physics.camera.project_tool_points
    moved = float(np.max(np.abs(px(converged) - px(frame.pins_tool))))
    # settling converges geometrically, so the frame is within a few bands of where it was
    # going (0.04 px here, 0.1–0.17 px at other presses on the box)
    assert 0 < moved < 4 * params.settle_px
    frame0, _, after0, physics0, data0 = run(False)
    assert np.array_equal(frame.pins_tool, frame0.pins_tool)
    # the next frame continues bit-identically: pins, time, steps, forces, state
    assert np.array_equal(after.pins_tool, after0.pins_tool)
    assert (after.time, after.n_steps, after.settle_steps, after.contact_force) == (
        after0.time,
        after0.n_steps,
        after0.settle_steps,
        after0.contact_force,
    )
    assert physics.steps == physics0.steps
    assert np.array_equal(data.qpos, data0.qpos) and np.array_equal(data.qvel, data0.qvel)
    assert np.array_equal(data.qacc_warmstart, data0.qacc_warmstart)


@pytest.mark.slow
def test_compliant_settings_are_measured_against_their_own_reference(tmp_path) -> None:
    """Both dome models in one sweep: each setting's pin error is against its own model's
    reference (the compliant reference against itself: 0), the plain solid (another
    material) has none, pin fronts never mix the models, the contour front does; without its reference a
    model's settings are refused."""
    tiny = Probe(
        tap_orientations_deg=(0.0, 180.0),
        slide_orientations_deg=(0.0,),
        directions_deg=(90.0,),
        lateral_mm=(9.9, 4.0, 0.0, -4.0),
        tap_depths_mm=(2.0, 4.0),
        contour_max_steps=3,
        gp_restarts=0,
    )
    pins = ("contact", "friction")
    settings = [
        Setting(REFERENCE, "reference", "fast", effects=pins),
        Setting(COMPLIANT_REFERENCE, "compliant dome", "default", effects=pins, dome="compliant"),
        Setting("compliant_fast", "compliant dome", "fast", effects=pins, dome="compliant"),
        Setting(
            "compliant_plain_solid",
            "compliant skin",
            "fast",
            physics=PLAIN_SOLID,
            effects=pins,
            dome="compliant",
            pins_comparable=False,
        ),
    ]
    rows = sweep_and_report(tmp_path, settings=settings, probe=tiny, workers=1, verbose=False)
    flex_ref, ref, fast, plain = rows
    assert all(r["status"] == "ok" for r in rows), [(r["setting"], r["error"]) for r in rows]
    assert ref["dome"] == fast["dome"] == "compliant" and flex_ref["dome"] == "flex"
    assert ref["pin_rms_px"] == 0.0 and flex_ref["pin_rms_px"] == 0.0
    assert 0.0 < fast["pin_rms_px"] < 5.0  # 2.5 mm against 1.8 mm nodes: close, not equal
    assert ref["on_front"] is True and flex_ref["on_front"] is True  # one front per model
    # the plain solid is another material, not an approximation of the reference: no pin error, no pin front
    assert plain.get("pin_rms_px") is None and plain["on_front"] is None
    assert np.isfinite(plain["theta_rms_deg"])
    assert ref["cellcount"] == "1.8 mm nodes" and ref["timestep_s"] is None
    for r in rows:  # placed on the contour front where, and only where, the contour was completed
        completed = r["contour_stop"] in ("loop closed", "end of contour")
        assert isinstance(r["on_front_contour"], bool) == completed, (r["setting"], r["contour_stop"])
    md = (tmp_path / "sweep.md").read_text()
    assert "compliant_reference" in md and "contour front" in md
    with pytest.raises(UserError, match="compliant_reference"):
        sweep_and_report(
            tmp_path / "no_ref", settings=settings[:1] + settings[2:], probe=tiny, workers=1, verbose=False
        )


def test_pin_fronts_stay_within_a_dome_model_and_the_contour_front_spans_both() -> None:
    flex = {**_row("flex_slow", 100.0, 1.0, output="pins"), "dome": "flex", "contour_completed_mm": 3.0}
    comp = {**_row("compliant_fast", 10.0, 0.5, output="pins"), "dome": "compliant", "contour_completed_mm": 1.0}
    assert not peers(comp, flex) and peers(comp, flex, "contour_completed_mm")
    assert pareto_flags([flex, comp]) == [True, True]  # faster and "more accurate", but against another reference
    assert pareto_flags([flex, comp], "contour_completed_mm") == [False, True]
    # a faster run that lost the contour is not placed and pushes no completed run off
    lost = {**_row("lost_fast", 5.0, 0.5, output="pins"), "dome": "compliant", "contour_completed_mm": math.inf}
    assert pareto_flags([flex, comp, lost], "contour_completed_mm") == [False, True, None]
    # annotate_fronts derives that figure from the contour error and how the run stopped
    closed = {**_row("closed", 20.0, 0.5, output="pins"), "contour_path_mean_mm": 2.0, "contour_stop": "loop closed"}
    gone = {**_row("gone", 5.0, 0.5, output="pins"), "contour_path_mean_mm": 1.0, "contour_stop": "lost the contour"}
    annotate_fronts([closed, gone])
    assert closed["contour_completed_mm"] == 2.0 and gone["contour_completed_mm"] == math.inf
    assert closed["on_front_contour"] is True and gone["on_front_contour"] is None
    assert pareto_flags([flex, comp], by_output=False) == [True, True]


@pytest.mark.parametrize("shape", [(128, 128), (320, 240), (120, 160), (640, 480)])
def test_pins_of_another_camera_are_compared_at_640x480(shape: tuple[int, int]) -> None:
    """The pin errors of settings at another resolution are taken at 640×480: the same pins
    seen by a `shape` camera (same field of view across the short side) land where the
    640×480 camera sees them, square and portrait frames included."""
    from twin.analysis.sweep.probe import rescale_pins
    from twin.core.sensor import CameraModel

    pins = CameraModel().geometry.pin_tip_points()
    seen = CameraModel(width=shape[0], height=shape[1]).project_tool_points(pins)
    np.testing.assert_allclose(rescale_pins(seen, *shape), CameraModel().project_tool_points(pins), atol=1e-9)
