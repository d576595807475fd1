"""How far a replay's pins are from a recording's, frame by frame: the RMS over the usable
frames' pins of the difference of their displacements from each run's own rest frame (px),
the same less each frame's mean difference, the correlation of the two displacement fields,
and the image direction of the edge's normal at θ = 0 (deg; twin.analysis.edge_imprint.
edge_normal_in_image). usage: pin_misfit.py RECORDED N REPLAY [REPLAY...]  (the first N samples);
pin_misfit.py RECORDED every:K REPLAY [REPLAY...] for replays of every K-th tap (`twin run …
--every-nth-tap K`): the recording's no-contact frame and taps 1, 1 + K, … beside the
replay's samples in order."""

import sys

import numpy as np

from twin.analysis.edge_imprint import edge_normal_in_image, usable
from twin.runs.record import Run, load_run

recorded = load_run(sys.argv[1])
every = int(sys.argv[2].removeprefix("every:")) if sys.argv[2].startswith("every:") else None
first = None if every else int(sys.argv[2])
kept = recorded.samples[:1] + recorded.samples[1::every] if every else recorded.samples[:first]
recorded = Run(recorded.path, recorded.meta, kept)
print(f"{'recorded':28s} edge normal {edge_normal_in_image(recorded)[0]:7.1f}°")
for path in sys.argv[3:]:
    replay = load_run(path)
    replay = Run(replay.path, replay.meta, replay.samples[:first])
    if len(replay.samples) != len(recorded.samples):
        sys.exit(f"{path}: {len(replay.samples)} samples against the recording's {len(recorded.samples)}")
    ok = usable(recorded) & usable(replay)
    a = recorded.pins_px[ok] - recorded.rest_pins_px
    b = replay.pins_px[ok] - replay.rest_pins_px
    d = a - b
    rms = np.sqrt(np.mean(np.sum(d**2, axis=2)))
    rms_shape = np.sqrt(np.mean(np.sum((d - d.mean(axis=1, keepdims=True)) ** 2, axis=2)))
    corr = np.sum(a * b) / np.sqrt(np.sum(a * a) * np.sum(b * b))
    print(
        f"{path.rstrip('/').split('/')[-1][:28]:28s} edge normal {edge_normal_in_image(replay)[0]:7.1f}°, "
        f"{ok.sum()} frames: misfit {rms:.3f} px, less each frame's mean {rms_shape:.3f} px, correlation {corr:.3f}"
    )
