"""The edge figures as a calibration's second objective: on sheared-tap runs, the figures the
twin's replayed pins give (twin.analysis.edge_imprint), frame for frame the recorded ones,
against the recorded runs' own, each miss over its tolerance.

The figures, per lateral bin l (mm) of each run:

* signal: the edge's orientation signal over its value at l = 0 (figure 1); a miss is
  the difference over SIGNAL_TOLERANCE (0.1);
* theta_pc23: how far a 1 mm slide along the edge turns θ_PC23 (deg/mm, figure 3), the
  twin's read in its own taps' PC2–PC3 or (settings `edge_theta_plane: recorded`) in the
  recorded run's, carried onto the twin's rest pins (edge_imprint.carried_pcs);
* theta_pc23_across: the same for a 1 mm slide across the edge (edge_imprint.
  across_edge_turn_sheared): onto the object the real drag turns θ_PC23 three to eight
  times as far across the edge as along it, and a fit to the along-edge turn alone can
  meet it by a drag that turns neither (docs/real-sensor.md, 2026-12-04, eighth);
* drag/signal: the fitted slide and twist terms' spread over the angle term's (figure 3);
* shift (settings `edge_signal_shift: apart`): the share of the signal that is a rigid shift
  of the pins (edge_imprint.signal_shift_share), a miss its difference over
  SHIFT_TOLERANCE (0.1); the signal ratios are then those of the signal without it.

The last three span decades across l, so their miss is the log of the ratio over
log(FACTOR_TOLERANCE) (a third either way), below a floor that keeps a vanishing figure finite.
A recorded figure is itself an estimate: over 1,000 of the DigiTac set's taps the signal
ratio 4 mm off the object reads 1.06 to 1.45 by which fifth is taken. So each miss is over
the tolerance and the recorded figure's spread together, √(tolerance² + spread²), the
spread its standard deviation over bootstrap resamples of the run's frames (seeded).
The twin's figures come from the same frames as the recorded ones (a frame whose recorded
pins were not all found is left out of both). With settings `edge_signal: still` the twin's
signal onto the object (l < 0) comes from the same taps replayed without their slides and
twists: there its sheared signal is buried in the slides' scatter (±0.26 of the ratio at
l = −4 with 500 taps a bin, the still one ±0.02) and the two agree within it. Off the
object the sheared one is kept: it is precise there (±0.04–0.06 px with 400 taps a bin),
and the slides raise it above the still one by 0.16–0.23 px at l = +1 … +5, so a still
figure there would not be the real's kind (docs/real-sensor.md, 2026-11-29). Onto the
object the real signal is partly a rigid shift of the pins that turns with the edge
(19–62 % of it at l = −5 … −3) and the twin's unslid imprint has next to none, which the
whole signal ratio counts as signal; `apart` weighs the imprint's pattern and that shift as
two figures (docs/real-sensor.md, "The imprint's rigid shift, and the signal without it")."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.analysis.edge_imprint import (
    BinFit,
    TapPCs,
    across_edge_turn_sheared,
    along_edge_turn_sheared,
    carried_pcs,
    drag_over_signal,
    is_sheared,
    sheared_fits,
    signal_profile,
    signal_shift_share,
    tap_pcs,
    turn_in_reference_plane,
    usable,
)
from twin.core.errors import UserError
from twin.core.scenario import SHEARED_TAP_MOTION
from twin.runs.record import Run

SIGNAL_TOLERANCE = 0.1
SHIFT_TOLERANCE = 0.1
#: the figures whose miss is their difference (the others': the log of their ratio)
LINEAR = {"signal": SIGNAL_TOLERANCE, "shift": SHIFT_TOLERANCE}
FACTOR_TOLERANCE = 4.0 / 3.0
#: figure -> the value below which it counts as this floor (its unit)
FLOORS = {"theta_pc23": 0.1, "theta_pc23_across": 0.1, "drag/signal": 0.1}
#: the miss of a figure the recorded run has and the twin's does not (in tolerances)
MISSING_MISS = 10.0

Figures = dict[tuple[str, float], float]


#: the figures θ_PC23 is read for, in a run's own taps' PC2–PC3 plane or another run's
THETA_FIGURES = ("theta_pc23", "theta_pc23_across")
#: each θ figure's turns {l: deg/mm} in edge_imprint.turn_in_reference_plane
THETA_TURN_KEYS = dict(zip(THETA_FIGURES, ("pc23_deg_per_mm", "across_pc23_deg_per_mm")))


def figure_values(
    run: Run, shift_apart: bool = False, pcs: TapPCs | None = None, fits: list[BinFit] | None = None
) -> Figures:
    """{(figure, l): value} of a sheared-tap run (module docstring); l = 0's signal, 1 by
    definition, is left out. `shift_apart`: the signal without its rigid shift, and the
    shift's share as figures of their own. `pcs`: the PCs θ_PC23 is read in (the run's
    own where None). `fits`: the run's `sheared_fits`, where the caller has them."""
    fits = sheared_fits(run) if fits is None else fits
    values = _imprint_values(run, shift_apart, fits)
    values.update({("drag/signal", l): v["ratio"] for l, v in drag_over_signal(run, fits).items()})
    if fits and pcs is None:
        pcs = tap_pcs(run, fits)
    values.update(_theta_values(run, pcs, fits))
    return _finite(values)


