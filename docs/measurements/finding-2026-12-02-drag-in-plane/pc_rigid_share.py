"""The rigid share of a tap run's first three PCs, and its signal's rigid share per depth and l.

python pc_rigid_share.py TAPS_RUN
"""

import sys
from pathlib import Path

import numpy as np

from twin.analysis import edge_imprint as ei
from twin.runs.record import load_run
from twin.sensing.perception import pca_fit, pins_to_vectors

taps = load_run(Path(sys.argv[1]))
ok = ei.usable(taps)
z = pins_to_vectors(taps.pins_px[ok])
mean, comps, expl = pca_fit(z, 3)
print("explained", np.round(expl * 100, 1))
for k in range(3):
    c = comps[k]
    print(f"PC{k + 1} rigid share {ei.translation_share(c) * 100:.1f} %")
sh = ei.signal_shift_share(taps)
for d, row in sh.items():
    print(d, {l: round(v * 100) for l, v in row.items()})
