"""`twin bench throughput` runs the slide protocol end to end in one process and over all
cores and reports consistent figures (no timing asserts: speed is printed, not tested)."""
from __future__ import annotations

import pytest

from twin.tools.bench import bench_throughput


@pytest.mark.slow
def test_throughput_rows_are_consistent() -> None:
    rows = bench_throughput(quick=True)
    assert [r["output"] for r in rows] == ["pins only", "rendered + tracked"]
    for r in rows:
        assert r["frames"] == 2 * 8 * 8  # 2 orientations × 8 directions × 8 samples
        assert r["fps_1_process"] > 0 and r["fps_all_cores"] > 0
        assert r["fps_all_cores_steady"] >= r["fps_all_cores"]  # start-up removed, never added
        assert r["ms_per_frame_1_process"] == pytest.approx(1e3 / r["fps_1_process"])
