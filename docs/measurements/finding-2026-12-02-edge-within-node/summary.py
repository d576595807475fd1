"""Each scan's pins against a reference scan's (edge_scan.py): RMS over the pins and the
worst pin, over the 22 frames.

    python summary.py REFERENCE.json SCAN.json ...
"""

import json
import sys

import numpy as np

reference = json.load(open(sys.argv[1]))
for name in sys.argv[2:]:
    scan = json.load(open(name))
    rms, worst = [], []
    for edge, frames in scan.items():
        for frame, ref in zip(frames, reference[edge]):
            distance = np.linalg.norm(np.array(frame) - np.array(ref), axis=1)
            rms.append(np.sqrt(np.mean(distance**2)))
            worst.append(distance.max())
    print(
        f"{name:24s} RMS {min(rms):.2f}-{max(rms):.2f} px (mean {np.mean(rms):.2f}), worst pin {min(worst):.2f}-{max(worst):.2f} px"
    )
