"""Which predicts the recorded frames' edge-frame shift best: a constant, one per lateral bin,
the depth, or the contact force (the twin's, from its still replay of the same taps)? Each
model with edge_frame_shift.py's image-fixed d0 and slide terms; rss in px².
usage: shift_by_force.py RECORDED STILL_REPLAY"""

import sys

import numpy as np
from edge_frame_shift import fit, frames, lateral_bins

from twin.runs.record import load_run

recorded, replay = load_run(sys.argv[1]), load_run(sys.argv[2])
_, shift, c, s, labels = frames(recorded)
index = {int(t): i for i, t in enumerate(replay.label("tap"))}
force = np.array([replay.samples[index[int(t)]]["truth"]["contact_force_n"] for t in labels["tap"]])
one = np.ones(len(c))
bins, names = lateral_bins(labels)
lateral = labels["lateral_mm"]
print(
    "contact force by l (N):", " ".join(f"{b:+d}: {force[np.abs(lateral - b) <= 0.5].mean():.2f}" for b in range(-5, 6))
)
print("constant      ", fit(shift, c, s, labels, [one], ["1"]))
print("per lateral   ", fit(shift, c, s, labels, bins, names))
print("depth (/mm)   ", fit(shift, c, s, labels, [labels["depth_mm"]], ["d"]))
print("force (/N)    ", fit(shift, c, s, labels, [force], ["F"]))
print("constant+force", fit(shift, c, s, labels, [one, force], ["1", "F"]))
print("per lateral+F ", fit(shift, c, s, labels, bins + [force], names + ["F"], show=["F"]))
