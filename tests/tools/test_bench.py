"""`twin bench` physics and throughput rows are consistent (no timing asserts: speed is printed, not tested)."""
from __future__ import annotations

import math

import pytest

from twin.tools.bench import bench_throughput, benchmark_physics


@pytest.mark.slow
def test_throughput_rows_are_consistent() -> None:
    rows = bench_throughput(quick=True)
    assert [r["output"] for r in rows] == ["pins only", "rendered + tracked"]
    for r in rows:
        assert r["frames"] == 2 * 8 * 8  # 2 orientations × 8 directions × 8 samples
        assert r["fps_1_process"] > 0 and r["fps_all_cores"] > 0
        assert r["fps_all_cores_steady"] >= r["fps_all_cores"]  # start-up removed, never added
        assert r["ms_per_frame_1_process"] == pytest.approx(1e3 / r["fps_1_process"])


def test_physics_rows_are_consistent() -> None:
    rows = benchmark_physics(["fast"], repeats=1, verbose=False)
    assert [(r["dome"], r["level"]) for r in rows] == [("flex", "fast"), ("compliant", "fast")]
    for row in rows:
        assert set(row) == {"dome", "level", "ms_per_frame", "steps_per_frame", "ms_per_step", "precompute_s",
                            "cached_s", "ratio_to_flex_default"}
        assert row["ms_per_frame"] > 0 and row["steps_per_frame"] >= 1
        assert row["ms_per_step"] * row["steps_per_frame"] == pytest.approx(row["ms_per_frame"])
        assert math.isnan(row["ratio_to_flex_default"])  # the flex default was not measured in this run
    assert rows[0]["precompute_s"] == rows[0]["cached_s"] == 0.0
    assert rows[1]["precompute_s"] > 0.0 and rows[1]["cached_s"] > 0.0
