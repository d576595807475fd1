"""How far a 1 mm in-contact slide along the edge and one across it turn θ_PC23 in sheared
taps (a DigiTac recording and its replays), per lateral bin: the along-edge figure of
twin.analysis.edge_imprint.along_edge_turn_sheared, and the same for the slide across the
edge (the fitted slide_lateral_mm term), in each run's own PC2–PC3 plane and, for a replay,
in the recording's; with the raw pins' turn (the slide's pin field along the orientation
direction, in degrees of θ).

    python across.py REAL_RUN [REPLAY_RUN ...]

The recording's own θ_PC23 turns come with their spread over RESAMPLES bootstrap draws of
its taps (twin.analysis.calibration_fit.figures.figure_spread, seeded), as the factor (×÷)
one standard deviation of their log spans.
"""

import math
import sys

from twin.analysis.calibration_fit.figures import figure_spread
from twin.analysis.comparison import taps_both_kept
from twin.analysis.edge_imprint import (
    BinFit,
    TapPCs,
    across_edge_turn_sheared,
    along_edge_turn_sheared,
    carried_pcs,
    sheared_fits,
    tap_pcs,
)
from twin.runs.record import Run, load_run

RESAMPLES = 20
SEED = 7


def turns(run: Run, fits: list[BinFit], pcs: TapPCs) -> dict[float, dict[str, float]]:
    """{l: {"along_raw", "along_pc23", "across_raw", "across_pc23"}} deg per mm, of the
    run's `sheared_fits` read in `pcs`."""
    along, across = along_edge_turn_sheared(run, pcs, fits), across_edge_turn_sheared(run, pcs, fits)
    return {
        l: {
            "along_raw": along[l]["raw_deg_per_mm"],
            "along_pc23": along[l]["pc23_deg_per_mm"],
            "across_raw": across[l]["raw_deg_per_mm"],
            "across_pc23": across[l]["pc23_deg_per_mm"],
        }
        for l in along
    }


def show(label: str, table: dict, laterals: list[float]) -> None:
    print(f"  {label}")
    for key in ("along_raw", "across_raw", "along_pc23", "across_pc23"):
        print(f"    {key:12s}", " ".join(f"{table[l][key]:6.2f}" if l in table else "     -" for l in laterals))


def main(real_path: str, replays: list[str]) -> None:
    real = load_run(real_path)
    fits = sheared_fits(real)
    own = turns(real, fits, tap_pcs(real, fits))
    laterals = list(own)
    print(f"{real_path}: {sum(f.n for f in fits)} taps; deg per mm of slide; l, mm:")
    print("    " + " " * 12, " ".join(f"{l:+6.0f}" for l in laterals))
    show("recording, own plane", own, laterals)
    spread = figure_spread(real, RESAMPLES, SEED)  # log units, as twin calibrate counts them
    print(f"    its spread over {RESAMPLES} bootstrap draws, ×÷:")
    for key, figure in (("along_pc23", "theta_pc23"), ("across_pc23", "theta_pc23_across")):
        print(f"    {key:12s}", " ".join(f"{math.exp(spread[figure, l]):6.2f}" for l in laterals))
    ratio = [own[l]["across_pc23"] / own[l]["along_pc23"] for l in laterals]
    print("    across / along", " ".join(f"{v:6.2f}" for v in ratio))
    for path in replays:
        replay = load_run(path)
        shared = taps_both_kept(real, replay)
        r, t = real.subset([i for i, _ in shared]), replay.subset([j for _, j in shared])
        r_fits, t_fits = sheared_fits(r), sheared_fits(t)
        r_pcs = tap_pcs(r, r_fits)
        print(f"{path}: {len(shared)} taps both kept")
        show("recording, these taps", turns(r, r_fits, r_pcs), laterals)
        show("replay, own plane", turns(t, t_fits, tap_pcs(t, t_fits)), laterals)
        show("replay, recording's plane", turns(t, t_fits, carried_pcs(r_pcs, r, t)), laterals)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
