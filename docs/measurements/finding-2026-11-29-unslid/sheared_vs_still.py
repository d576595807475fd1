"""The edge's orientation signal per lateral bin (px, the debiased spread of the fitted θ
term, twin.analysis.edge_imprint), with its spread over resamplings of each bin's taps
(seeded), and for runs with slides also the same read at zero slide: the linear model plus
θ × slide and θ × slide² terms for the slide along, across and the twist, so the θ
gradient is the one where the slide is 0.

usage: sheared_vs_still.py [--boots N] RUN [RUN ...]   (the repository on PYTHONPATH)"""

import argparse

import numpy as np

from twin.analysis.edge_imprint import SHEARED_TERMS, SLIDE_TERMS, _pin_rms, _TermNoise, usable
from twin.runs.record import load_run
from twin.sensing.perception import pins_to_vectors


def bin_signal(z, values, idx, at_zero_slide):
    """(signal px, residual px) of one bin's taps `idx`."""
    base = [values[t][idx] - values[t][idx].mean() for t in SHEARED_TERMS]
    cols = base
    if at_zero_slide:
        theta = base[0]
        cols = base + [theta * values[s][idx] for s in SLIDE_TERMS] + [theta * values[s][idx] ** 2 for s in SLIDE_TERMS]
    x = np.column_stack(cols)
    design = np.column_stack([np.ones(len(idx)), x])
    coef, *_ = np.linalg.lstsq(design, z[idx], rcond=None)
    unexplained = z[idx] - design @ coef
    return _TermNoise(design, unexplained).spread_px(x, coef, [0]), _pin_rms(unexplained)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--boots", type=int, default=30)
    args = ap.parse_args()
    for path in args.runs:
        run = load_run(path)
        ok = usable(run)
        z = pins_to_vectors(run.pins_px[ok])
        lateral = run.label("lateral_mm")[ok]
        centre = np.round(lateral)
        values = {t: run.label(t)[ok] for t in SHEARED_TERMS[:-1]}
        values["lateral_in_bin_mm"] = lateral - centre
        slides = any(np.abs(values[s]).max() > 0 for s in SLIDE_TERMS)
        rng = np.random.default_rng(0)
        print(path, "(sheared)" if slides else "(still)")
        print("   l  taps  signal px ± sd   resid px" + ("   at zero slide px ± sd   resid px" if slides else ""))
        for c in sorted(set(centre.tolist())):
            idx = np.flatnonzero(centre == c)
            if len(idx) < 20:
                continue
            line = f"{c:+4.0f} {len(idx):5d}"
            for zero in (False, True) if slides else (False,):
                s, r = bin_signal(z, values, idx, zero)
                sd = np.std([bin_signal(z, values, rng.choice(idx, len(idx)), zero)[0] for _ in range(args.boots)])
                line += f"   {s:6.3f} ± {sd:5.3f}   {r:6.2f}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
