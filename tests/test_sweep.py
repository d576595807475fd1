"""`twin bench sweep`: what accuracy costs in time. The quick sweep is the smoke check
(run as the CLI in its own process, as a user would); no timing asserts, only that the
outputs exist and make sense. The Pareto rules and the failure reporting are checked on
small inputs."""
from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from twin.sweep import (CSV_COLUMNS, DEFAULT, REFERENCE, Probe, Setting, dominates, markdown_table, pareto_flags,
                        quick_settings, run_sweep)

ROOT = Path(__file__).resolve().parents[1]


def _read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _f(v: str) -> float:
    return float(v) if v not in ("", None) else float("nan")


@pytest.mark.slow
def test_quick_sweep_writes_a_consistent_table(tmp_path) -> None:
    out = tmp_path / "bench"
    proc = subprocess.run([sys.executable, "-m", "twin.cli", "bench", "sweep", "--quick", "--out", str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=900)
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
        assert np.isfinite(_f(r["pin_rms_px"])) and np.isfinite(_f(r["theta_rms_deg"]))
        assert np.isfinite(_f(r["lateral_rms_mm"])) and np.isfinite(_f(r["contour_path_mean_mm"]))
        if r["output"] == "frames":
            assert _f(r["render_ms"]) > 0 and _f(r["track_ms"]) > 0
            assert 0 < _f(r["pin_tracking_rms_px"]) < 1.0, r  # the tracker finds the rendered pins to < 1 px
        else:
            assert _f(r["pin_tracking_rms_px"]) == 0.0  # projected pins are the true pins
    # render changes how pins are read, never the physics: identical true pins
    assert by["render_off"]["pin_physics_rms_px"] == by[DEFAULT]["pin_physics_rms_px"]
    assert _f(by[DEFAULT]["pin_physics_rms_px"]) > 0  # the default grid is coarser than the reference's
    # every ok row is flagged on or off the front, the default included
    assert all(r["on_front"] in ("True", "False") for r in rows)
    md = (out / "sweep.md").read_text()
    verdict = "lies on the Pareto front" if by[DEFAULT]["on_front"] == "True" else "NOT on the Pareto front"
    assert verdict in md and "Failures: 0." in md
    assert sum(line.startswith("| ") for line in md.splitlines()) == len(rows) + 1  # header + one per setting
    meta = json.loads((out / "sweep.json").read_text())["meta"]
    assert meta["quick"] is True and meta["failures"] == []


def test_failed_setting_is_recorded_counted_and_kept_off_the_front(tmp_path) -> None:
    tiny = Probe(tap_orientations_deg=(0.0, 180.0), slide_orientations_deg=(0.0,), directions_deg=(0.0,),
                 lateral_mm=(9.9, 4.0, 0.0, -4.0), tap_depths_mm=(2.0, 4.0), contour_max_steps=3, gp_restarts=0)
    settings = [Setting(REFERENCE, "reference", "fast", effects=("contact", "friction")),
                Setting("bad_timestep", "time step", physics={"timestep_s": 1.0})]
    rows = run_sweep(tmp_path, settings=settings, probe=tiny, workers=1, verbose=False)
    ok, bad = rows
    assert ok["status"] == "ok" and ok["pin_rms_px"] == 0.0 and ok["on_front"] is True
    assert bad["status"] == "failed" and bad["stage"] == "build" and "timestep_s" in bad["error"]
    assert bad["on_front"] is None
    md = (tmp_path / "sweep.md").read_text()
    assert "Failures: 1" in md and "bad_timestep" in md and "failed in build" in md
    csv_rows = _read_csv(tmp_path / "sweep.csv")
    assert csv_rows[1]["status"] == "failed" and "timestep_s" in csv_rows[1]["error"]


def _row(name: str, ms: float, err: float, output: str = "frames", status: str = "ok") -> dict:
    return {"setting": name, "output": output, "status": status, "total_ms": ms, "pin_rms_px": err}


def test_pareto_front_with_noise_margins() -> None:
    rows = [_row("slow_exact", 100.0, 0.0), _row("mid", 40.0, 3.0), _row("fast_rough", 20.0, 6.0),
            _row("dominated", 60.0, 4.0), _row("noise_twin", 41.0, 3.01), _row("pins", 10.0, 3.0, output="pins"),
            _row("broken", 1.0, 0.0, status="failed")]
    flags = dict(zip([r["setting"] for r in rows], pareto_flags(rows, "pin_rms_px")))
    assert flags == {"slow_exact": True, "mid": True, "fast_rough": True, "dominated": False,
                     "noise_twin": True, "pins": True, "broken": None}
    # across output kinds the projected-pin setting dominates the rendered one of equal error
    assert dominates(rows[5], rows[1], "pin_rms_px")
    assert pareto_flags(rows, "pin_rms_px", by_output=False)[1] is False
    # a difference within the noise margins is no domination either way
    assert not dominates(rows[4], rows[1], "pin_rms_px") and not dominates(rows[1], rows[4], "pin_rms_px")


def test_markdown_reports_a_default_off_the_front() -> None:
    rows = [dict(_row(REFERENCE, 100.0, 0.0, output="pins"), knob="reference", on_front=True),
            dict(_row(DEFAULT, 50.0, 4.0), knob="default", on_front=False),
            dict(_row("better", 30.0, 3.0), knob="x", on_front=True)]
    meta = {"probe": {"tap_orientations_deg": [0], "lateral_mm": [0], "tap_depths_mm": [2], "slide_orientations_deg": [0],
                      "directions_deg": [0], "contour_max_steps": 1}, "failures": [], "date": "today", "machine": "m",
            "gl": "egl", "workers": 1, "quick": True, "wall_s": 1.0}
    md = markdown_table(rows, meta)
    assert "**The default is NOT on the Pareto front**" in md and "Failures: 0." in md
