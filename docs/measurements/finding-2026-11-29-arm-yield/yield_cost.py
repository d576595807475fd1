"""What the arm's yield costs: the same 150 taps of a recorded run replayed still through a
scenario with and without its `arm_yield_mm_per_n`, alternately three times in one process
(one worker); wall time per frame and the ratio. usage: yield_cost.py SCENARIO RECORDED"""

import sys
import tempfile
import time
from pathlib import Path

from twin.core.scenario import load_scenario
from twin.runs.lab_recording import with_taps_from
from twin.runs.record import load_run
from twin.runs.run import run_scenario

scenario = load_scenario(sys.argv[1])
recorded = load_run(sys.argv[2])
calibration = scenario.sensor.calibration
rigid = scenario.with_changes(
    sensor={
        **scenario.sensor.model_dump(),
        "calibration": {**calibration.model_dump(), "arm_yield_mm_per_n": [0.0, 0.0, 0.0]},
    }
)
times = {"rigid": [], "yielding": []}
for _ in range(3):
    for name, s in (("rigid", rigid), ("yielding", scenario)):
        replay = with_taps_from(s, recorded, first=150, without_slides=True)
        t0 = time.perf_counter()
        run_scenario(replay, Path(tempfile.mkdtemp()) / "run", workers=1, progress=False)
        times[name].append((time.perf_counter() - t0) / 151)
for name, t in times.items():
    print(f"{name:9s} " + " ".join(f"{1e3 * v:6.1f}" for v in t) + " ms/frame")
print("ratio yielding/rigid per pair:", " ".join(f"{y / r:.2f}" for y, r in zip(times["yielding"], times["rigid"])))
