"""`twin bench` physics and throughput rows are consistent (no timing asserts: speed is printed, not tested)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from twin.core.errors import UserError
from twin.tools.bench import bench_observation, bench_pixels, bench_startup, bench_throughput, benchmark_physics


@pytest.mark.slow
def test_throughput_rows_are_consistent() -> None:
    rows = bench_throughput(quick=True)
    assert [r["output"] for r in rows] == ["pins only", "rendered + tracked"]
    for r in rows:
        assert r["frames"] == 2 * 8 * 8  # 2 orientations × 8 directions × 8 samples
        assert r["fps_1_process"] > 0 and r["fps_all_cores"] > 0
        assert r["fps_all_cores_steady"] >= r["fps_all_cores"]  # start-up removed, never added
        assert r["pool_start_s"] > 0 and r["env_build_s"] > 0
        assert r["ms_per_frame_1_process"] == pytest.approx(1e3 / r["fps_1_process"])


def test_physics_rows_are_consistent() -> None:
    rows = benchmark_physics(["fast"], repeats=1, verbose=False)
    assert [(r["dome"], r["level"]) for r in rows] == [("flex", "fast"), ("compliant", "fast")]
    for row in rows:
        assert set(row) == {
            "dome",
            "level",
            "ms_per_frame",
            "steps_per_frame",
            "ms_per_step",
            "precompute_s",
            "cached_s",
            "ratio_to_flex_default",
            "ratio_min",
            "ratio_max",
        }
        assert row["ms_per_frame"] > 0 and row["steps_per_frame"] >= 1
        assert row["ms_per_step"] * row["steps_per_frame"] == pytest.approx(row["ms_per_frame"])
        assert math.isnan(row["ratio_to_flex_default"])  # the flex default was not measured in this run
        assert math.isnan(row["ratio_min"]) and math.isnan(row["ratio_max"])
    assert rows[0]["precompute_s"] == rows[0]["cached_s"] == 0.0
    assert rows[1]["precompute_s"] > 0.0 and rows[1]["cached_s"] > 0.0


def test_physics_ratios_are_taken_round_by_round() -> None:
    """Every row is timed once per round beside the flex default, so each round gives a
    ratio: the flex default's own is 1 in every round, every other row's a positive range,
    and the headline ratio is best time against best time."""
    rows = {(r["dome"], r["level"]): r for r in benchmark_physics(["fast", "default"], repeats=3, verbose=False)}
    assert set(rows) == {(dome, level) for dome in ("flex", "compliant") for level in ("fast", "default")}
    flex = rows[("flex", "default")]
    assert flex["ratio_min"] == flex["ratio_max"] == flex["ratio_to_flex_default"] == 1.0
    for row in rows.values():
        assert 0 < row["ratio_min"] <= row["ratio_max"]
        assert row["ratio_to_flex_default"] == pytest.approx(row["ms_per_frame"] / flex["ms_per_frame"])


def _scenario(folder: Path, name: str, body: str) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(
        f"name: {name}\nobject: {{name: rectangle, friction: 1.0}}\neffects: [contact, friction]\n"
        f"protocol: {{kind: taps, orientations_deg: [0], lateral_mm: [0], depths_mm: [2]}}\n{body}"
    )
    return path


def test_a_scenarios_dome_is_timed_at_its_own_level(tmp_path) -> None:
    """`twin bench physics --scenario`: a scenario's dome runs the same edge and steps as the
    levels do, so a scenario that asks for the compliant fast level with the bench's
    friction does the fast row's work to the increment, and one at the default level does not."""
    fast = _scenario(tmp_path, "as_fast", "dome: compliant\nfidelity: fast\n")
    default = _scenario(tmp_path, "as_default", "dome: compliant\nfidelity: default\n")
    rows = benchmark_physics(["fast"], repeats=1, verbose=False, scenarios=[fast, default])
    assert [(r["dome"], r["level"]) for r in rows] == [
        ("flex", "fast"),
        ("compliant", "fast"),
        ("compliant", "scenario:as_fast"),
        ("compliant", "scenario:as_default"),
    ]
    assert rows[2]["steps_per_frame"] == rows[1]["steps_per_frame"]
    assert rows[3]["steps_per_frame"] != rows[1]["steps_per_frame"]


def test_a_scenario_the_bench_cannot_build_is_refused_naming_its_field(tmp_path) -> None:
    bad = _scenario(tmp_path, "bad", "dome: compliant\nphysics: {membrane_young_mpa: -1}\n")
    with pytest.raises(UserError, match=r"bad\.yaml.*membrane_young_mpa"):
        benchmark_physics(["fast"], repeats=1, verbose=False, scenarios=[bad])


@pytest.mark.slow
def test_startup_rows_name_every_stage() -> None:
    rows = bench_startup(quick=True)
    assert [r["stage"] for r in rows] == [
        "imports",
        "scene build",
        "environment",
        "first frame, one process",
        "pool start",
        "twin run taps_rectangle --workers 2: first frame",
    ]
    assert all(r["seconds"] > 0 and r["rounds"] == 1 for r in rows)


def test_pixels_rows_cover_96x96_to_1280x960() -> None:
    rows = bench_pixels(quick=True)
    assert [r["resolution"] for r in rows][0] == "96x96" and rows[-1]["resolution"] == "1280x960"
    assert "120x160" in [r["resolution"] for r in rows]  # a portrait camera renders and tracks too
    default = next(r for r in rows if r["resolution"] == "640x480")
    assert default["render_to_640x480"] == 1.0 and default["pixels_to_640x480"] == 1.0
    assert default["silhouette_to_640x480"] == 1.0
    for r in rows:
        assert r["render_ms"] > 0 and r["track_ms"] > 0 and r["silhouette_ms"] > 0
        assert r["pixels"] == r["pixels_to_640x480"] * 640 * 480


@pytest.mark.slow
def test_observation_rows_compare_the_fast_small_frame_with_the_default() -> None:
    rows = bench_observation(quick=True)
    assert [(r["level"], r["resolution"], r["renderer"]) for r in rows] == [
        ("fast", "128x128", "silhouette"),
        ("fast", "128x128", "gl"),
        ("default", "640x480", "silhouette"),
        ("default", "640x480", "gl"),
    ]
    assert len({r["frames"] for r in rows}) == 1 and rows[0]["frames"] > 0  # the same moves in each
    assert rows[-1]["fps_to_default"] == 1.0
    assert all(r["fps"] > 0 and r["fps_to_default"] > 0 for r in rows)


@pytest.mark.parametrize(
    "argv, named",
    [
        (["bench", "sweep", "--settings", "reference,fast,nope"], "'nope'"),
        (["bench", "sweep", "--settings", "fast,default"], "'reference'"),  # the pin errors' reference
        (["bench", "pixels", "--settings", "fast"], "twin bench sweep"),
    ],
)
def test_sweep_settings_are_checked_before_anything_runs(argv, named, tmp_path, capsys) -> None:
    from twin.tools.cli import main

    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert named in err and "Traceback" not in err, err
    assert not (tmp_path / "out" / "sweep.csv").exists()
