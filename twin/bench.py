"""`twin bench`: speed (and, for the sweep, accuracy) figures printed as tables.

Speed targets are checked here by printing measured figures, never by timed asserts
in tests. Each section returns rows (dicts) so the sweep can write CSV/markdown.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import numpy as np

from twin import gl


def _time_per_call(fn: Callable[[], object], min_calls: int = 20, min_seconds: float = 0.5) -> float:
    """Median seconds per call of `fn` over at least `min_calls` calls and `min_seconds`."""
    fn()  # warm-up
    samples: list[float] = []
    start = time.perf_counter()
    while len(samples) < min_calls or time.perf_counter() - start < min_seconds:
        t0 = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - t0)
    return float(np.median(samples))


def bench_render(quick: bool = False) -> list[dict]:
    """Inside-camera frames per second at 640×480, with and without anti-aliasing."""
    from twin.render import PinRenderer
    from twin.tactip import CameraModel

    camera = CameraModel()
    pins = camera.geometry.pin_tip_points()
    rng = np.random.default_rng(0)
    rows = []
    for lighting in (False, True):
        for msaa in (0, 4):
            renderer = PinRenderer(camera, lighting=lighting, msaa=msaa)
            jitter = lambda: pins + rng.normal(0, 2e-4, pins.shape)  # noqa: E731  (new pins each frame)
            seconds = _time_per_call(lambda: renderer.render(jitter()), min_calls=30 if quick else 120)
            renderer.close()
            rows.append({"section": "render", "resolution": f"{camera.width}x{camera.height}", "lighting": lighting,
                         "msaa": msaa, "ms_per_frame": seconds * 1e3, "fps": 1.0 / seconds, "gl": gl.GL_BACKEND})
    base = {(r["lighting"]): r["ms_per_frame"] for r in rows if r["msaa"] == 0}
    for r in rows:
        r["aa_cost_ms"] = r["ms_per_frame"] - base[r["lighting"]]
    return rows


def bench_physics(quick: bool = False) -> list[dict]:
    """ms of physics per settled frame for each fidelity level (contour-like steps)."""
    from twin.physics import benchmark_physics

    rows = benchmark_physics(repeats=1 if quick else 3, verbose=False)
    return [{"section": "physics", **r} for r in rows]


def bench_perception(quick: bool = False) -> list[dict]:
    """Tracker ms/frame at 640×480, GP training on 288 points, prediction per frame."""
    from twin.perception import benchmark_perception

    r = benchmark_perception(np.random.default_rng(0), n_frames=20 if quick else 50, n_restarts=1 if quick else 2)
    return [{"section": "perception", **{k: v for k, v in r.items() if not isinstance(v, (list, dict))}}]


def bench_sweep(quick: bool = False, out: Path | None = None, workers: int | None = None,
                cluster: str | None = None) -> list[dict]:
    """The fidelity sweep (twin.sweep): per setting, ms per frame split into physics,
    render, tracking and perception, against pin error (px), perception error (deg, mm)
    and contour error (mm); writes sweep.csv, sweep.md, sweep.json and pareto.png to
    `out` (default out/bench). Prints its own table."""
    from twin.sweep import run_sweep

    return run_sweep(out if out is not None else Path("out") / "bench", quick=quick, workers=workers, cluster=cluster)


SECTIONS: dict[str, Callable[..., list[dict]]] = {
    "render": bench_render,
    "physics": bench_physics,
    "perception": bench_perception,
    "sweep": bench_sweep,
}
#: Sections that take out/workers/cluster and write and print their own outputs.
_SELF_REPORTING = {"sweep"}


def _print_rows(title: str, rows: list[dict]) -> None:
    if not rows:
        return
    keys = list(rows[0].keys())
    fmt = lambda v: f"{v:.2f}" if isinstance(v, float) else str(v)  # noqa: E731
    widths = [max(len(k), *(len(fmt(r.get(k, ""))) for r in rows)) for k in keys]
    print(f"\n== {title} ==")
    print("  ".join(k.ljust(w) for k, w in zip(keys, widths)))
    for r in rows:
        print("  ".join(fmt(r.get(k, "")).ljust(w) for k, w in zip(keys, widths)))


def run_bench(what: str = "all", quick: bool = False, out: Path | None = None, workers: int | None = None,
              cluster: str | None = None) -> int:
    """Run one section or all of them, print tables, optionally write CSVs to `out`.

    The sweep section always writes its files (to `out`, default out/bench) and runs its
    settings in parallel (`workers` local processes, default all cores, or a Ray
    `cluster`). Returns the exit code: 1 when a sweep setting failed (reported, not hidden).
    """
    names = list(SECTIONS) if what == "all" else [what]
    status = 0
    for name in names:
        if name not in SECTIONS:
            from twin.errors import UserError

            raise UserError(f"unknown bench section {name!r}; choose from {', '.join(SECTIONS)}")
        if name in _SELF_REPORTING:
            rows = SECTIONS[name](quick, out=out, workers=workers, cluster=cluster)
            failed = [r["setting"] for r in rows if r.get("status") != "ok"]
            if failed:
                print(f"{len(failed)} sweep setting(s) failed: {', '.join(failed)}")
                status = 1
            continue
        rows = SECTIONS[name](quick)
        _print_rows(name, rows)
        if out is not None:
            import csv

            out.mkdir(parents=True, exist_ok=True)
            with open(out / f"bench_{name}.csv", "w", newline="") as fh:
                writer = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
                writer.writeheader()
                writer.writerows(rows)
    return status
