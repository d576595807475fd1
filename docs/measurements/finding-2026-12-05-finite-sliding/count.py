"""What finite sliding costs on a replay of a recording's taps, in one process: increments,
contact solves per increment, increments settled where the contact set switches, and the
time in increments, beside the same scenario without it (written by `variant.py`).

    python count.py RECORDING EVERY SCENARIO [SCENARIO ...]   (every EVERY-th tap, one worker)
"""

import collections
import shutil
import sys
import tempfile
import time

import twin.world.dome.compliant.physics as physics
from twin.tools.cli import main

recording, every, scenarios = sys.argv[1], sys.argv[2], sys.argv[3:]
counts: collections.Counter = collections.Counter()
state = {"solves": 0}
solve, increment = physics.CompliantPhysics._solve, physics.CompliantPhysics._increment


def counted_solve(self, *args):
    state["solves"] += 1
    return solve(self, *args)


def counted_increment(self, object2tool):
    before, switches, t0 = state["solves"], self.contact_switches, time.perf_counter()
    increment(self, object2tool)
    counts["seconds"] += time.perf_counter() - t0
    counts["increments"] += 1
    counts[f"solves {state['solves'] - before}"] += 1
    counts["settled at a switch"] += self.contact_switches - switches


physics.CompliantPhysics._solve, physics.CompliantPhysics._increment = counted_solve, counted_increment
seconds = {}
for scenario in scenarios:
    counts.clear()
    out = tempfile.mkdtemp()
    shutil.rmtree(out)
    sys.argv = ["twin", "run", scenario, "--taps-from", recording, "--every-nth-tap", every, "--workers", "1"]
    sys.argv += ["--quiet", "--out", out]
    try:
        main()
    except SystemExit as done:
        if done.code:
            raise
    shutil.rmtree(out, ignore_errors=True)
    seconds[scenario] = counts["seconds"]
    solves = sorted((int(k.split()[1]), v) for k, v in counts.items() if k.startswith("solves "))
    print(f"{scenario}: {counts['increments']} increments in {counts['seconds']:.1f} s")
    print("  solves per increment: " + ", ".join(f"{n}: {v}" for n, v in solves))
    print(f"  settled where the contact set switches: {counts['settled at a switch']}")
first = scenarios[0]
for scenario in scenarios[1:]:
    print(f"time in increments, {scenario} / {first}: {seconds[scenario] / seconds[first]:.2f}")
