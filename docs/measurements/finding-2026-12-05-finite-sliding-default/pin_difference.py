"""Sample by sample, how far two replays of the same taps put the pins.

    python pin_difference.py RUN_A RUN_B   # two `twin run --taps-from` outputs of one set

Prints, for RUN_B against RUN_A, the median and 95th percentile over the taps of each
tap's RMS pin difference (px), the largest single pin's, and the median RMS pin motion from
rest of RUN_A, for scale.
"""

import json
import sys

import numpy as np


def pins(run: str) -> dict[int, np.ndarray]:
    """Each sample's tracked pins (127, 2) px, by sample index."""
    with open(f"{run}/samples.jsonl") as lines:
        return {s["index"]: np.array(s["pins_px"], float) for s in map(json.loads, lines)}


if __name__ == "__main__":
    a, b = pins(sys.argv[1]), pins(sys.argv[2])
    apart = np.array([np.linalg.norm(a[k] - b[k], axis=1) for k in sorted(a) if k in b])
    rms = np.sqrt((apart**2).mean(axis=1))
    moved = np.sqrt(np.array([(np.linalg.norm(a[k] - a[0], axis=1) ** 2).mean() for k in sorted(a)]))
    print(
        f"{sys.argv[2]} against {sys.argv[1]}: per-tap RMS pin difference median {np.median(rms):.3f} px, "
        f"95 % {np.percentile(rms, 95):.3f} px, largest pin {apart.max():.3f} px; "
        f"pins' RMS motion from rest median {np.median(moved):.2f} px"
    )