def _theta_values(run: Run, pcs: TapPCs | None, fits: list[BinFit]) -> Figures:
    """The θ_PC23 figures (THETA_FIGURES) of a sheared-tap run read in `pcs`."""
    values: Figures = {}
    for figure, turns in zip(
        THETA_FIGURES, (along_edge_turn_sheared(run, pcs, fits), across_edge_turn_sheared(run, pcs, fits))
    ):
        values.update({(figure, l): v["pc23_deg_per_mm"] for l, v in turns.items()})
    return values


@dataclass
class PairedFigures:
    """Two runs of the same taps read for a comparison: A's figures, B's, B's θ_PC23 turns
    read in A's taps' PC2–PC3 plane carried onto B's rest pins (edge_imprint.carried_pcs),
    as a calibration reads a twin's against a recording's with `edge_theta_plane:
    recorded`, and the angle between the two planes (deg; None where a run has no usable
    tap to take a plane from)."""

    a: Figures
    b: Figures
    b_in_a_plane: Figures
    plane_angle_deg: float | None


def paired_figures(a: Run, b: Run) -> PairedFigures:
    """`PairedFigures` of runs `a` and `b`, each run's fits and PCs taken once."""
    fits_a, fits_b = sheared_fits(a), sheared_fits(b)
    pcs_a = tap_pcs(a, fits_a) if usable(a).any() else None
    pcs_b = tap_pcs(b, fits_b) if usable(b).any() else None
    in_a_plane, angle = {}, None
    if pcs_a is not None and pcs_b is not None:
        read = turn_in_reference_plane(a, b, pcs_a, pcs_b, fits_b)
        in_a_plane = _finite({(f, l): v for f, key in THETA_TURN_KEYS.items() for l, v in read[key].items()})
        angle = read["angle_deg"]
    return PairedFigures(
        figure_values(a, pcs=pcs_a, fits=fits_a), figure_values(b, pcs=pcs_b, fits=fits_b), in_a_plane, angle
    )


def _finite(values: Figures) -> Figures:
    """The figures a run has: a NaN one (e.g. drag / signal in a bin whose signal is within
    its noise, a shift share without energy) is a figure it lacks, not a miss of NaN."""
    return {k: v for k, v in values.items() if math.isfinite(v)}


