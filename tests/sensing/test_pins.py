"""PinReader: observations to pins, with the stops a frame can force."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from twin.core.environment import Observation
from twin.core.errors import MistrackedPinsError
from twin.core.poses import Pose
from twin.sensing.pins import PinReader
from twin.sensing.tracker import render_pins_frame, template_pins_px

REST = template_pins_px()


def _observation(frame: np.ndarray, true_px: np.ndarray | None) -> Observation:
    truth = {} if true_px is None else {"pins_px": true_px}
    return Observation(time=0.0, pose=Pose(0, 0, 3), frame=frame, truth=truth)


def test_a_pin_tracked_onto_another_pins_blob_stops_a_simulated_run() -> None:
    """The frame shows the rest pattern, but in truth two neighbouring pins swapped places
    (each moved one spacing onto the other's spot): the tracker, seeing the rest frame,
    keeps each on its old blob, a spacing from the truth. With the truth the reader stops;
    without it (a real sensor) it cannot tell; with the truth as drawn it reads every pin."""
    frame = render_pins_frame(REST)
    reader = PinReader(_observation(frame, REST))
    i = 60
    j = int(cKDTree(REST).query(REST[i], k=2)[1][1])
    swapped = REST.copy()
    swapped[[i, j]] = REST[[j, i]]
    with pytest.raises(MistrackedPinsError, match=r"put 2 pin\(s\) on another pin's blob"):
        reader.read(_observation(frame, swapped))
    assert reader.read(_observation(frame, None)).found.all()
    reading = reader.read(_observation(frame, REST))
    assert reading.found.all() and np.abs(reading.pins_px - REST).max() < 0.5
