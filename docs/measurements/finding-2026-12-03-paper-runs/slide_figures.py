"""The along-edge slides (90°, 270°; l = −6 mm) of paper-rig runs, per (taps, slides) pair:

* the drag (the pins' RMS shift from the slide's unslid first sample, px) at each of the
  seven sliding samples (3.9 … 15.9 mm along);
* the first step's figures (`twin.analysis.edge_imprint.along_edge_turn_slides`): raw pins
  and θ_PC23 in degrees of turn per mm, the drag's share of energy in the taps' PC2–PC3
  plane and in a rigid shift, the pressed frames' radius there;
* the pressed and sliding frames' offset in the plane (`twin evaluate`'s reading), with the
  taps' PCA as the paper's (each frame's uniform shift kept) and with each frame's uniform
  shift taken out (taps and slides alike).

    python slide_figures.py TAPS SLIDES [TAPS SLIDES …]
"""

import sys
from pathlib import Path

import numpy as np

from twin.analysis.edge_imprint import along_edge_turn_slides, without_uniform_shift
from twin.analysis.evaluation import _offset_deg, pc23_handedness
from twin.runs.record import load_run
from twin.sensing.perception import pca_fit, pins_to_vectors


def drags(slides, directions, samples=None) -> np.ndarray:
    """(n, 254) px: each slide's sliding frames at `samples` (sample_in_slide; None: all of
    them) less its pressed (first) frame, over the slides in `directions` (deg), every
    orientation."""
    d, k, th = slides.label("direction_deg"), slides.label("sample_in_slide"), slides.label("theta_deg")
    z = pins_to_vectors(slides.pins_px)
    sliding = k > 0 if samples is None else np.isin(k, samples)
    out = []
    for direction in directions:
        for t in np.unique(th):
            pressed = np.flatnonzero((d == direction) & (th == t) & (k == 0))
            if len(pressed) == 1:
                out += [z[b] - z[pressed[0]] for b in np.flatnonzero((d == direction) & (th == t) & sliding)]
    return np.array(out)


def drag_by_sample(slides) -> list[float]:
    """The along-edge drag (RMS over the pins, mean over the slides, px) at each sliding sample."""
    last = int(slides.label("sample_in_slide").max())
    return [
        float(
            np.mean(np.sqrt(np.mean(np.sum(drags(slides, (90, 270), [i]).reshape(-1, 127, 2) ** 2, axis=-1), axis=1)))
        )
        for i in range(1, last + 1)
    ]


def readings(taps, slides, prep) -> dict[str, dict]:
    mean, comps, _ = pca_fit(pins_to_vectors(prep(taps.pins_px, taps.rest_pins_px)), 3)

    def plane(pins):
        return (pins_to_vectors(prep(pins, taps.rest_pins_px)) - mean) @ comps[1:3].T

    sense = pc23_handedness(plane(taps.pins_px), taps.label("theta_deg"))
    d, k, th = slides.label("direction_deg"), slides.label("sample_in_slide"), slides.label("theta_deg")
    out = {}
    for direction in (90, 270):
        for name, m in (("pressed", (d == direction) & (k == 0)), ("sliding", (d == direction) & (k > 0))):
            out[f"{direction}° {name}"] = _offset_deg(plane(slides.pins_px[m]), th[m], sense)
    return out


if __name__ == "__main__":
    args = sys.argv[1:]
    for taps_dir, slides_dir in zip(args[::2], args[1::2]):
        taps, slides = load_run(Path(taps_dir)), load_run(Path(slides_dir))
        print(f"{taps_dir} / {slides_dir}")
        print("  drag by sample, px: " + " ".join(f"{v:.1f}" for v in drag_by_sample(slides)))
        f = along_edge_turn_slides(taps, slides)

        def share(v):  # None where the slides move no pin
            return "—" if v is None else f"{100 * v:.2f} %"

        print(
            f"  first step: raw {f['raw_deg_per_mm']:.1f} °/mm, θ_PC23 {f['pc23_deg_per_mm']:.1f} °/mm,"
            f" in PC2–PC3 {share(f['plane_share'])} of its energy, in a rigid shift {share(f['translation_share'])},"
            f" pressed radius {f['radius_px']:.2f} px"
        )
        for label, prep in (
            ("uniform shift kept", lambda p, rest: p),
            ("uniform shift taken out", without_uniform_shift),
        ):
            r = readings(taps, slides, prep)
            print(
                f"  {label}: "
                + ";  ".join(
                    f"{n} {v['offset_deg']:+.1f}° ± {v['spread_deg']:.1f}, r {v['radius_px']:.2f} px"
                    for n, v in r.items()
                )
            )