def _imprint_values(run: Run, shift_apart: bool, fits: list[BinFit] | None = None) -> Figures:
    """The figures of the imprint alone (LINEAR: the signal ratios, and the shift's share
    with `shift_apart`), which a replay without slides has too; `fits` the run's
    `sheared_fits`, where the caller has them."""
    fits = sheared_fits(run) if fits is None else fits
    values: Figures = {}
    for row in signal_profile(run, without_shift=shift_apart, fits=fits).values():
        values.update({("signal", l): v for l, v in row.items() if l != 0.0})
    if shift_apart:
        for row in signal_shift_share(run, fits).values():
            values.update({("shift", l): v for l, v in row.items()})
    return _finite(values)


def _scale(figure: str, value: float) -> float:
    """The figure in the units its miss is counted in: the ratio itself, or the log of the floored value."""
    return value if figure in LINEAR else math.log(max(value, FLOORS[figure]))


def _tolerance(figure: str) -> float:
    return LINEAR.get(figure, math.log(FACTOR_TOLERANCE))


def difference(figure: str, a: float, b: float) -> float:
    """B's value of a figure less A's, in its miss's units: the difference of the signal
    ratios and shares, the log of B / A (each floored at FLOORS) for the others."""
    return _scale(figure, b) - _scale(figure, a)


def miss(figure: str, twin: float | None, recorded: float, spread: float = 0.0) -> float:
    """The twin's miss of one recorded figure over √(tolerance² + spread²), `spread` the
    recorded figure's in the miss's units (signed: + = the twin's is larger)."""
    if twin is None or not math.isfinite(twin):
        return MISSING_MISS
    return difference(figure, recorded, twin) / math.hypot(_tolerance(figure), spread)


#: the sides of the edge a figure's bins are pooled over (l in mm): onto the object, off it
SIDES = {"onto": lambda l: l < 0, "off": lambda l: l >= 0}


def side_groups(rows: list[dict], *keys: str) -> dict[tuple, list[dict]]:
    """`rows` (each with "lateral_mm") grouped by their values of `keys` and the side of the
    edge (SIDES) their bin lies on: {(values…, side): rows in their order}, sorted by the
    values, the sides in SIDES' order."""
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        side = next(name for name, on_side in SIDES.items() if on_side(row["lateral_mm"]))
        groups.setdefault((*(row[k] for k in keys), side), []).append(row)
    sides = list(SIDES)
    return dict(sorted(groups.items(), key=lambda item: (item[0][:-1], sides.index(item[0][-1]))))


def pooled_difference(figure: str, a: list[float], b: list[float], spread: list[float]) -> dict:
    """B's figure less A's (in its miss's units: `difference`) over several lateral bins,
    each weighted by the inverse square of its `spread` (> 0, the miss's units): "difference"
    (the weighted mean), "statistical_error" (1 / √Σw), "error" (that times Birge's ratio
    √(χ² / dof) where the bins scatter about the mean more than their spreads allow),
    "chi2_per_dof" and "bins"."""
    d = np.array([difference(figure, x, y) for x, y in zip(a, b)])
    w = np.asarray(spread, dtype=float) ** -2
    mean = float(np.sum(w * d) / np.sum(w))
    chi2_per_dof = float(np.sum(w * (d - mean) ** 2) / (len(d) - 1)) if len(d) > 1 else 0.0
    statistical = float(1.0 / np.sqrt(np.sum(w)))
    return {
        "difference": mean,
        "statistical_error": statistical,
        "error": statistical * math.sqrt(max(chi2_per_dof, 1.0)),
        "chi2_per_dof": chi2_per_dof,
        "bins": len(d),
    }


def _unscale(figure: str, value: float) -> float:
    """A figure's value from its miss's units (`_scale`'s inverse above the floor)."""
    return value if figure in LINEAR else math.exp(value)


