"""ms of physics per frame, the lab-fit apex dome against the flex default and the compliant
default, in rounds in one process (twin.tools.bench.benchmark_physics's sequence).

    python bench_labfit.py TAPS_SCENARIO   (the apex profile's paper/taps.yaml)"""

import sys
import time

import numpy as np
import yaml

from twin.core.scenario import ContourProtocol
from twin.world.dome.registry import DOME_MODELS
from twin.world.dome.testbed import edge_scene, sensor_down

s = yaml.safe_load(open(sys.argv[1]))
mat = s["sensor"]["calibration"]["dome_material"]
flex, comp = DOME_MODELS["flex"], DOME_MODELS["compliant"]
rows = {
    "flex default": flex.params("default", flex.settings(), {}, "bench"),
    "compliant default": comp.params("default", comp.settings(), {}, "bench"),
    "lab fit, apex 30": comp.params("default", comp.settings(**s["physics"]), mat, "bench"),
    "lab fit, sphere": comp.params("default", comp.settings(**(s["physics"] | {"apex_radius_mm": 20})), mat, "bench"),
}
friction = float(s["sensor"]["calibration"]["friction"])
for p in rows.values():
    (comp if p.__class__ is rows["compliant default"].__class__ else flex).precompute(p)
c = ContourProtocol()
poses = (
    [sensor_down(0, 0, c.depth_mm)]
    + [sensor_down(0, c.step_mm * k, c.depth_mm) for k in range(1, 9)]
    + [sensor_down(0, 8 * c.step_mm, -2)]
)
repeats = 5
sec = np.zeros((repeats, len(rows)))
steps = [0] * len(rows)
for r in range(-1, repeats):
    for i, (name, p) in enumerate(rows.items()):
        _, _, _, physics = edge_scene(p, object_friction=friction if name.startswith("lab") else 1.0, scenario=name)
        t0 = time.perf_counter()
        for pose in poses:
            physics.move(pose, c.speed_mm_s)
            physics.settle()
        if r >= 0:
            sec[r, i] = time.perf_counter() - t0
            steps[i] = physics.steps
best = sec.min(axis=0)
ratio = sec / sec[:, :1]
for i, name in enumerate(rows):
    print(
        f"{name:20s} {1000 * best[i] / len(poses):7.2f} ms/frame  {steps[i] / len(poses):6.1f} steps/frame  "
        f"x{best[i] / best[0]:.2f} of flex default (per round {ratio[:, i].min():.2f}-{ratio[:, i].max():.2f})"
    )
