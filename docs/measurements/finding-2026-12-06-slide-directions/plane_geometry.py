"""Where the paper's slides move a frame in the taps' PC2-PC3 plane, by slide direction:
round the plane (turning theta_PC23) or along its radius (changing only its length).

    python plane_geometry.py [LABEL=]FOLDER ...   # FOLDER/runs/{slides_rectangle,taps3,eval/model_pca.npz}

For each slide sample: its point q in the PC2-PC3 plane (the evaluation's model, about its
origin) and the point q0 of a static 3 mm tap at the same l and theta (taps3: the shipped
taps at 3 mm, the slides' depth). The drag d = q - q0 is split along q0 (radial) and across
it (round), and into the part of the pins' shift that is rigid (every pin moved by the mean
shift) and the rest. Printed per direction and On/Off (the sensor's middle on the object,
l <= 0): RMS over samples of |q0| and of each part (px), and the RMS theta_PC23 change (deg).
"""

import sys

import numpy as np

from twin.runs.record import load_run
from twin.sensing.perception import PerceptionModel


def still_at(by_theta, theta, lateral):
    """The 3 mm taps at theta, interpolated linearly in l (mm) between the shipped positions."""
    rows = sorted(by_theta[theta], key=lambda r: r[0])
    ls = np.array([r[0] for r in rows])
    flat = np.array([r[1].ravel() for r in rows])
    return np.array([np.interp(lateral, ls, flat[:, j]) for j in range(flat.shape[1])]).reshape(-1, 2)


def rms(x):
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


if __name__ == "__main__":
    for given in sys.argv[1:]:
        label, _, folder = given.rpartition("=")
        model = PerceptionModel.load(f"{folder}/runs/eval/model_pca.npz")
        by_theta = {}
        for s in load_run(f"{folder}/runs/taps3").samples:
            lab = s["labels"]
            by_theta.setdefault(round(lab["theta_deg"] % 360, 3), []).append(
                (lab["lateral_mm"], np.array(s["pins_px"]))
            )

        rows = {}
        for s in load_run(f"{folder}/runs/slides_rectangle").samples:
            lab = s["labels"]
            if lab.get("no_contact") or lab["lateral_mm"] > 6.0:
                continue
            pins, still = (
                np.array(s["pins_px"]),
                still_at(by_theta, round(lab["theta_deg"] % 360, 3), lab["lateral_mm"]),
            )
            shift = pins - still
            rigid = still + shift.mean(axis=0)
            q, q0, qr = (model.pc23_px(p[None])[0] for p in (pins, still, rigid))
            e = q0 / np.linalg.norm(q0)
            e_round = np.array([-e[1], e[0]])
            d, dr = q - q0, qr - q0
            turn = np.degrees(np.arctan2(q0[0] * q[1] - q0[1] * q[0], q0 @ q))
            on = "On" if lab["lateral_mm"] <= 0 else "Off"
            rows.setdefault((lab["direction_deg"], on), []).append(
                (np.linalg.norm(q0), d @ e, d @ e_round, dr @ e, dr @ e_round, turn, np.linalg.norm(shift.mean(axis=0)))
            )
        print(label or folder)
        print(
            "  direction  on/off   n  |q0| px   drag radial / round px   rigid part radial / round px   theta turn deg  mean shift px"
        )
        for (direction, on), r in sorted(rows.items()):
            r = np.array(r)
            print(
                f"  {direction:5.0f}°   {on:>3} {len(r):4d}  {rms(r[:, 0]):6.2f}   {rms(r[:, 1]):8.2f} / {rms(r[:, 2]):6.2f}"
                f"          {rms(r[:, 3]):8.2f} / {rms(r[:, 4]):6.2f}              {rms(r[:, 5]):6.1f}   {rms(r[:, 6]):6.2f}"
            )