def pooled_rows(rows: list[dict]) -> list[dict]:
    """`EdgeFigureTarget.table`'s rows pooled per run, figure and side of the edge (SIDES):
    the twin's miss of the recorded figure's weighted mean over the side's bins, each bin
    weighted by the inverse square of its recorded spread. The miss is the pooled
    difference over √(tolerance² + its statistical error²), without Birge's ratio: that
    would grow as the twin's bins scatter and shrink the miss of a twin that scatters. A
    bin the twin lacks is left out of its side; a side it lacks entirely misses by
    MISSING_MISS. Rows: run, figure, side, lateral_mm (None), recorded and twin (the
    weighted means, in the figure's unit), spread (the statistical error), bins, miss and
    miss_tolerance (over the tolerance alone)."""
    out = []
    for (run, figure, side), bins in side_groups(rows, "run", "figure").items():
        both = [r for r in bins if r["twin"] is not None and math.isfinite(r["twin"])]
        weighed = both or bins
        w = np.array([r["spread"] for r in weighed]) ** -2
        mean = float(np.sum(w * [_scale(figure, r["recorded"]) for r in weighed]) / w.sum())
        row = {"run": run, "figure": figure, "side": side, "lateral_mm": None, "recorded": _unscale(figure, mean)}
        if not both:
            row.update(spread=float(w.sum() ** -0.5), bins=0, twin=None)
            out.append(row | {"miss": MISSING_MISS, "miss_tolerance": MISSING_MISS})
            continue
        pooled = pooled_difference(
            figure, [r["recorded"] for r in both], [r["twin"] for r in both], [r["spread"] for r in both]
        )
        error, d = pooled["statistical_error"], pooled["difference"]
        row.update(spread=error, bins=len(both), twin=_unscale(figure, mean + d))
        row.update(miss=d / math.hypot(_tolerance(figure), error), miss_tolerance=d / _tolerance(figure))
        out.append(row)
    return out


def figure_spread(
    run: Run, resamples: int, seed: int, values: Figures | None = None, shift_apart: bool = False
) -> Figures:
    """Each figure's standard deviation (in its miss's units) over `resamples` bootstrap
    resamples of the run's frames (its no-contact frames kept); 0 for every figure when
    `resamples` is 0, and for a figure that some resample lacks, the spread of those that have it.
    `values`: the run's own figures (`figure_values`, with `shift_apart`), where the caller has them."""
    values = figure_values(run, shift_apart) if values is None else values
    if resamples == 0:
        return dict.fromkeys(values, 0.0)
    drawn: dict[tuple[str, float], list[float]] = {k: [] for k in values}
    for (resampled,) in _resampled([run], resamples, seed):
        for k, v in figure_values(resampled, shift_apart).items():
            if k in drawn:
                drawn[k].append(_scale(k[0], v))
    return {k: float(np.std(v)) if len(v) > 1 else 0.0 for k, v in drawn.items()}


def paired_figure_spread(
    a: Run, b: Run, resamples: int, seed: int, paired: PairedFigures | None = None
) -> tuple[Figures, Figures]:
    """The standard deviation (in each figure's miss's units) of b's figure less a's over
    `resamples` bootstrap resamples of their taps, the same taps drawn for both: `a` and
    `b` hold the same taps in the same order (a recording and its replay on the taps they
    share, twin.runs.pairing.shared_taps), so what the draw of taps does to both figures
    alike drops out of the difference. Two dicts: b's own figures, and b's θ_PC23 turns
    read in each resample's plane of a's (`PairedFigures.b_in_a_plane`). Only figures both
    runs have; 0 for each when `resamples` is 0. `paired`: `paired_figures(a, b)`, where
    the caller has it."""
    paired = paired_figures(a, b) if paired is None else paired
    keys = (set(paired.a) & set(paired.b), set(paired.a) & set(paired.b_in_a_plane))
    if resamples == 0:
        return dict.fromkeys(keys[0], 0.0), dict.fromkeys(keys[1], 0.0)
    drawn: tuple[dict, dict] = ({k: [] for k in keys[0]}, {k: [] for k in keys[1]})
    for ra, rb in _resampled([a, b], resamples, seed):
        p = paired_figures(ra, rb)
        for read, draws in zip((p.b, p.b_in_a_plane), drawn):
            for k, values in draws.items():
                if k in p.a and k in read:
                    values.append(difference(k[0], p.a[k], read[k]))
    own, in_a_plane = ({k: float(np.std(v)) if len(v) > 1 else 0.0 for k, v in d.items()} for d in drawn)
    return own, in_a_plane


