"""Per replay, on the taps both it and the recording kept: the angle between its PC2–PC3
plane and the recording's, each plane's energy by ring of pins, and θ_PC23's turn per mm of
slide along the edge over the recording's, read in the replay's own plane and in the
recording's (twin.analysis.edge_imprint.turn_in_reference_plane).

    python planes.py REAL_RUN REPLAY_RUN [REPLAY_RUN ...]
"""

import sys

import numpy as np

from twin.analysis.comparison import taps_both_kept
from twin.analysis.edge_imprint import (
    along_edge_turn_sheared,
    pin_rings,
    plane_angle_deg,
    tap_pcs,
    turn_in_reference_plane,
)
from twin.runs.record import load_run


def plane_by_ring(pcs, rings: np.ndarray) -> np.ndarray:
    """The PC2–PC3 pair's energy (of 2) in each ring of pins."""
    energy = np.sum(pcs.components[list(pcs.pair)].reshape(2, -1, 2) ** 2, axis=(0, 2))
    return np.array([energy[rings == k].sum() for k in range(rings.max() + 1)])


recording = load_run(sys.argv[1])
for path in sys.argv[2:]:
    replay = load_run(path)
    shared = taps_both_kept(recording, replay)
    real, twin = recording.subset([i for i, _ in shared]), replay.subset([j for _, j in shared])
    real_pcs, twin_pcs = tap_pcs(real), tap_pcs(twin)
    rings = pin_rings(real.rest_pins_px)
    real_turn = {l: v["pc23_deg_per_mm"] for l, v in along_edge_turn_sheared(real, real_pcs).items()}
    own_turn = {l: v["pc23_deg_per_mm"] for l, v in along_edge_turn_sheared(twin, twin_pcs).items()}
    in_real = turn_in_reference_plane(real, twin)
    laterals = sorted(real_turn, reverse=True)
    print(f"{path.rstrip('/').split('/')[-1]}: {len(shared) - 1} taps both kept")
    print(
        f"  PCs explained, %: recording {np.round(100 * real_pcs.explained, 1)}, replay {np.round(100 * twin_pcs.explained, 1)}"
    )
    print(f"  the planes lie {plane_angle_deg(real_pcs, twin_pcs):.1f} deg apart (check: {in_real['angle_deg']:.1f})")
    print(
        "  plane's energy by ring (centre → rim), recording:",
        " ".join(f"{v:.2f}" for v in plane_by_ring(real_pcs, rings)),
    )
    print(
        "                                         replay:   ",
        " ".join(f"{v:.2f}" for v in plane_by_ring(twin_pcs, rings)),
    )
    print("  l, mm:                                 ", " ".join(f"{l:+5.0f}" for l in laterals))
    print("  θ_PC23 per mm, recording:              ", " ".join(f"{real_turn[l]:5.2f}" for l in laterals))
    print("  replay / recording, in its own plane:  ", " ".join(f"{own_turn[l] / real_turn[l]:5.2f}" for l in laterals))
    print(
        "  replay / recording, in the recording's:",
        " ".join(f"{in_real['pc23_deg_per_mm'][l] / real_turn[l]:5.2f}" for l in laterals),
    )
