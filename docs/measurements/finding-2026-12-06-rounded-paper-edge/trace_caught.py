"""Trace finite sliding's most carried skin node over a run: at each increment where a node
has been carried more than 1 mm (the first measurement of each increment), which node,
how far (mm), its contact normal's angle from the object's top (deg: 0 on the top face, 90 on a wall, between on an edge), the force on
it (N) and its rest point and displacement in the dome's frame (mm). It wraps
CompliantPhysics._contact_geometry, which each measurement calls once before its checks, to
read them from its result, and then runs `twin run` in the same process.
usage: python trace_caught.py SCENARIO.yaml OUT  (e.g. ../finding-2026-12-06-pooled-fit/across-slide-fails.yaml)"""

import math
import sys

import numpy as np

from twin.world.dome.compliant import physics

geometry = physics.CompliantPhysics._contact_geometry
rows: list[str] = []
last = [None]  # the (physics, increment) last traced
most = [0.0, ""]  # the largest carry (m) and its row


def traced(self, object2tool, through):
    gaps, frames = geometry(self, object2tool, through)
    carried = np.linalg.norm(through, axis=1)
    node = int(np.argmax(carried))
    if carried[node] > 1e-3 and last[0] != (id(self), self._steps):
        last[0] = (id(self), self._steps)
        top = self._object_pose(self._at)[:3, 2]
        tilt = math.degrees(math.acos(float(np.clip(-frames[node, 0] @ top, -1.0, 1.0))))
        rows.append(
            f"{self._steps:9d} {node:5d} {carried[node] * 1e3:8.2f} {tilt:8.1f} {np.linalg.norm(self.forces[node]):8.3f}"
            f"  {np.array2string(self.surface.points[node] * 1e3, precision=2)}"
            f"  {np.array2string(through[node] * 1e3, precision=2)}"
        )
        if carried[node] > most[0]:
            most[:] = carried[node], rows[-1]
    return gaps, frames


physics.CompliantPhysics._contact_geometry = traced
from twin.tools.cli import main  # noqa: E402 (after the wrap, which the run's physics then calls)

code = main(["run", sys.argv[1], "--workers", "1", "--quiet", "--out", sys.argv[2]])
print("increment  node  carried  normal°  force N  rest point (mm)  carried by (mm)")
print("\n".join(rows))
print(f"most carried:\n{most[1]}")
print(f"twin run exit code {code}")
