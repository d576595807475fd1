"""How far a 1 mm in-contact slide along the edge and one across it turn θ_PC23 in sheared
taps (a DigiTac recording and its replays), per lateral bin: the along-edge figure of
twin.analysis.edge_imprint.along_edge_turn_sheared, and the same for the slide across the
edge (the fitted slide_lateral_mm term), in each run's own PC2–PC3 plane and, for a replay,
in the recording's; with the raw pins' turn (the slide's pin field along the orientation
direction, in degrees of θ).

    python across.py REAL_RUN [REPLAY_RUN ...]

The recording's own figures come with their spread over RESAMPLES bootstrap draws of its
taps (seeded), as the factor (×÷) one standard deviation of their log spans.
"""

import sys

import numpy as np

from twin.analysis.comparison import taps_both_kept
from twin.analysis.edge_imprint import carried_pcs, sheared_fits, tap_pcs
from twin.core.poses import wrap_deg
from twin.runs.record import Run, load_run

TERMS = {"along": "slide_along_mm", "across": "slide_lateral_mm"}
RESAMPLES = 20
SEED = 7


def resampled(run: Run, rng: np.random.Generator) -> Run:
    """The run with its taps drawn with replacement, its no-contact frames kept."""
    rest = [s for s in run.samples if s["labels"].get("no_contact")]
    taps = [s for s in run.samples if not s["labels"].get("no_contact")]
    return Run(run.path, run.meta, rest + [taps[i] for i in rng.integers(0, len(taps), len(taps))])


def turns(fits, pcs) -> dict[float, dict[str, float]]:
    """{l: {"along_raw", "along_pc23", "across_raw", "across_pc23"}} deg per mm."""
    out = {}
    for f in fits:
        g_t = f.gradients["theta_deg"]
        row = {}
        for name, term in TERMS.items():
            g = f.gradients[term]
            row[f"{name}_raw"] = abs(float(g @ g_t / (g_t @ g_t)))
            turn = wrap_deg(pcs.theta_pc23_deg(f.mean_z + g) - pcs.theta_pc23_deg(f.mean_z))[0]
            row[f"{name}_pc23"] = abs(float(turn))
        out[f.lateral_mm] = row
    return out


def show(label: str, table: dict, laterals: list[float]) -> None:
    print(f"  {label}")
    for key in ("along_raw", "across_raw", "along_pc23", "across_pc23"):
        print(f"    {key:12s}", " ".join(f"{table[l][key]:6.2f}" if l in table else "     -" for l in laterals))


def main(real_path: str, replays: list[str]) -> None:
    real = load_run(real_path)
    fits = sheared_fits(real)
    laterals = [f.lateral_mm for f in fits]
    print(f"{real_path}: {sum(f.n for f in fits)} taps; deg per mm of slide; l, mm:")
    print("    " + " " * 12, " ".join(f"{l:+6.0f}" for l in laterals))
    own = turns(fits, tap_pcs(real, fits))
    show("recording, own plane", own, laterals)
    rng = np.random.default_rng(SEED)
    drawn = []
    for _ in range(RESAMPLES):
        r = resampled(real, rng)
        r_fits = sheared_fits(r)
        drawn.append(turns(r_fits, tap_pcs(r, r_fits)))
    print(f"    its spread over {RESAMPLES} bootstrap draws, ×÷:")
    for key in ("along_pc23", "across_pc23"):
        factors = []
        for l in laterals:
            logs = [np.log(max(d[l][key], 1e-3)) for d in drawn if l in d]
            factors.append(f"{np.exp(np.std(logs)):6.2f}")
        print(f"    {key:12s}", " ".join(factors))
    ratio = [own[l]["across_pc23"] / own[l]["along_pc23"] for l in laterals]
    print("    across / along", " ".join(f"{v:6.2f}" for v in ratio))
    for path in replays:
        replay = load_run(path)
        shared = taps_both_kept(real, replay)
        r, t = real.subset([i for i, _ in shared]), replay.subset([j for _, j in shared])
        r_fits, t_fits = sheared_fits(r), sheared_fits(t)
        print(f"{path}: {len(shared)} taps both kept")
        show("recording, these taps", turns(r_fits, tap_pcs(r, r_fits)), laterals)
        show("replay, own plane", turns(t_fits, tap_pcs(t, t_fits)), laterals)
        show("replay, recording's plane", turns(t_fits, carried_pcs(tap_pcs(r, r_fits), r, t)), laterals)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
