"""Table I's PCA + GP with every frame's uniform shift (its mean pin displacement from the
rest frame) taken out of the taps and the slides before the PCA: what the along-edge cells
read when the drag's rigid shift cannot enter the taps' PC2-PC3 plane.
usage: uniform_shift_out.py TAPS SLIDES   (the repository on PYTHONPATH)"""

import sys

from twin.analysis.edge_imprint import without_uniform_shift
from twin.analysis.evaluation import along_edge_reading, table_i
from twin.runs.record import Run, load_run
from twin.runs.training import train_from_run
from twin.tools.evaluation_report import format_along_edge_reading, format_table


def shifted_out(run: Run) -> Run:
    rest = run.rest_pins_px
    pins = without_uniform_shift(run.pins_px, rest)
    samples = [{**s, "pins_px": p} for s, p in zip(run.samples, pins)]
    return Run(run.path, run.meta, samples)


taps, slides = load_run(sys.argv[1]), load_run(sys.argv[2])
for name, (t, s) in {
    "as recorded": (taps, slides),
    "uniform shift out": (shifted_out(taps), shifted_out(slides)),
}.items():
    model = train_from_run(t, "pca", 0)
    pred = model.predict(s.pins_px, resolution=s.resolution)
    print(name)
    print(format_table(table_i(s, {"PCA + GP": pred.theta_deg}), paper=False))
    print(format_along_edge_reading(along_edge_reading(model, t, s)))
