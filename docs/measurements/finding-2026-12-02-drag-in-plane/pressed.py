"""PCA + GP and the raw-pin GP on the along-edge slides' unslid first samples (pressed) and
the later ones (sliding), RMS orientation error (deg), with the models `twin evaluate` wrote.

    python pressed.py EVAL_DIR SLIDES_RUN
"""

import sys
from pathlib import Path

import numpy as np

from twin.runs.record import load_run
from twin.sensing.perception import PerceptionModel, angle_error_deg

m = PerceptionModel.load(Path(sys.argv[1]) / "model_pca.npz")
b = PerceptionModel.load(Path(sys.argv[1]) / "model_baseline.npz")
s = load_run(Path(sys.argv[2]))
d, k, th = s.label("direction_deg"), s.label("sample_in_slide"), s.label("theta_deg")
for dd in (90, 270):
    for name, mm in (("pressed", (d == dd) & (k == 0)), ("sliding", (d == dd) & (k > 0))):
        out = []
        for lab, model in (("PCA+GP", m), ("baseline", b)):
            p = model.predict(s.pins_px[mm], resolution=s.resolution)
            e = angle_error_deg(p.theta_deg, th[mm])
            out.append(f"{lab} {np.sqrt(np.mean(e**2)):5.1f}")
        print(dd, name, mm.sum(), "  ".join(out))
