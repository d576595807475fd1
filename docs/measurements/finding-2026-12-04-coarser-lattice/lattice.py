"""lattice.py SCENARIO SPACINGS: the pins of a scenario's compliant dome on the edge scene
(twin.world.dome.testbed) at several surface spacings (mm, comma-separated), each frame
against the finest spacing's, in px of the paper's camera; and what each spacing's
sequence costs in the same run (wall time, ratio to the scenario's own spacing).

The sequence: `twin bench physics`'s (a press at the edge, eight contour steps along it),
then a tap at each l = +4 … −6 mm (3 mm deep), a 1 mm slide along the edge and a 5° twist,
as the DigiTac set's taps are made; lifted clear between taps."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from twin.core.scenario import ContourProtocol, load_scenario
from twin.core.sensor import CameraModel
from twin.runs.spec import dome_params, load_scenario_stimulus
from twin.world.dome.registry import builder_of
from twin.world.dome.testbed import edge_scene, sensor_down

LATERAL_MM = (4, 2, 0, -2, -4, -6)


def frames(params, friction: float) -> tuple[np.ndarray, list[str], float]:
    """(frames, 127, 2) px: how far the pins' images moved from rest at each recorded frame,
    each frame's label, and the seconds the sequence's physics took."""
    contour = ContourProtocol()
    depth, step = contour.depth_mm, contour.step_mm
    camera = CameraModel()
    _, _, _, physics = edge_scene(params, True, friction, scenario="lattice")
    rest = camera.project_tool_points(physics.rest_pins)
    pins, labels, seconds = [], [], 0.0

    def go(pose: np.ndarray, label: str | None = None) -> None:
        nonlocal seconds
        t0 = time.perf_counter()
        physics.move(pose, contour.speed_mm_s)
        frame = physics.settle()
        seconds += time.perf_counter() - t0
        if label is not None:
            pins.append(camera.project_tool_points(frame.pins_tool) - rest)
            labels.append(label)

    for k in range(9):
        go(sensor_down(0, step * k, depth), f"bench {k}")
    for x in LATERAL_MM:
        go(sensor_down(x, 0, -2))  # lifted clear: not kept
        go(sensor_down(x, 0, 3), f"l={x:+d} press")
        go(sensor_down(x, 1, 3), f"l={x:+d} slide")
        go(sensor_down(x, 1, 3, 5), f"l={x:+d} twist")
    return np.array(pins), labels, seconds


def main() -> None:
    scenario = load_scenario(Path(sys.argv[1]))
    base = dome_params(scenario)
    friction = load_scenario_stimulus(scenario).friction
    spacings = sorted(float(s) for s in sys.argv[2].split(","))
    pins, seconds = {}, {}
    for spacing in spacings:
        params = base.with_(spacing=spacing * 1e-3)
        builder_of(params).precompute(params)
        frames(params, friction)  # untimed: the first run fills the influence columns
        pins[spacing], labels, seconds[spacing] = frames(params, friction)
    finest = pins[spacings[0]]
    signal = np.sqrt((finest**2).sum(-1).mean(-1))  # (frames,) px: how far the pins moved, RMS
    own = base.spacing * 1e3
    print(f"# {scenario.name}: the pins at each spacing against {spacings[0]:g} mm, px (RMS over the 127 pins)")
    print(
        f"# the pins moved {signal.mean():.2f} px RMS from rest on average ({signal.min():.2f}–{signal.max():.2f} by frame)"
    )
    print(f"# cost: the sequence's physics, wall s, and its ratio to the scenario's own {own:g} mm (same run)")
    print("spacing_mm  rms_px_mean  rms_px_worst  worst_frame  share_worst  max_pin_px  seconds  ratio_to_own")
    for spacing in spacings:
        diff = np.sqrt(((pins[spacing] - finest) ** 2).sum(-1))  # (frames, 127) px
        rms = np.sqrt((diff**2).mean(-1))
        ratio = seconds[spacing] / seconds[own] if own in seconds else float("nan")
        print(
            f"{spacing:<10g}  {rms.mean():<11.3f}  {rms.max():<12.3f}  {labels[int(rms.argmax())]:<11s}"
            f"  {np.max(rms / signal):<11.3f}  {diff.max():<10.3f}  {seconds[spacing]:<7.2f}  {ratio:.2f}"
        )


if __name__ == "__main__":
    main()
