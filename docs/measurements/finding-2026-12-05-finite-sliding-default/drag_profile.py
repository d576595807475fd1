"""The along-edge slides' drag (direction 90°, l = −6 mm) sample by sample, and its part in
the taps' PC2–PC3 plane, from run.sh's runs (kept in runs/ until removed).

    python drag_profile.py FOLDER ...   # folders holding runs/taps_rectangle and runs/slides_rectangle

For each sample of the slides (mean over their edge angles): how far the sensor has slid
(mm), the drag's RMS over the pins (px), its norm in the PC2–PC3 plane of the taps' PCA
(px), that norm's share of the drag's squared norm, and the norm there of its rigid part
(every pin moved by the drag's mean)."""

import json
import sys

import numpy as np
from sklearn.decomposition import PCA


def samples(run: str) -> list[dict]:
    with open(f"{run}/samples.jsonl") as lines:
        return [json.loads(line) for line in lines]


if __name__ == "__main__":
    for folder in sys.argv[1:]:
        taps = [s for s in samples(f"{folder}/runs/taps_rectangle") if not s["labels"].get("no_contact")]
        plane = PCA(3).fit(np.array([np.ravel(s["pins_px"]) for s in taps])).components_[1:3]
        slides: dict[float, list] = {}
        for s in samples(f"{folder}/runs/slides_rectangle"):
            labels = s["labels"]
            if labels["lateral_mm"] == -6 and labels["direction_deg"] == 90.0:
                slides.setdefault(labels["theta_deg"], []).append(s)
        rows: dict[int, list] = {}
        for slide in slides.values():
            slide.sort(key=lambda s: s["labels"]["sample_in_slide"])
            first, start = np.ravel(slide[0]["pins_px"]), np.array(slide[0]["pose"][:2])
            for s in slide:
                drag = np.ravel(s["pins_px"]) - first
                rigid = np.tile(drag.reshape(-1, 2).mean(axis=0), len(drag) // 2)
                in_plane = np.linalg.norm(plane @ drag)
                share = in_plane**2 / max(float(drag @ drag), 1e-12)
                rows.setdefault(s["labels"]["sample_in_slide"], []).append(
                    (
                        np.linalg.norm(np.array(s["pose"][:2]) - start),
                        np.sqrt(drag @ drag / (len(drag) // 2)),
                        in_plane,
                        share,
                        np.linalg.norm(plane @ rigid),
                    )
                )
        print(folder)
        for k in sorted(rows)[1:]:
            slid, rms, in_plane, share, rigid = np.mean(rows[k], axis=0)
            print(
                f"  slid {slid:5.2f} mm: drag {rms:6.2f} px RMS, {in_plane:6.2f} px in PC2–PC3 "
                f"({100 * share:.2f} % of its square), its rigid part's {rigid:6.2f} px there"
            )
