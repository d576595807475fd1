"""How much of the taps' PC2 and PC3 is a uniform shift of all the pins (the share of each
component's energy in a rigid shift, twin.analysis.edge_imprint.translation_share): the
part of the plane a slide's uniform drag lands in. Over the paper's taps (all 18 angles)
the PCs are fitted without taking the frames' shifts out (tap_pcs).
usage: python plane_uniform_share.py NAME=TAP_RUN...  (e.g. "sway 0=sway_0/runs/taps_rectangle")"""

import sys

from twin.analysis.edge_imprint import tap_pcs, translation_share
from twin.runs.record import load_run

print("taps                                 PC1/PC2/PC3, %     uniform share of PC2 / PC3, %")
for named in sys.argv[1:]:
    name, path = named.split("=", 1)
    pcs = tap_pcs(load_run(path))
    explained = "/".join(f"{100 * e:.1f}" for e in pcs.explained)
    shares = " / ".join(f"{100 * translation_share(pcs.components[i]):.1f}" for i in pcs.pair)
    print(f"{name:36s} {explained:18s} {shares}")
