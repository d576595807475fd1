"""Why the held-out taps read l worse off the object with the edge within nodes: φ by
lateral position and depth, and what the lateral GP makes of it.

    python heldout_phi.py WHOLE_DIR WITHIN_DIR   (heldout.py's OUT_DIRs, 0 and 1)

Per run: the mean φ (deg) and ρ (px) of each (depth, l) group of the training taps and the
held-out taps, as the model trained on the training taps computes them; the lateral GP's
length scales and log marginal likelihood; and its reading (mm) over φ = 124 … 145° at
θ_PC23 = 0."""

import sys
from pathlib import Path

import numpy as np

from twin.runs.record import load_run
from twin.runs.training import train_from_run

for label, out in zip(("whole nodes", "within nodes"), sys.argv[1:3], strict=True):
    train, heldout = load_run(Path(out) / "taps_rectangle"), load_run(Path(out) / "taps_heldout")
    model = train_from_run(train, "pca", 0)
    print(f"== {label}: mean φ (deg) / ρ (px) by depth (mm) and l (mm)")
    for name, run in (("train", train), ("held", heldout)):
        v = model.spherical(run.pins_px)
        lateral, depth = run.label("lateral_mm"), run.label("depth_mm")
        for d in sorted(set(depth.tolist())):
            cells = []
            for lat in sorted(set(lateral.tolist()), reverse=True):
                at = (lateral == lat) & (depth == d)
                cells.append(f"{lat:+.0f}: {np.degrees(v[at, 2]).mean():5.1f}/{v[at, 0].mean():5.1f}")
            print(f"{name} {d:.1f} mm  " + "  ".join(cells))
    gp = model._gps["lat"]
    print(f"lateral GP: {gp.kernel_}  log marginal likelihood {gp.log_marginal_likelihood_value_:.1f}")
    phi = np.radians(np.arange(124.0, 146.0, 1.0))
    reading = gp.predict(np.column_stack([np.ones_like(phi), np.zeros_like(phi), phi]))
    print("reading over φ 124…145°: " + " ".join(f"{r:.2f}" for r in reading))
