"""The paper's Fig. 2 in the twin (twin.analysis.shear): sliding shears the skin, tapping does not.

Taps across the rectangle's edge at the 8 lateral positions vs slides through the same
distances in the 8 directions (twin.runs.protocols geometry; 0° = onto the object, 90° =
along the edge). "Shift" = slide frame minus the tap at the same lateral position (px),
averaged over pins and samples (twin.analysis.shear.shear_numbers).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from twin.analysis.shear import DIRECTIONS_DEG, collect_shear_data, shear_numbers
from twin.tools.shear_report import plot_shear_figure, write_shear_figure


@pytest.fixture(scope="module")
def with_friction() -> dict:
    return collect_shear_data("default", friction=True)


@pytest.fixture(scope="module")
def frictionless() -> dict:
    return collect_shear_data("default", friction=False)


def test_sliding_traces_differ_from_taps(with_friction):
    numbers = shear_numbers(with_friction)["directions"]
    assert set(numbers) == set(DIRECTIONS_DEG)
    for direction, n in numbers.items():
        # the skin membrane carries most of the drag (DomeParams.membrane_young), so the whole
        # field shifts by a few px (1.7 px sliding off the object, 180°) and the central pin,
        # the paper's Fig. 2b, by 4–11 px; frictionless: ≤ 0.4 and ≤ 0.8 px
        assert n["mean_abs_shift_px"] > 1.2, (direction, n)
        assert np.linalg.norm(n["central_pin_shift_px"]) > 3.0, (direction, n)


def test_sliding_traces_differ_by_direction(with_friction):
    numbers = shear_numbers(with_friction)["directions"]
    shifts = {d: np.array(n["central_pin_shift_px"]) for d, n in numbers.items()}  # Fig. 2b's pin
    for a, b in itertools.combinations(DIRECTIONS_DEG, 2):
        assert np.linalg.norm(shifts[a] - shifts[b]) > 2.0, (a, b, shifts[a], shifts[b])


def test_opposite_directions_shift_pins_in_opposite_ways(with_friction):
    numbers = shear_numbers(with_friction)["directions"]
    s90, s270 = (np.array(numbers[d]["mean_shift_px"]) for d in (90.0, 270.0))
    assert np.dot(s90, s270) < 0
    assert min(np.linalg.norm(s90), np.linalg.norm(s270)) > 3.0
    # along the edge the skin is dragged along the slide: the part that reverses with the
    # direction is along it (the part common to both, ≈ 1.5 px across the edge, is the
    # press's lateral stress that static friction held and sliding releases)
    reversing = (s90 - s270) / 2
    assert abs(reversing[1]) > 10 * abs(reversing[0])
    c90, c270 = (np.array(numbers[d]["central_pin_shift_px"]) for d in (90.0, 270.0))
    assert np.dot(c90, c270) < 0


def test_without_friction_sliding_and_tapping_coincide(frictionless, with_friction):
    free = shear_numbers(frictionless)["directions"]
    stuck = shear_numbers(with_friction)["directions"]
    for direction in DIRECTIONS_DEG:
        # within 1 px on average (the default grid holds a few frames in a slightly
        # different frictionless equilibrium at the edge: ≤ 2.5 px mean in one frame)
        assert free[direction]["mean_abs_shift_px"] < 1.0, (direction, free[direction])
        assert np.linalg.norm(free[direction]["central_pin_shift_px"]) < 1.0
        assert free[direction]["mean_abs_shift_px"] < 0.2 * stuck[direction]["mean_abs_shift_px"]


def test_figure_is_written_with_all_pins(with_friction, tmp_path):
    png = plot_shear_figure(with_friction, tmp_path / "fig2.png", "test")
    assert png.is_file() and png.stat().st_size > 20_000
    assert with_friction["tap_pins_px"].shape == (8, 127, 2)
    assert all(s["pins_px"].shape == (8, 127, 2) for s in with_friction["slides"].values())


def test_write_shear_figure_returns_the_numbers(tmp_path):
    numbers = write_shear_figure(tmp_path / "fig2_fast.png", fidelity="fast", friction=True)
    assert (tmp_path / "fig2_fast.png").is_file()
    assert numbers["fidelity"] == "fast" and numbers["friction"] is True
    assert set(numbers["directions"]) == set(DIRECTIONS_DEG)
    for n in numbers["directions"].values():
        assert set(n) == {"mean_shift_px", "mean_abs_shift_px", "max_shift_px", "central_pin_shift_px"}
        assert np.all(np.isfinite(n["mean_shift_px"]))


@pytest.mark.parametrize("friction", [False, True])
def test_compliant_dome_figure(tmp_path, friction):
    """`twin figure shear --dome compliant`: without friction each slide sample is the tap
    at the same lateral position (quasi-static, path-independent: < 0.3 px, the taps being
    interpolated between 2 mm apart positions); with friction sliding shifts the pins."""
    numbers = write_shear_figure(tmp_path / "fig2_compliant.png", fidelity="fast", friction=friction, dome="compliant")
    assert numbers["dome"] == "compliant" and (tmp_path / "fig2_compliant.png").is_file()
    along = numbers["directions"][90.0]  # along the edge, 6 mm onto the object: the tap there is exact
    if friction:
        assert along["mean_abs_shift_px"] > 1.0
    else:
        assert along["mean_abs_shift_px"] < 0.3
