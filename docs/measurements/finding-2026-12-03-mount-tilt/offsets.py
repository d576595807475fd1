"""Per lateral bin, on the taps a replay shares with the recording, each run in its own PCs:
the mean frame's offset in PC2–PC3 from a turn about the centre (deg;
twin.analysis.edge_imprint.pressed_offset_deg), how far a 1 mm slide along the edge turns
θ_PC23 (deg/mm), and that slide's drag in the plane along the angle term's direction
(px/mm). usage: offsets.py RECORDED REPLAY [REPLAY...]"""

import sys

import numpy as np

from twin.analysis.edge_imprint import along_edge_turn_sheared, sheared_fits, tap_pcs
from twin.runs.pairing import shared_taps
from twin.runs.record import Run, load_run


def figures(run: Run) -> dict[float, dict[str, float]]:
    fits = sheared_fits(run)
    pcs = tap_pcs(run, fits)
    out = along_edge_turn_sheared(run, pcs, fits)
    for f in fits:
        ahead = pcs.field_in_plane(f.gradients["theta_deg"])
        out[f.lateral_mm]["drag_along_theta_px"] = float(
            pcs.field_in_plane(f.gradients["slide_along_mm"]) @ ahead / np.linalg.norm(ahead)
        )
    return out


recorded = load_run(sys.argv[1])
for path in sys.argv[2:]:
    replay = load_run(path)
    pairs = shared_taps(recorded, replay)
    a, b = recorded.subset([i for i, _ in pairs]), replay.subset([j for _, j in pairs])
    print(f"== {path.rstrip('/').split('/')[-1]}: {len(pairs)} shared taps")
    fa, fb = figures(a), figures(b)
    ls = sorted(set(fa) & set(fb))
    print("l, mm                       " + " ".join(f"{l:+5.0f}" for l in ls))
    for name, f in (("recorded", fa), ("replay", fb)):
        print(f"{name:9s} offset, deg       " + " ".join(f"{f[l]['offset_deg']:+5.0f}" for l in ls))
        print(f"{name:9s} θ_PC23 °/mm       " + " ".join(f"{f[l]['pc23_deg_per_mm']:5.1f}" for l in ls))
        print(f"{name:9s} drag along θ px/mm" + " ".join(f"{abs(f[l]['drag_along_theta_px']):5.2f}" for l in ls))
