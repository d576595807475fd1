"""Issue 40's point-4 criteria on full.py's tables: per variant, the lateral positions where
the signal ratio is within 0.1 of the real's, and drag / signal and θ_PC23 within a third
(twin / real between 2/3 and 4/3), with the misses.
usage: criteria.py OUT.json [OUT.json ...]"""

import json
import sys


def within(figure: str, twin: float, real: float) -> bool:
    """Whether one figure meets point 4: 0.1 on the signal ratio, a third on the others."""
    if figure == "signal":
        return abs(twin - real) <= 0.1
    return 2 / 3 <= twin / real <= 4 / 3


if __name__ == "__main__":
    for path in sys.argv[1:]:
        for name, table in json.load(open(path))["tables"].items():
            print(name)
            for figure in ("signal", "theta_pc23", "drag/signal"):
                rows = [r for r in table if r["figure"] == figure]
                missed = [r for r in rows if not within(figure, r["twin"], r["recorded"])]
                misses = ", ".join(f"{r['lateral_mm']:+.0f}: {r['twin']:.2f} vs {r['recorded']:.2f}" for r in missed)
                print(f"  {figure:12s} {len(rows) - len(missed):2d}/{len(rows)}  {misses}")