def _resampled(runs: list[Run], resamples: int, seed: int):
    """`resamples` times, the runs (the same taps in the same order) with their taps drawn
    with replacement, the same draw for each run; no-contact frames kept (seeded)."""
    split = [
        (
            [s for s in run.samples if s["labels"].get("no_contact")],
            [s for s in run.samples if not s["labels"].get("no_contact")],
        )
        for run in runs
    ]
    n = len(split[0][1])
    if any(len(taps) != n for _, taps in split):
        raise ValueError(f"resampling runs together needs the same taps in each: {[len(t) for _, t in split]}")
    rng = np.random.default_rng(seed)
    for _ in range(resamples):
        pick = rng.integers(0, n, n)
        yield [Run(run.path, run.meta, rest + [taps[i] for i in pick]) for run, (rest, taps) in zip(runs, split)]


@dataclass
class EdgeFigureTarget:
    """The recorded runs' edge figures and the rows of a calibration's data that hold each run."""

    records: list[Run]
    rows: list[np.ndarray]  # per run: its samples' rows in the calibration data
    recorded: list[Figures]
    spread: list[Figures]  # per run: each recorded figure's bootstrap spread (its miss's units)
    weight: float
    still_rows: list[np.ndarray | None]  # per run: the rows of its still replay in the pins given, or None
    shift_apart: bool = False  # the signal without its rigid shift, and the shift as a figure (settings)
    #: per run, its taps' PCs, which the twin's θ_PC23 turn is read in (settings edge_theta_plane:
    #: recorded), or None: the twin's own
    recorded_pcs: list[TapPCs] | None = None
    #: the misses of each figure pooled over either side of the edge (`pooled_rows`; settings
    #: edge_figure_bins: pooled) rather than one per lateral bin
    pooled: bool = False

    @classmethod
    def of(
        cls,
        records: list[Run],
        run_index: np.ndarray,
        weight: float,
        resamples: int,
        seed: int,
        still_rows: list[np.ndarray | None] | None = None,
        shift_apart: bool = False,
        theta_in_recorded_plane: bool = False,
        pooled: bool = False,
    ) -> EdgeFigureTarget:
        """The recorded figures and their spread over `resamples` bootstrap resamples (seeded);
        UserError naming a run that is not sheared taps or has no lateral bin to compare.
        `still_rows`: per run, where its still replay's pins are (the twin's signal then
        comes from them). `shift_apart`: settings edge_signal_shift is apart;
        `theta_in_recorded_plane`: settings edge_theta_plane is recorded; `pooled`: settings
        edge_figure_bins is pooled (each recorded figure's spread must then be above 0)."""
        recorded = []
        for run in records:
            if not is_sheared(run):
                kind = run.meta["scenario"]["protocol"]["kind"]
                raise UserError(
                    f"{run.path}: calibration settings field 'weights.edge_figures' needs sheared-tap runs "
                    f"(twin import-lab, or a sheared_taps protocol); this run's protocol is {kind!r}"
                )
            figures = figure_values(run, shift_apart)
            if not any(f == "signal" for f, _ in figures):
                raise UserError(
                    f"{run.path}: too few usable taps for the edge figures (a lateral bin needs 20 frames with every "
                    "pin found, and l = 0 must have one); set weights.edge_figures: 0 or record more taps"
                )
            recorded.append(figures)
        rows = [np.nonzero(run_index == r)[0] for r in range(len(records))]
        spread = [
            figure_spread(run, resamples, seed + r, figures, shift_apart)
            for r, (run, figures) in enumerate(zip(records, recorded))
        ]
        still = still_rows or [None] * len(records)
        pcs = [tap_pcs(run) for run in records] if theta_in_recorded_plane else None
        if pooled and any(v <= 0 for figures in spread for v in figures.values()):
            raise UserError(
                "calibration settings field 'edge_figure_bins: pooled' weighs each lateral bin by its recorded "
                "figure's bootstrap spread, and some spread is 0; set edge_figure_resamples to 2 or more"
            )
        return cls(records, rows, recorded, spread, weight, still, shift_apart, pcs, pooled)

    @property
    def n_residuals(self) -> int:
        """How many misses `residuals` returns: one per recorded figure and lateral bin, or
        (pooled) one per recorded figure and side of the edge."""
        if not self.pooled:
            return sum(len(f) for f in self.recorded)
        return sum(
            len({(figure, side) for figure, l in f for side, on_side in SIDES.items() if on_side(l)})
            for f in self.recorded
        )

    def simulated_runs(self, pins_px: np.ndarray, still: bool = False) -> list[Run | None]:
        """Each recorded run with its pins replaced by those of `pins_px` (px) at its rows,
        its rest pins by their mean over its no-contact frames. `still`: its still replay
        instead, the slide and twist labels 0 (None for a run without one)."""
        runs: list[Run | None] = []
        for run, rows, still_rows in zip(self.records, self.rows, self.still_rows):
            if still and still_rows is None:
                runs.append(None)
                continue
            pins = pins_px[still_rows if still else rows]
            samples = [
                {
                    **s,
                    "pins_px": p,
                    "labels": {k: 0.0 if still and k in SHEARED_TAP_MOTION else v for k, v in s["labels"].items()},
                }
                for s, p in zip(run.samples, pins)
            ]
            rest = [k for k, s in enumerate(run.samples) if s["labels"].get("no_contact")]
            meta = {**run.meta, "rest_pins_px": pins[rest].mean(axis=0) if rest else run.meta.get("rest_pins_px")}
            runs.append(Run(run.path, meta, samples))
        return runs

    def table(self, pins_px: np.ndarray) -> list[dict]:
        """One row per recorded figure: run, figure, l (mm), recorded, its spread (the miss's
        units), twin, miss (over √(tolerance² + spread²)), miss_tolerance (over the tolerance
        alone); where `pooled`, those rows pooled per figure and side (`pooled_rows`)."""
        out = []
        runs, stills = self.simulated_runs(pins_px), self.simulated_runs(pins_px, still=True)
        for r, (run, still, recorded, spread) in enumerate(zip(runs, stills, self.recorded, self.spread)):
            plane = None if self.recorded_pcs is None else carried_pcs(self.recorded_pcs[r], self.records[r], run)
            twin = figure_values(run, self.shift_apart, plane)
            if still is not None:
                onto = {k: v for k, v in _imprint_values(still, self.shift_apart).items() if k[1] < 0.0}
                twin = {k: v for k, v in twin.items() if not (k[0] in LINEAR and k[1] < 0.0)} | onto
            for (figure, l), value in sorted(recorded.items()):
                simulated = twin.get((figure, l))
                out.append(
                    {
                        "run": r,
                        "figure": figure,
                        "lateral_mm": l,
                        "recorded": value,
                        "spread": spread[figure, l],
                        "twin": simulated,
                        "miss": miss(figure, simulated, value, spread[figure, l]),
                        "miss_tolerance": miss(figure, simulated, value),
                    }
                )
        return pooled_rows(out) if self.pooled else out

    def residuals(self, pins_px: np.ndarray) -> np.ndarray:
        """√weight × each recorded figure's miss (tolerances), in `table`'s order."""
        return np.sqrt(self.weight) * np.array([row["miss"] for row in self.table(pins_px)])
