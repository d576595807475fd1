"""`twin bench`: speed (and, for the sweep, accuracy) figures printed as tables.

Speed targets are checked here by printing measured figures, never by timed asserts
in tests. Each section returns rows (dicts) so the sweep can write CSV/markdown.
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path

import numpy as np

from twin.analysis.sweep.knobs import named_settings
from twin.core.errors import UserError
from twin.core.resources import scenario_path
from twin.core.scenario import ContourProtocol, load_scenario
from twin.core.sensor import CameraModel
from twin.runs.backends import make_environment
from twin.runs.parallel import WorkerPool, default_workers
from twin.runs.protocols import protocol_moves
from twin.runs.runner import chunk_moves, chunk_samples, close_worker_envs, run_chunk, worker_environment
from twin.runs.spec import dome_params, load_scenario_stimulus, sim_spec
from twin.sensing.perception import benchmark_perception
from twin.sensing.tracker import PinTracker
from twin.tools.sweep_report import sweep_and_report
from twin.world import gl
from twin.world.dome.registry import DOME_MODELS, builder_of
from twin.world.dome.testbed import edge_scene, sensor_down
from twin.world.render import PinRenderer
from twin.world.scene import build_scene
from twin.world.silhouette import SilhouetteRenderer


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

    camera = CameraModel()
    pins = camera.geometry.pin_tip_points()
    rng = np.random.default_rng(0)
    rows = []
    for lighting in (False, True):
        for msaa in (0, 4):
            renderer = PinRenderer(camera, lighting=lighting, msaa=msaa)
            jitter = lambda: pins + rng.normal(0, 2e-4, pins.shape)  # noqa: E731  (new pins each frame)
            seconds = _time_per_call(
                lambda renderer=renderer, jitter=jitter: renderer.render(jitter()), min_calls=30 if quick else 120
            )
            renderer.close()
            rows.append(
                {
                    "section": "render",
                    "resolution": f"{camera.width}x{camera.height}",
                    "lighting": lighting,
                    "msaa": msaa,
                    "ms_per_frame": seconds * 1e3,
                    "fps": 1.0 / seconds,
                    "gl": gl.GL_BACKEND,
                }
            )
    base = {(r["lighting"]): r["ms_per_frame"] for r in rows if r["msaa"] == 0}
    for r in rows:
        r["aa_cost_ms"] = r["ms_per_frame"] - base[r["lighting"]]
    return rows


#: Camera shapes of `twin bench pixels`, from 96×96 to 1280×960 (the last is the default's 4× the pixels)
PIXEL_SHAPES = [(96, 96), (128, 128), (160, 120), (120, 160), (320, 240), (640, 480), (1280, 960)]


def bench_pixels(quick: bool = False) -> list[dict]:
    """Inside-camera render and tracking ms per frame against the frame's pixel count,
    96×96 to 1280×960 (no lighting, no anti-aliasing), with the GL renderer and the
    silhouette renderer (twin.world.silhouette), timed in rounds that run every shape once
    (median over rounds), so that a host that speeds up or slows down moves every shape
    alike; each row's render times also as ratios of 640×480's (median of the per-round
    ratios)."""

    rng = np.random.default_rng(0)
    renderers, silhouettes, trackers = [], [], []
    for width, height in PIXEL_SHAPES:
        camera = CameraModel(width=width, height=height)
        renderer = PinRenderer(camera)
        renderers.append(renderer)
        silhouettes.append(SilhouetteRenderer(camera))
        trackers.append(PinTracker(renderer.render(camera.geometry.pin_tip_points())))
    pins = CameraModel().geometry.pin_tip_points()
    calls = 10 if quick else 40
    render_s = np.zeros((5 if quick else 9, len(PIXEL_SHAPES)))
    track_s, silhouette_s = np.zeros_like(render_s), np.zeros_like(render_s)
    for round_ in range(-1, len(render_s)):  # round −1 untimed
        for i, (renderer, silhouette, tracker) in enumerate(zip(renderers, silhouettes, trackers)):
            moved = [pins + rng.normal(0, 2e-4, pins.shape) for _ in range(calls)]
            t0 = time.perf_counter()
            frames = [renderer.render(p) for p in moved]
            t1 = time.perf_counter()
            for frame in frames:
                tracker.track(frame)
            t2 = time.perf_counter()
            for p in moved:
                silhouette.render(p)
            if round_ >= 0:
                render_s[round_, i], track_s[round_, i] = (t1 - t0) / calls, (t2 - t1) / calls
                silhouette_s[round_, i] = (time.perf_counter() - t2) / calls
    for renderer in renderers:
        renderer.close()
    default = PIXEL_SHAPES.index((640, 480))
    return [
        {
            "section": "pixels",
            "resolution": f"{w}x{h}",
            "pixels": w * h,
            "render_ms": 1e3 * float(np.median(render_s[:, i])),
            "track_ms": 1e3 * float(np.median(track_s[:, i])),
            "pixels_to_640x480": w * h / (640 * 480),
            "render_to_640x480": float(np.median(render_s[:, i] / render_s[:, default])),
            "silhouette_ms": 1e3 * float(np.median(silhouette_s[:, i])),
            "silhouette_to_640x480": float(np.median(silhouette_s[:, i] / silhouette_s[:, default])),
            "gl": gl.GL_BACKEND,
        }
        for i, (w, h) in enumerate(PIXEL_SHAPES)
    ]


#: (fidelity level, width, height, renderer) of `twin bench observation`: the fast level's
#: small frame and the default level's 640×480 frame, each drawn by both renderers, against
#: the last: the default level's 640×480 frame drawn by GL, as every frame was drawn before
#: the silhouette renderer (twin.world.silhouette)
OBSERVATION_SETUPS = [
    ("fast", 128, 128, "silhouette"),
    ("fast", 128, 128, "gl"),
    ("default", 640, 480, "silhouette"),
    ("default", 640, 480, "gl"),
]


def bench_observation(quick: bool = False) -> list[dict]:
    """Printed by `twin bench pixels` after its own table. Full-observation frames per second (the move into a frame, settling, rendering and
    tracking: the environment's step) of the fast level at 128×128 against the default
    level at 640×480 (OBSERVATION_SETUPS, renderers included), on the multi-directional
    slide protocol (§III-C), flex dome.

    Both environments are built first; then rounds run the same chunk of moves in each,
    and `fps_to_default` is the median of the per-round ratios of a frame's time."""

    base = load_scenario(scenario_path("slides_rectangle"))
    scenario = base.model_copy(
        update={
            "effects": ["contact", "friction", "render"],
            "protocol": base.protocol.model_copy(update={"orientations_deg": [0.0]}),
        }
    )
    moves = chunk_moves(protocol_moves(scenario.protocol))[0]
    envs = []
    for level, width, height, renderer in OBSERVATION_SETUPS:
        camera = scenario.sensor.camera.model_copy(update={"width": width, "height": height, "renderer": renderer})
        setup = scenario.model_copy(
            update={"fidelity": level, "sensor": scenario.sensor.model_copy(update={"camera": camera})}
        )
        envs.append(make_environment(setup, 0))
    seconds = np.zeros((3 if quick else 7, len(envs)))
    frames = np.zeros(len(envs), dtype=int)
    try:
        for round_ in range(-1, len(seconds)):  # round −1 untimed
            for i, env in enumerate(envs):
                t0 = time.perf_counter()
                frames[i] = sum(1 for _ in chunk_samples(env, moves))
                if round_ >= 0:
                    seconds[round_, i] = time.perf_counter() - t0
    finally:
        for env in envs:
            env.close()
    default = len(envs) - 1
    return [
        {
            "section": "observation",
            "level": level,
            "resolution": f"{width}x{height}",
            "renderer": renderer,
            "frames": int(frames[i]),
            "fps": float(np.median(frames[i] / seconds[:, i])),
            "fps_to_default": float(np.median((seconds[:, default] / frames[default]) / (seconds[:, i] / frames[i]))),
            "gl": gl.GL_BACKEND,
        }
        for i, (level, width, height, renderer) in enumerate(OBSERVATION_SETUPS)
    ]


def bench_physics(quick: bool = False, scenarios: Sequence[Path] = ()) -> list[dict]:
    """ms of physics per settled frame for each fidelity level (contour-like steps), and
    for each of `scenarios`' domes."""

    rows = benchmark_physics(repeats=1 if quick else 5, verbose=False, scenarios=scenarios)
    return [{"section": "physics", **r} for r in rows]


def bench_perception(quick: bool = False) -> list[dict]:
    """Tracker ms/frame at 640×480, GP training on 288 points, prediction per frame."""

    r = benchmark_perception(np.random.default_rng(0), n_frames=20 if quick else 50, n_restarts=1 if quick else 2)
    return [{"section": "perception", **{k: v for k, v in r.items() if not isinstance(v, (list, dict))}}]


def _timed_chunk(scenario, seed: int, moves) -> tuple[int, float, float]:
    """Run one protocol chunk in this process's environment (built on first use).

    Returns (recorded frames, seconds running the chunk, seconds getting the
    environment — ≈ 0 when this process had already built it)."""

    t0 = time.perf_counter()
    worker_environment(scenario, seed)
    startup = time.perf_counter() - t0
    t1 = time.perf_counter()
    samples = run_chunk(scenario, seed, moves)
    return len(samples), time.perf_counter() - t1, startup


def _pid_after(seconds: float) -> int:
    """A warm-up job: this worker's pid, after holding it `seconds` (s)."""
    time.sleep(seconds)
    return os.getpid()


def _start_workers(pool: WorkerPool, hold_s: float = 0.05) -> float:
    """Seconds until every one of `pool`'s local workers has answered a job (forkserver, the
    simulator's imports, one process per worker). Rounds of short jobs go out until as many
    processes as workers have answered: the first worker up would otherwise answer them all,
    and its siblings' start-up would be timed as if it were their work."""
    t0 = time.perf_counter()
    answered: set[int] = set()
    while len(answered) < pool.workers:
        answered.update(pool.map_ordered(_pid_after, [(hold_s,)] * pool.workers))
    return time.perf_counter() - t0


def bench_throughput(quick: bool = False) -> list[dict]:
    """End-to-end frames per second on the multi-directional slide protocol (§III-C),
    pins only and rendered + tracked, in one process and over all local cores.

    A frame is one recorded sample: the move into it (≈ 2–4 mm, sliding in contact),
    settling, the observation (projected pins, or a rendered 640×480 frame tracked by
    twin.sensing.tracker); the protocol's unrecorded approach and lift moves count against it.
    Columns: fps_1_process (frames / time running the chunks, one process);
    pool_start_s (the worker pool answering a first job: forkserver, imports, processes);
    env_build_s (the slowest worker's environment build, in its first chunk);
    fps_all_cores (frames / wall time of the parallel run, both start-ups included);
    fps_all_cores_steady (the same without them: frames / (wall of the chunks − the
    slowest worker's environment build)); speedup = fps_all_cores_steady / fps_1_process,
    same run.
    """

    base = load_scenario(scenario_path("slides_rectangle"))
    orientations = [-160.0, 0.0] if quick else [-160.0, -80.0, 0.0, 80.0]
    rows = []
    workers = default_workers()
    outputs = (("pins only", ["contact", "friction"]), ("rendered + tracked", ["contact", "friction", "render"]))
    for label, effects in outputs:
        scenario = base.model_copy(
            update={"effects": effects, "protocol": base.protocol.model_copy(update={"orientations_deg": orientations})}
        )
        jobs = [(scenario, 0, chunk) for chunk in chunk_moves(protocol_moves(scenario.protocol))]
        serial = [_timed_chunk(*job) for job in jobs]
        close_worker_envs()  # this process's environment (and GL context) is not needed any more
        frames = sum(f for f, _, _ in serial)
        fps_1 = frames / sum(s for _, s, _ in serial)
        with WorkerPool(workers) as pool:
            pool_start = _start_workers(pool)
            t0 = time.perf_counter()
            parallel = list(pool.map_ordered(_timed_chunk, jobs))
            wall = time.perf_counter() - t0
        startup = max(s for _, _, s in parallel)
        rows.append(
            {
                "section": "throughput",
                "output": label,
                "frames": frames,
                "workers": workers,
                "fps_1_process": fps_1,
                "ms_per_frame_1_process": 1e3 / fps_1,
                "pool_start_s": pool_start,
                "env_build_s": startup,
                "fps_all_cores": frames / (pool_start + wall),
                "fps_all_cores_steady": frames / (wall - startup),
                "speedup": frames / (wall - startup) / fps_1,
            }
        )
    return rows


#: What `twin bench startup` runs: an open-loop scenario with rendered frames, two workers
STARTUP_SCENARIO, STARTUP_WORKERS = "taps_rectangle", 2

_IMPORT_PROBE = (
    "import time; t0 = time.perf_counter(); import twin.tools.cli, twin.runs.run; print(time.perf_counter() - t0)"
)


def _first_frame_of_twin_run(scenario: str, workers: int) -> float:
    """Seconds from starting `twin run SCENARIO --workers N` (a fresh interpreter) to its
    first recorded sample; the run is then killed (its workers end with it)."""
    with tempfile.TemporaryDirectory() as tmp:
        samples = Path(tmp) / "run" / "samples.jsonl"
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "twin.tools.cli",
                "run",
                scenario,
                "--workers",
                str(workers),
                "--out",
                str(samples.parent),
                "--quiet",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        try:
            while not (samples.exists() and samples.stat().st_size > 0):
                if proc.poll() is not None:
                    raise RuntimeError(
                        f"twin run {scenario} ended before its first frame: "
                        f"{proc.stderr.read().decode(errors='replace')[-500:]}"
                    )
                time.sleep(0.005)
            return time.perf_counter() - t0
        finally:
            proc.kill()
            proc.wait()


def bench_startup(quick: bool = False) -> list[dict]:
    """What `twin run taps_rectangle --workers 2` spends before its first frame, in
    seconds (median of 3 rounds, 1 with quick), warm caches: imports (a fresh
    interpreter importing the CLI and the runner), scene build (the scenario resolved and
    its MuJoCo scene compiled), environment (the whole simulated rig: scene,
    renderer's GL context, reset), pool start (forkserver and workers importing the
    simulator and answering a first job), first frame in one process (the first chunk's
    first sample once the environment exists), and end to end: the first sample line
    of the `twin run` command, from its start."""
    scenario = load_scenario(scenario_path(STARTUP_SCENARIO))
    chunk = chunk_moves(protocol_moves(scenario.protocol))[0]
    stages: dict[str, list[float]] = {}

    def timed(stage: str, fn: Callable[[], object]) -> object:
        t0 = time.perf_counter()
        result = fn()
        stages.setdefault(stage, []).append(time.perf_counter() - t0)
        return result

    for _ in range(1 if quick else 3):
        probe = subprocess.run([sys.executable, "-c", _IMPORT_PROBE], capture_output=True, text=True, check=True)
        stages.setdefault("imports", []).append(float(probe.stdout.strip()))
        timed("scene build", lambda: build_scene(sim_spec(scenario).scene))
        env = timed("environment", lambda: make_environment(scenario, scenario.seed))
        reader_frames: list[float] = []
        t0 = time.perf_counter()
        for _sample in chunk_samples(env, chunk):
            reader_frames.append(time.perf_counter() - t0)
            break
        env.close()
        stages.setdefault("first frame, one process", []).append(reader_frames[0])
        with WorkerPool(STARTUP_WORKERS) as pool:
            stages.setdefault("pool start", []).append(_start_workers(pool))
        stages.setdefault(f"twin run {STARTUP_SCENARIO} --workers {STARTUP_WORKERS}: first frame", []).append(
            _first_frame_of_twin_run(STARTUP_SCENARIO, STARTUP_WORKERS)
        )
    return [
        {"section": "startup", "stage": stage, "seconds": float(np.median(times)), "rounds": len(times)}
        for stage, times in stages.items()
    ]


def bench_sweep(
    quick: bool = False,
    out: Path | None = None,
    workers: int | None = None,
    cluster: str | None = None,
    settings: list[str] | None = None,
) -> list[dict]:
    """The fidelity sweep (twin.analysis.sweep): per setting, ms per frame split into physics,
    render, tracking and perception, against pin error (px), perception error (deg, mm)
    and contour error (mm); writes sweep.csv, sweep.md, sweep.json and pareto.png to
    `out` (default out/bench). Prints its own table. `settings`: names of the full sweep's
    settings to run instead of the quick or full set (UserError naming an unknown one)."""

    return sweep_and_report(
        out if out is not None else Path("out") / "bench",
        quick=quick,
        workers=workers,
        cluster=cluster,
        settings=None if settings is None else named_settings(settings),
    )


SECTIONS: dict[str, Callable[..., list[dict]]] = {
    "render": bench_render,
    "pixels": bench_pixels,
    "physics": bench_physics,
    "perception": bench_perception,
    "throughput": bench_throughput,
    "startup": bench_startup,
    "sweep": bench_sweep,
}
#: Tables a section prints after its own: `twin bench pixels` then shows what small
#: frames buy a whole observation
_FOLLOW_UPS: dict[str, dict[str, Callable[..., list[dict]]]] = {"pixels": {"observation": bench_observation}}
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


#: the physics benchmark's row every ratio is to: (dome model, fidelity level)
BASELINE_ROW = ("flex", "default")


def benchmark_physics(
    levels: list[str] | None = None, repeats: int = 5, verbose: bool = True, scenarios: Sequence[Path] = ()
) -> list[dict]:
    """ms of physics per settled frame for each dome model and fidelity level, best of
    `repeats`, and each row's time as a ratio of the flex default's (same run).

    A contour-following sequence on the edge scene with the contour protocol's defaults
    (twin.core.scenario.ContourProtocol: depth d, step e, speed): press to d at the edge, then
    eight steps of e along the edge, then lift off. Each frame = move + settle, timed as
    wall time of the whole physics calls (stepping or contact increments, pin read-out,
    checks). The rows are timed in rounds, each round running every row once after an
    untimed round (the compliant model's first run fills its columns), so that a host that
    speeds up or slows down during the run moves every row alike. Returns one dict per
    (dome, level): ms_per_frame (best), steps_per_frame (mean; flex: MuJoCo steps,
    compliant: contact increments), ms_per_step, precompute_s (compliant: computing and
    storing the influence matrices, DomeCompliance.one_off: the sealed gel's once per
    surface and ν, a skinned dome's once per surface and materials; flex: 0), cached_s
    (compliant: what a run pays at its first contact once they are in the cache,
    DomeCompliance.precompute; flex: 0),
    ratio_to_flex_default (best against best) and ratio_min, ratio_max (the lowest and
    highest ratio within one round: how far a single run's ratio may be trusted; NaN
    where the flex default is not among the levels). Besides the levels, the compliant
    default as the plain solid without its skin (twin.world.dome.compliant.PLAIN_SOLID, level
    `default+plain_solid`: what the skin costs), with 1 mm increments
    (`default+increment_1mm`, scenario `physics: {increment_mm: 1}`), and with an edge
    placed within a node (`default+edge_within_node`, `physics: {edge_within_node: true}`:
    what that costs) and with finite sliding (`default+finite_sliding`, `physics:
    {finite_sliding: true}`). Then one row for each of `scenarios` (level `scenario:<name>`): its
    dome model at its fidelity level with its `physics`, its calibration's dome material
    and its skin–object friction (or none where its effects leave friction out), on the
    same edge and sequence: what a scenario's dome costs beside the flex default.
    """

    contour = ContourProtocol()
    depth, step = contour.depth_mm, contour.step_mm
    poses = (
        [sensor_down(0, 0, depth)]
        + [sensor_down(0, step * k, depth) for k in range(1, 9)]
        + [sensor_down(0, 8 * step, -2)]
    )
    tables = [builder.levels for builder in DOME_MODELS.values()]
    tables += [
        {
            f"default+{name}": builder.params("default", builder.settings(**physics), {}, "benchmark")
            for name, physics in builder.presets.items()
        }
        for builder in DOME_MODELS.values()
        if builder.presets
    ]
    #: each row's level, dome parameters and edge contact (friction on, skin–object friction)
    cases = [(level, table[level], True, 1.0) for table in tables for level in levels or list(table) if level in table]
    for path in scenarios:
        scenario = load_scenario(path)
        friction = load_scenario_stimulus(scenario).friction
        cases.append((f"scenario:{scenario.name}", dome_params(scenario), scenario.has("friction"), friction))
    rows = []
    for level, params, _, _ in cases:
        builder = builder_of(params)
        precompute, cached = builder.precompute(params)
        rows.append({"dome": builder.name, "level": level, "precompute_s": precompute, "cached_s": cached})
    seconds = np.zeros((repeats, len(rows)))  # [round, row]
    steps = [0] * len(rows)
    for round_ in range(-1, repeats):  # round −1 untimed
        for i, (r, (_, params, friction, object_friction)) in enumerate(zip(rows, cases)):
            model, data, handles, physics = edge_scene(
                params, friction, object_friction, scenario=f"benchmark-{r['dome']}-{r['level']}"
            )
            t0 = time.perf_counter()
            for pose in poses:
                physics.move(pose, contour.speed_mm_s)
                physics.settle()
            if round_ >= 0:
                seconds[round_, i], steps[i] = time.perf_counter() - t0, physics.steps
    flex = next((seconds[:, i] for i, r in enumerate(rows) if (r["dome"], r["level"]) == BASELINE_ROW), None)
    for i, r in enumerate(rows):
        best = float(seconds[:, i].min())
        r.update(
            {
                "ms_per_frame": 1e3 * best / len(poses),
                "steps_per_frame": steps[i] / len(poses),
                "ms_per_step": 1e3 * best / steps[i],
            }
        )
        if flex is None:
            r["ratio_to_flex_default"] = r["ratio_min"] = r["ratio_max"] = float("nan")
        else:
            per_round = seconds[:, i] / flex
            r["ratio_to_flex_default"] = best / float(flex.min())
            r["ratio_min"], r["ratio_max"] = float(per_round.min()), float(per_round.max())
        if verbose:
            print(
                f"{r['dome']:9s} {r['level']:10s} {r['ms_per_frame']:7.1f} ms/frame  {r['steps_per_frame']:5.1f} "
                f"steps/frame  {r['ms_per_step']:.3f} ms/step  ×{r['ratio_to_flex_default']:.2f} of flex default "
                f"({r['ratio_min']:.2f}–{r['ratio_max']:.2f} within a round)"
            )
    return rows


def run_bench(
    what: str = "all",
    quick: bool = False,
    out: Path | None = None,
    workers: int | None = None,
    cluster: str | None = None,
    settings: list[str] | None = None,
    scenarios: Sequence[Path] = (),
) -> int:
    """Run one section or all of them, print tables, optionally write CSVs to `out`.

    The sweep section always writes its files (to `out`, default out/bench) and runs its
    settings in parallel (`workers` local processes, default all cores, or a Ray
    `cluster`); `settings` names the full sweep's settings to run (bench_sweep);
    `scenarios` adds their domes to the physics section (benchmark_physics). Returns
    the exit code: 1 when a sweep setting failed (reported, not hidden).
    """
    names = list(SECTIONS) if what == "all" else [what]
    if settings is not None and names != ["sweep"]:
        raise UserError("--settings chooses settings of the sweep: use it with `twin bench sweep`")
    if scenarios and names != ["physics"]:
        raise UserError("--scenario adds a scenario's dome to the physics rows: use it with `twin bench physics`")
    sections = {**SECTIONS, "physics": partial(bench_physics, scenarios=scenarios)}
    status = 0
    for name in names:
        if name not in sections:
            raise UserError(f"unknown bench section {name!r}; choose from {', '.join(sections)}")
        if name in _SELF_REPORTING:
            rows = sections[name](quick, out=out, workers=workers, cluster=cluster, settings=settings)
            failed = [r["setting"] for r in rows if r.get("status") != "ok"]
            if failed:
                print(f"{len(failed)} sweep setting(s) failed: {', '.join(failed)}")
                status = 1
            continue
        for table, bench in {name: sections[name], **_FOLLOW_UPS.get(name, {})}.items():
            rows = bench(quick)
            _print_rows(table, rows)
            if out is not None:
                out.mkdir(parents=True, exist_ok=True)
                with open(out / f"bench_{table}.csv", "w", newline="") as fh:
                    writer = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
                    writer.writeheader()
                    writer.writerows(rows)
    return status
