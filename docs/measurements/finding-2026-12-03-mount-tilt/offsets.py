"""Per lateral bin, on the taps a replay shares with the recording: the mean frame's offset in
PC2–PC3 from a turn about the centre (deg; twin.analysis.edge_imprint.pressed_offset_deg) and
how far a 1 mm slide along the edge turns θ_PC23 (deg/mm), each run in its own PCs.
usage: offsets.py RECORDED REPLAY [REPLAY...]"""

import sys

from twin.analysis.edge_imprint import along_edge_turn_sheared
from twin.runs.pairing import shared_taps
from twin.runs.record import Run, load_run


def figures(run: Run) -> dict[float, dict[str, float]]:
    return along_edge_turn_sheared(run)


recorded = load_run(sys.argv[1])
for path in sys.argv[2:]:
    replay = load_run(path)
    pairs = shared_taps(recorded, replay)
    a = Run(recorded.path, recorded.meta, [recorded.samples[i] for i, _ in pairs])
    b = Run(replay.path, replay.meta, [replay.samples[j] for _, j in pairs])
    print(f"== {path.rstrip('/').split('/')[-1]}: {len(pairs)} shared taps")
    fa, fb = figures(a), figures(b)
    ls = sorted(set(fa) & set(fb))
    print("l, mm                  " + " ".join(f"{l:+5.0f}" for l in ls))
    for name, f in (("recorded", fa), ("replay", fb)):
        print(f"{name:9s} offset, deg  " + " ".join(f"{f[l]['offset_deg']:+5.0f}" for l in ls))
        print(f"{name:9s} θ_PC23 °/mm  " + " ".join(f"{f[l]['pc23_deg_per_mm']:5.1f}" for l in ls))
