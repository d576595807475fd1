"""The edge figures at the fit's best point (the report's 'after' is at the defaults, none identifiable)."""

import json
import sys
from pathlib import Path

from twin.analysis.calibration_fit.data import load_data
from twin.analysis.calibration_fit.evaluator import Evaluator
from twin.analysis.calibration_fit.settings import load_settings
from twin.analysis.calibration_fit.space import Space
from twin.core.scenario import load_scenario
from twin.runs.parallel import WorkerPool


def main():
    fit = Path(sys.argv[1])
    rep = json.loads((fit / "report.json").read_text())
    best = json.loads((fit / "checkpoint.json").read_text())["best"]
    scenario = load_scenario(Path(rep["scenario"]))
    settings = load_settings(Path(sys.argv[2]))
    space = Space(scenario, settings)
    rest = rep["camera_from_rest"]["values"]
    space.defaults.update(rest)
    data = load_data([Path(r) for r in rep["runs"]], scenario, settings.weights)
    with WorkerPool(2) as pool:
        ev = Evaluator(space, data, pool)
        values = {**space.defaults, **best}
        tips = ev.simulate_one({n: values[n] for n in space.physics}, "best")
        table = ev.figure_table(tips, values)
    print(best)
    print(
        "chi2 figures",
        sum(r["miss"] ** 2 for r in table),
        "within tolerance",
        sum(abs(r["miss_tolerance"]) <= 1 for r in table),
        "of",
        len(table),
    )
    for r in table:
        print(
            f"{r['figure']:12s} {r['lateral_mm']:+3.0f} real {r['recorded']:7.3f} twin {r['twin']:7.3f} miss {r['miss_tolerance']:+5.1f} fitted {r['miss']:+5.1f}"
        )


if __name__ == "__main__":
    main()
