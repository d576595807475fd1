"""The sweep: every setting's probe as one parallel job, the timing pass, each setting's
pin error against its dome's reference, and the fronts."""

from __future__ import annotations

import os
import platform
import time
from dataclasses import asdict

from twin.analysis.sweep.fronts import annotate_fronts
from twin.analysis.sweep.knobs import DEFAULT, REFERENCE, REFERENCES, Setting, full_settings, quick_settings
from twin.analysis.sweep.probe import FULL_PROBE, QUICK_PROBE, Probe, probe_setting, rms_px
from twin.analysis.sweep.timing import TIMING_ORIENTATIONS, TIMING_REPEATS, time_settings
from twin.core.errors import UserError
from twin.runs.parallel import default_workers, map_ordered
from twin.world import gl


def run_sweep(
    quick: bool = False,
    workers: int | None = None,
    cluster: str | None = None,
    settings: list[Setting] | None = None,
    probe: Probe | None = None,
    seed: int = 0,
    verbose: bool = True,
) -> tuple[list[dict], dict]:
    """Run the sweep: its rows and meta (how, where and when it was measured). Its files:
    twin.tools.sweep_report.

    quick: the QUICK_PROBE over quick_settings() (smoke check, < 2 min on 2 cores).
    workers / cluster: as twin.runs.parallel.map_ordered (default: all local cores); one
      accuracy job per setting. The timing pass then runs here, one setting at a time
      (`time_settings`; on a cluster too, so that every time is from the same machine).
    Returns the rows (dicts, one per setting, with the figures of the package docstring).
    """
    settings = settings if settings is not None else (quick_settings() if quick else full_settings())
    probe = probe if probe is not None else (QUICK_PROBE if quick else FULL_PROBE)
    names = [s.name for s in settings]
    for dome in sorted({s.dome for s in settings}):
        if REFERENCES[dome] not in names:
            raise UserError(
                f"the sweep needs the {REFERENCES[dome]!r} setting: the pin error of every {dome} "
                "setting is measured against it"
            )
    if len(set(names)) != len(names):
        raise UserError(f"sweep settings need distinct names, got {names}")
    n_workers = 1 if cluster is None and workers == 1 else (workers or default_workers())
    wall0 = time.perf_counter()
    results: list[dict] = []
    for i, result in enumerate(
        map_ordered(probe_setting, [(s, probe, seed) for s in settings], workers=workers, cluster=cluster)
    ):
        results.append(result)
        r = result["row"]
        if verbose:
            state = "ok" if r["status"] == "ok" else f"FAILED in {r['stage']}: {r['error']}"
            print(
                f"[{i + 1}/{len(settings)}] {r['setting']:18s} {r.get('total_ms', float('nan')):7.1f} ms/frame  "
                f"{r['wall_s']:6.1f} s  {state}",
                flush=True,
            )
    rows = [r["row"] for r in results]
    repeats = TIMING_REPEATS[1] if quick else TIMING_REPEATS[0]
    time_settings(settings, rows, probe, seed, repeats, verbose)
    wall = time.perf_counter() - wall0
    for setting, result in zip(settings, results):
        row = result["row"]
        ref_truth = results[names.index(REFERENCES[setting.dome])]["slide_truth_px"]
        pins = result["slide_pins_px"]
        if setting.pins_comparable and ref_truth is not None and pins is not None and len(pins) == len(ref_truth):
            row["pin_rms_px"] = rms_px(pins, ref_truth)
            row["pin_physics_rms_px"] = rms_px(result["slide_truth_px"], ref_truth)
    annotate_fronts(rows)
    meta = {
        "quick": quick,
        "probe": asdict(probe),
        "seed": seed,
        "workers": n_workers if cluster is None else f"ray {cluster}",
        "wall_s": wall,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.python_version()}",
        "gl": gl.GL_BACKEND,
        "failures": [f"{r['setting']} ({r['stage']}): {r['error']}" for r in rows if r["status"] != "ok"],
        "reference": REFERENCE,
        "references": {d: r for d, r in REFERENCES.items() if r in names},
        "default": DEFAULT if DEFAULT in names else None,
        "timing": {"repeats": repeats, "orientations_deg": list(probe.slide_orientations_deg[:TIMING_ORIENTATIONS])},
        "date": time.strftime("%Y-%m-%d"),
    }
    return rows, meta
