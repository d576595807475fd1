"""Observations to pins: the one way to get (127, 2) px pins from any observation.

A rendered or filmed observation carries a frame, and the tracker (twin.sensing.tracker)
finds the pins in it against the no-contact reference frame; an observation of a scene
without rendering carries the pins projected through the camera model. `PinReader` takes
both, so everything downstream (perception, control, recording) is the same code.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.core.environment import Observation
from twin.core.errors import LostPinsError, MistrackedPinsError
from twin.sensing.tracker import PinTracker


class PinReading(NamedTuple):
    """Pins of one observation: positions (127, 2) px in the pin order of
    twin.core.sensor; found (127,) bool, None when projected (all found); tracking time ms."""

    pins_px: np.ndarray
    found: np.ndarray | None
    ms: float


class PinReader:
    """Turns observations into pins: tracked from frames, or taken as projected.

    reference: the no-contact observation (`Environment.reset()`); its frame, if any, is
    the tracker's reference. A frame with more than `max_lost_fraction` of its pins
    untracked stops the run with LostPinsError (a torn skin, a covered lens or a camera
    that moved). A simulated observation carries its true pins: a pin the tracker reports
    found more than `max_mistrack_fraction` of a pin spacing from its true position took
    another pin's blob, and the run stops with MistrackedPinsError instead of recording it."""

    max_lost_fraction = 0.2
    max_mistrack_fraction = 0.5

    def __init__(self, reference: Observation) -> None:
        self.tracker = PinTracker(reference.frame) if reference.frame is not None else None
        #: (127, 2) px: the pins at rest (found in the reference frame, or projected), None
        #: when the reference carries neither
        self.rest_px = self.tracker.reference_pins_px if self.tracker is not None else reference.pins_px

    def read(self, obs: Observation) -> PinReading:
        if obs.frame is None or self.tracker is None:
            if obs.pins_px is None:
                raise LostPinsError(f"observation at pose {obs.pose} has neither a frame nor pins")
            return PinReading(obs.pins_px, None, 0.0)
        result = self.tracker.track(obs.frame)
        lost = int((~result.found).sum())
        if lost > self.max_lost_fraction * len(result.found):
            reasons = sorted({r for r in result.reasons if r})
            raise LostPinsError(
                f"lost {lost}/{len(result.found)} pins at pose {obs.pose} ({', '.join(reasons)}); "
                "check the camera and the skin"
            )
        true_px = obs.truth.get("pins_px")
        if true_px is not None:
            off_px = np.linalg.norm(result.pins_px - np.asarray(true_px, float), axis=1)
            wrong = np.flatnonzero(result.found & (off_px > self.max_mistrack_fraction * self.tracker.spacing_px))
            if len(wrong):
                raise MistrackedPinsError(
                    f"the tracker put {len(wrong)} pin(s) on another pin's blob at pose {obs.pose}: pin "
                    f"{wrong[0]} found {off_px[wrong[0]]:.1f} px from its true position (a pin spacing is "
                    f"{self.tracker.spacing_px:.1f} px); the pins moved further between frames than it can follow"
                )
        return PinReading(result.pins_px, result.found, result.ms)
