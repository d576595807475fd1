"""The sheared taps' orientation signal per lateral bin, as `twin evaluate` fits it (the θ
term's spread, RMS over pins), beside the same with its noise bias removed.

The θ gradient is a least-squares estimate, so its squared spread carries the estimate's
variance: σ_θ² (XᵀX)⁻¹_θθ Σ_j s_j² / 127, s_j² the residual variance of pin coordinate j.
usage: noise_bias.py [--bootstrap N] RUN[:EVERY:OFFSET] ... (EVERY/OFFSET: every EVERY-th
usable frame; N: also the debiased ratio's standard deviation over N resamplings of each
bin's taps, seeded). Run with the repository on PYTHONPATH."""

import sys

import numpy as np

from twin.analysis.edge_imprint import SHEARED_TERMS, usable
from twin.runs.record import load_run
from twin.sensing.perception import pins_to_vectors


def signal_by_bin(
    path: str, every: int = 1, offset: int = 0, resample: np.random.Generator | None = None
) -> dict[float, tuple[int, float, float, float]]:
    """{l: (frames, signal px, signal without its noise bias px, the bias px)}; with
    `resample`, each bin's taps drawn with replacement first."""
    run = load_run(path)
    index = np.nonzero(usable(run))[0]
    index = index[(index % every) == offset]
    z = pins_to_vectors(run.pins_px[index])
    lateral = run.label("lateral_mm")[index]
    centre = np.round(lateral)
    values = {t: run.label(t)[index] for t in SHEARED_TERMS[:-1]}
    values["lateral_in_bin_mm"] = lateral - centre
    out = {}
    for c in sorted(set(centre.tolist())):
        m = centre == c
        if m.sum() < 20:
            continue
        if resample is not None:
            m = resample.choice(np.nonzero(m)[0], size=int(m.sum()))
        x = np.column_stack([values[t][m] for t in SHEARED_TERMS])
        x = x - x.mean(axis=0)
        design = np.column_stack([np.ones(len(x)), x])
        coef, *_ = np.linalg.lstsq(design, z[m], rcond=None)
        residual = z[m] - design @ coef
        n, p = design.shape
        variance_theta = np.mean(x[:, 0] ** 2)
        raw2 = variance_theta * np.sum(coef[1] ** 2) / 127
        bias2 = variance_theta * np.linalg.pinv(design.T @ design)[1, 1] * np.sum(residual**2) / (n - p) / 127
        out[c + 0.0] = (len(design), np.sqrt(raw2), np.sqrt(max(raw2 - bias2, 0.0)), np.sqrt(bias2))
    return out


if __name__ == "__main__":
    args = sys.argv[1:]
    draws = int(args[1]) if args[0] == "--bootstrap" else 0
    for spec in args[2:] if draws else args:
        path, every, offset = (spec.split(":") + ["1", "0"])[:3]
        table = signal_by_bin(path, int(every), int(offset))
        raw0, clean0 = table[0.0][1], table[0.0][2]
        print(spec)
        for c, (n, raw, clean, bias) in table.items():
            print(
                f"  l {c:+.0f} n {n:4d} raw {raw:.3f} ({raw / raw0:.2f})  "
                f"debiased {clean:.3f} ({clean / clean0:.2f})  noise {bias:.3f}"
            )
        if draws:
            rng = np.random.default_rng(0)
            tables = [signal_by_bin(path, int(every), int(offset), rng) for _ in range(draws)]
            ratios = {c: [t[c][2] / t[0.0][2] for t in tables] for c in table}
            print("  debiased ratio over " + f"{draws} resamplings, mean ± sd:")
            print("   " + "  ".join(f"{c:+.0f}: {np.mean(r):.2f} ± {np.std(r):.2f}" for c, r in ratios.items()))
