"""The edge figures of an imported DigiTac run at several physics points, one column each.

usage: sens.py FIT_DIR SCENARIO SETTINGS VARIANTS.json OUT.json
FIT_DIR: a finished `twin calibrate` of the run (its runs and its camera from the
no-contact frame); VARIANTS.json: {name: {parameter: value}} over BASE (the previous
fit's best point). Run with the repository on PYTHONPATH."""

import json
import sys
from pathlib import Path

from twin.analysis.calibration_fit.data import load_data
from twin.analysis.calibration_fit.evaluator import Evaluator
from twin.analysis.calibration_fit.settings import load_settings
from twin.analysis.calibration_fit.space import Space
from twin.core.scenario import load_scenario
from twin.runs.parallel import WorkerPool

BASE = {
    "material.membrane_young_mpa": 0.31,
    "material.skin_held_deg": 90.0,
    "friction": 0.51,
    "material.skin_bending_mpa": 0.05,
    "material.tip_sway_mm_per_n": 0.0,
    "tcp.z_mm": 0.0,
    "material.young_kpa": 13.3,
}


def main():
    fit, scenario_path, settings_path, variants_path, out = map(Path, sys.argv[1:6])
    variants = json.loads(variants_path.read_text())
    rep = json.loads((fit / "report.json").read_text())
    scenario = load_scenario(scenario_path)
    settings = load_settings(settings_path)
    space = Space(scenario, settings)
    space.defaults.update(rep["camera_from_rest"]["values"])
    data = load_data([Path(r) for r in rep["runs"]], scenario, settings.weights)
    tables = {}
    with WorkerPool(2) as pool:
        ev = Evaluator(space, data, pool)
        points = [{**BASE, **v} for v in variants.values()]
        tips = ev.simulate([{n: p[n] for n in space.physics} for p in points])
        for (name, _), p, t in zip(variants.items(), points, tips):
            if t is None:
                print(name, "failed", ev.failures[-1]["error"])
                continue
            tables[name] = ev.figure_table(t, {**space.defaults, **p})
    out.write_text(json.dumps(tables, default=float, indent=1))
    names = list(tables)
    first = tables[names[0]]
    print(f"{'figure':12s} {'l':>3s} {'real':>7s} " + " ".join(f"{n[:9]:>9s}" for n in names))
    for i, r in enumerate(first):
        print(
            f"{r['figure']:12s} {r['lateral_mm']:+3.0f} {r['recorded']:7.3f} "
            + " ".join(f"{tables[n][i]['twin']:9.3f}" for n in names)
        )
    print(f"{'chi2':24s}" + " ".join(f"{sum(r['miss'] ** 2 for r in tables[n]):9.1f}" for n in names))
    print(f"{'within':24s}" + " ".join(f"{sum(abs(r['miss_tolerance']) <= 1 for r in tables[n]):9d}" for n in names))


if __name__ == "__main__":
    main()
