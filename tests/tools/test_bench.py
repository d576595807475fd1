"""`twin bench` physics and throughput rows are consistent (no timing asserts: speed is printed, not tested)."""
from __future__ import annotations

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
    (row,) = benchmark_physics(["fast"], repeats=1, verbose=False)
    assert set(row) == {"level", "ms_per_frame", "steps_per_frame", "ms_per_step"}
    assert row["level"] == "fast" and row["ms_per_frame"] > 0 and row["steps_per_frame"] >= 1
