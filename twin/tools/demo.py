"""`twin demo`: the README's main job — trace all six objects with the model trained on
the tap set (trained on first use, then cached), print the metrics table, write plots."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

from twin.core.resources import scenario_path
from twin.core.scenario import load_scenario
from twin.runs.contour_run import run_contour
from twin.runs.parallel import map_ordered
from twin.runs.sim_env import render_scenario_view
from twin.runs.training import cached_tap_model
from twin.tools.video import write_run_video

OBJECTS = ("rectangle", "large_circle", "small_circle", "flower", "spiral", "tape_measure")
COLUMNS = (
    ("object", "{}"),
    ("completed", "{}"),
    ("steps", "{}"),
    ("orientation_rms_deg", "{:.1f}"),
    ("lateral_rms_mm", "{:.2f}"),
    ("path_distance_mean_mm", "{:.2f}"),
    ("path_distance_max_mm", "{:.2f}"),
    ("coverage", "{:.2f}"),
    ("sim_time_s", "{:.1f}"),
    ("wall_time_s", "{:.1f}"),
)


def trace_contour(scenario, out: Path, model, video: bool = False) -> dict:
    """Trace one contour scenario into `out` with `model` (and write its video.mp4 when
    `video`); returns its metrics.json."""

    run_contour(scenario, out, model=model, progress=False)
    if video:
        write_run_video(out)
    return json.loads((out / "metrics.json").read_text())


def format_metrics(rows: list[dict]) -> str:
    widths = [max(len(c), *(len(f.format(r[c])) for r in rows)) for c, f in COLUMNS]
    lines = ["  ".join(c.ljust(w) for (c, _), w in zip(COLUMNS, widths))]
    lines += ["  ".join(f.format(r[c]).ljust(w) for (c, f), w in zip(COLUMNS, widths)) for r in rows]
    return "\n".join(lines)


def run_demo(
    out: Path, seed: int = 0, objects: tuple[str, ...] = OBJECTS, workers: int | None = None, video: bool = False
) -> int:
    """Trace `objects` (video: one MP4 per run, twin.tools.video); exit code 0 when all complete."""

    out.mkdir(parents=True, exist_ok=True)
    scenarios = [load_scenario(scenario_path(f"contour_{name}")).with_changes(seed=seed) for name in objects]
    t0 = time.perf_counter()
    model = cached_tap_model(scenarios[0])
    print(f"perception model: {model.info['path']} ({time.perf_counter() - t0:.1f} s)")
    render_scenario_view(load_scenario(scenario_path("rectangle_render")), out / "rig_overview.png", view="scene")
    t1 = time.perf_counter()
    jobs = []
    for s in scenarios:
        run_dir = out / s.name
        if run_dir.exists():
            shutil.rmtree(run_dir)
        jobs.append((s, run_dir, model, video))
    rows = list(map_ordered(trace_contour, jobs, workers=workers))
    wall = time.perf_counter() - t1
    print(format_metrics(rows))
    done = sum(r["completed"] for r in rows)
    mean_rms = sum(r["orientation_rms_deg"] for r in rows) / len(rows)
    print(
        f"{done}/{len(rows)} contours completed; mean orientation RMS {mean_rms:.1f}° (paper, real rig: 12.2°); "
        f"all objects in {wall:.1f} s wall time"
    )
    (out / "metrics.json").write_text(json.dumps({"objects": rows, "wall_time_s": wall}, indent=1))
    print(
        f"wrote {out}/contour_<object>/contour.png{', video.mp4' if video else ''}, metrics.json and {out}/rig_overview.png"
    )
    return 0 if done == len(rows) else 1
