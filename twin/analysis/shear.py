"""The data of the paper's Figure 2: what sliding does to the pins, reproduced in the twin
(the figure itself: twin.tools.shear_report).

Aquilina et al. 2019, Fig. 2: "(a) The black trace shows the pin motion of the sensor
when tapping across a straight edge at different lateral positions without sliding. The
coloured traces depict the sensor moving the same amount across the edge as the black
trace whilst sliding in different directions (from 0° to 315°). (b) Zoomed in version of
(a) over the central pin."

Here, on the rectangle's +x edge with the paper's geometry (twin.runs.protocols; sensor
orientation θ = 0, depth 3 mm, the slide protocol's depth):
  * taps: the 8 lateral positions l = 9.9, 6, 4, …, −6 mm, one static press each
    (twin.runs.protocols.tap_moves), giving one black trace per pin (8 points, px);
  * slides: for each direction δ = 0°, 45°, …, 315° (0° = onto the object, 90° = along
    the edge, 180° = off it), the slide protocol's straight slide through 8 samples the
    same distances apart (twin.runs.protocols.slide_moves), one coloured trace per pin.
Every slide starts from a reset (no contact), like the runner's chunks.

The numbers returned quantify the figure: for each slide sample, the *shear shift* is the
pin displacement (px) from the static tap at the same lateral position (tap traces
interpolated linearly in l); per direction we report its mean over pins and samples
(u, v components and the mean magnitude).
"""

from __future__ import annotations

import numpy as np

from twin.core.scenario import DEFAULT_DOME, SlideProtocol, TapProtocol, hover_over, scenario_from_dict
from twin.runs.protocols import slide_moves, tap_moves
from twin.runs.sim_env import SimEnvironment

DIRECTIONS_DEG = tuple(float(a) for a in range(0, 360, 45))
DEPTH_MM = 3.0
CENTRAL_PIN = 0  # pin order of twin.core.sensor: the central pin first


def _environment(fidelity: str, friction: bool, dome: str = DEFAULT_DOME):

    effects = ["contact", "friction"] if friction else ["contact"]
    scenario = scenario_from_dict(
        {
            "name": f"shear_figure_{dome}_{fidelity}_{'friction' if friction else 'frictionless'}",
            "object": {"name": "rectangle"},
            "fidelity": fidelity,
            "effects": effects,
            "dome": dome,
        }
    )
    return SimEnvironment(scenario, start_pose=hover_over(60.0, 0.0, 0.0))


def collect_shear_data(fidelity: str = "default", friction: bool = True, dome: str = DEFAULT_DOME) -> dict:
    """Run the taps and the 8 slides on the `dome` model ('flex' or 'compliant'); returns
    the raw traces.

    Returns a dict with
      tap_lateral_mm (8,), tap_pins_px (8, 127, 2): the taps across the edge;
      slides: {direction_deg: {"lateral_mm": (8,), "pins_px": (8, 127, 2)}};
      rest_pins_px (127, 2): the no-contact frame.
    """
    env = _environment(fidelity, friction, dome)
    try:
        rest = env.reset().pins_px
        tap_lateral, tap_pins = [], []
        for move in tap_moves(TapProtocol(orientations_deg=[0.0], depths_mm=[DEPTH_MM])):
            env.move_to(move.pose, move.speed_mm_s)
            if move.record:
                tap_lateral.append(move.labels["lateral_mm"])
                tap_pins.append(env.observe().pins_px.copy())
        slides = {}
        for direction in DIRECTIONS_DEG:
            env.reset()
            lateral, pins = [], []
            for move in slide_moves(
                SlideProtocol(orientations_deg=[0.0], directions_deg=[direction], depth_mm=DEPTH_MM)
            ):
                env.move_to(move.pose, move.speed_mm_s)
                if move.record:
                    lateral.append(move.labels["lateral_mm"])
                    pins.append(env.observe().pins_px.copy())
            slides[direction] = {"lateral_mm": np.array(lateral), "pins_px": np.array(pins)}
    finally:
        env.close()
    return {
        "tap_lateral_mm": np.array(tap_lateral),
        "tap_pins_px": np.array(tap_pins),
        "slides": slides,
        "rest_pins_px": np.asarray(rest),
    }


def tap_pins_at(data: dict, lateral_mm: np.ndarray) -> np.ndarray:
    """(N, 127, 2) px: the tap frames interpolated linearly at lateral positions (mm)."""
    lat = data["tap_lateral_mm"]
    order = np.argsort(lat)
    lat, pins = lat[order], data["tap_pins_px"][order]
    flat = pins.reshape(len(lat), -1)
    out = np.stack([np.interp(lateral_mm, lat, flat[:, j]) for j in range(flat.shape[1])], axis=-1)
    return out.reshape(len(np.atleast_1d(lateral_mm)), *pins.shape[1:])


def shear_numbers(data: dict) -> dict:
    """Per direction: mean shear shift (px) of the slide frames from the taps at the same l.

    Returns {"directions": {δ: {"mean_shift_px": [du, dv], "mean_abs_shift_px": m,
    "max_shift_px": M, "central_pin_shift_px": [du, dv]}}} — means over pins and the
    8 samples; "central_pin" is the mean over samples for pin 0.
    """
    out = {}
    for direction, slide in data["slides"].items():
        shift = slide["pins_px"] - tap_pins_at(data, slide["lateral_mm"])  # (8, 127, 2)
        out[float(direction)] = {
            "mean_shift_px": shift.mean(axis=(0, 1)).tolist(),
            "mean_abs_shift_px": float(np.linalg.norm(shift, axis=2).mean()),
            "max_shift_px": float(np.linalg.norm(shift, axis=2).max()),
            "central_pin_shift_px": shift[:, CENTRAL_PIN].mean(axis=0).tolist(),
        }
    return {"directions": out}
