"""Table I (twin.tools.evaluate): RMS orientation error per sliding direction, on and off
the object, with angles compared on the circle; figures worked out by hand."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from twin.runs.record import Run
from twin.tools.evaluate import DIRECTIONS, PAPER_TABLE_I, format_table, table_i


def _run(rows: list[tuple[float, float, bool]]) -> Run:
    samples = [{"labels": {"direction_deg": d, "theta_deg": t, "on_object": on}, "pins_px": None} for d, t, on in rows]
    return Run(Path("synthetic"), {}, samples)


def test_rms_per_direction_on_and_off_with_wrap() -> None:
    # direction 0 on: errors 3 and 4 -> RMS sqrt(12.5); off: 179 vs -179 is 2 deg, not 358
    # direction 90 on: error 10; every other cell is empty
    run = _run([(0, 10, True), (0, 20, True), (0, 179, False), (90, -40, True)])
    theta_hat = np.array([13.0, 16.0, -179.0, -30.0])
    table = table_i(run, {"PCA + GP": theta_hat})
    cells = table["PCA + GP"]
    assert cells[0]["on"] == pytest.approx(math.sqrt(12.5))
    assert cells[0]["off"] == pytest.approx(2.0)
    assert cells[90] == {"on": pytest.approx(10.0), "off": None}
    assert all(cells[d] == {"on": None, "off": None} for d in DIRECTIONS if d not in (0, 90))


def test_text_table_puts_the_papers_row_under_the_twins() -> None:
    run = _run([(0, 0, True)])
    text = format_table(table_i(run, {"PCA + GP": np.array([5.0])}))
    lines = text.splitlines()
    assert lines[1].startswith("twin PCA + GP") and "5.00/—" in lines[1]
    assert lines[2].startswith("paper PCA + GP") and f"{PAPER_TABLE_I['PCA + GP'][90][0]:.2f}/—" in lines[2]
