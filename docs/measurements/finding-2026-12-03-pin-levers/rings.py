"""Per replay, on the taps both it and the recording kept: the angle between its PC2–PC3
plane and the recording's, and for each plane, by ring of pins (centre → rim), the pair's
energy (of 2) and the share of it that moves the pins radially in the image (along each
pin's direction from the grid's centre; the rest moves them round it). Where the edge's
orientation pair outweighs the press (two of the first three PCs explain nearly the same
and more than the third), the pair is read as those two and the line says so: the
paper's PC2–PC3 is then the pair's one half and the press. Last, θ's turn per mm of slide
along the edge over the recording's, each read in its own pair, l = +5 … −5.

    python rings.py REAL_RUN REPLAY_RUN [REPLAY_RUN ...]
"""

import sys
from dataclasses import replace

import numpy as np

from twin.analysis.comparison import taps_both_kept
from twin.analysis.edge_imprint import (
    TapPCs,
    along_edge_turn_sheared,
    pin_rings,
    plane_angle_deg,
    rotating_pair,
    tap_pcs,
)
from twin.runs.record import load_run


def by_ring(pcs: TapPCs, rest_px: np.ndarray, rings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pair's energy in each ring, and the radial share of it (NaN for the centre
    pin, which has no direction from the centre)."""
    pair = pcs.components[list(pcs.pair)].reshape(2, -1, 2)
    outward = rest_px - rest_px.mean(axis=0)
    distance = np.linalg.norm(outward, axis=1, keepdims=True)
    outward = np.where(distance > 1.0, outward / np.maximum(distance, 1e-9), np.nan)
    radial = np.sum(np.einsum("kpi,pi->kp", pair, outward) ** 2, axis=0)
    total = np.sum(pair**2, axis=(0, 2))
    energy = np.array([total[rings == k].sum() for k in range(rings.max() + 1)])
    share = np.array([radial[rings == k].sum() if k else np.nan for k in range(rings.max() + 1)]) / energy
    return energy, share


recording = load_run(sys.argv[1])
rings = pin_rings(recording.rest_pins_px)
for path in sys.argv[2:]:
    replay = load_run(path)
    shared = taps_both_kept(recording, replay)
    real, twin = recording.subset([i for i, _ in shared]), replay.subset([j for _, j in shared])
    real_pcs, twin_pcs = (replace(p, pair=rotating_pair(p.explained)) for p in (tap_pcs(real), tap_pcs(twin)))
    pairs = f"the pairs: PC{real_pcs.pair[0] + 1}–PC{real_pcs.pair[1] + 1} and PC{twin_pcs.pair[0] + 1}–PC{twin_pcs.pair[1] + 1}"
    print(
        f"{path.rstrip('/').split('/')[-1]}: {len(shared) - 1} taps both kept; the planes lie "
        f"{plane_angle_deg(real_pcs, twin_pcs):.1f} deg apart ({pairs})"
    )
    for name, pcs, run in (("recording", real_pcs, real), ("replay", twin_pcs, twin)):
        energy, share = by_ring(pcs, run.rest_pins_px, rings)
        print(f"  {name:9s} energy by ring:", " ".join(f"{v:.2f}" for v in energy))
        print(f"  {name:9s} radial share: ", " ".join("  — " if np.isnan(v) else f"{v:.2f}" for v in share))
    real_turn = {l: v["pc23_deg_per_mm"] for l, v in along_edge_turn_sheared(real, real_pcs).items()}
    own_turn = {l: v["pc23_deg_per_mm"] for l, v in along_edge_turn_sheared(twin, twin_pcs).items()}
    laterals = sorted(real_turn, reverse=True)
    print("  θ turn per mm, replay / recording:", " ".join(f"{own_turn[l] / real_turn[l]:.2f}" for l in laterals))
