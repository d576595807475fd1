"""The edge figures of a whole imported DigiTac run at several physics points, through the
camera fitted to its no-contact frame (solved on a small import of the same set).

usage: full.py SCENARIO SETTINGS SMALL_RUN FULL_RUN VARIANTS.json OUT.json
VARIANTS.json: {name: {parameter: value}} over BASE (the sway fit's best point). Run with
the repository on PYTHONPATH."""

import json
import sys
import time
from pathlib import Path

from twin.analysis.calibration_fit.data import load_data
from twin.analysis.calibration_fit.evaluator import Evaluator
from twin.analysis.calibration_fit.fit import _camera_from_rest
from twin.analysis.calibration_fit.settings import load_settings
from twin.analysis.calibration_fit.space import Space
from twin.core.scenario import load_scenario
from twin.runs.parallel import WorkerPool

BASE = {
    "material.young_kpa": 26.02,
    "material.membrane_young_mpa": 0.1664,
    "material.skin_bending_mpa": 0.04814,
    "material.tip_sway_mm_per_n": 0.1437,
    "friction": 0.5491,
    "tcp.z_mm": -0.28,
    "material.skin_held_deg": 90.0,
}


def main():
    scenario_path, settings_path, small, full, variants_path, out = map(Path, sys.argv[1:7])
    variants = json.loads(variants_path.read_text())
    scenario, settings = load_scenario(scenario_path), load_settings(settings_path)
    space = Space(scenario, settings)
    with WorkerPool(2) as pool:
        # the camera from the no-contact frame: a small run suffices (the figures need many taps, the camera one frame)
        weights = settings.weights.model_copy(update={"edge_figures": 0.0})
        small_space = Space(scenario, settings.model_copy(update={"weights": weights}))
        small_ev = Evaluator(small_space, load_data([small], scenario, weights), pool)
        camera = _camera_from_rest(small_ev, small_ev.simulate_one(dict(small_space.defaults), "the small run"))
        space.defaults.update(camera["values"])
        print("camera", {k: round(v, 5) for k, v in camera["values"].items()}, flush=True)
        ev = Evaluator(space, load_data([full], scenario, settings.weights), pool)
        tables = {}
        for name, change in variants.items():
            point = {**BASE, **change}
            t0 = time.time()
            (tips,) = ev.simulate([{n: point[n] for n in space.physics}])
            if tips is None:
                print(name, "failed", ev.failures[-1]["error"], flush=True)
                continue
            tables[name] = ev.figure_table(tips, {**space.defaults, **point})
            print(name, f"{time.time() - t0:.0f} s, chi2 {sum(r['miss'] ** 2 for r in tables[name]):.1f}", flush=True)
            out.write_text(json.dumps({"camera": camera["values"], "tables": tables}, default=float, indent=1))
    names = list(tables)
    print(f"{'figure':12s} {'l':>3s} {'real':>7s} " + " ".join(f"{n[:9]:>9s}" for n in names))
    for i, r in enumerate(tables[names[0]]):
        print(
            f"{r['figure']:12s} {r['lateral_mm']:+3.0f} {r['recorded']:7.3f} "
            + " ".join(f"{tables[n][i]['twin']:9.3f}" for n in names)
        )
    print(f"{'chi2':24s}" + " ".join(f"{sum(r['miss'] ** 2 for r in tables[n]):9.1f}" for n in names))
    print(f"{'within':24s}" + " ".join(f"{sum(abs(r['miss_tolerance']) <= 1 for r in tables[n]):9d}" for n in names))


if __name__ == "__main__":
    main()
