"""`twin bench physics`'s flex default, compliant default and default+finite_sliding rows,
with the contact solves' Newton iterations counted over all of them: run with PYTHONPATH
at a checkout before and after finite sliding's re-solves start from the solve before them.

    PYTHONPATH=CHECKOUT python newton_bench.py
"""

import twin
import twin.world.dome.compliant.physics as physics
from twin.tools.bench import benchmark_physics

iterations = {"n": 0}
increment = physics.CompliantPhysics._increment


def counted(self, object2tool):
    before = self.iterations
    increment(self, object2tool)
    iterations["n"] += self.iterations - before


physics.CompliantPhysics._increment = counted
rows = benchmark_physics(levels=["default", "default+finite_sliding"], repeats=5, verbose=False)
print(twin.__file__, "Newton iterations", iterations["n"])
for r in rows:
    print(
        f"{r['dome']:9s} {r['level']:24s} {r['ms_per_frame']:6.1f} ms/frame  ×{r['ratio_to_flex_default']:.2f} "
        f"({r['ratio_min']:.2f}–{r['ratio_max']:.2f} within a round)"
    )
