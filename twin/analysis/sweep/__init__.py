"""Fidelity sweep: what accuracy costs in time (`twin bench sweep`, part of `twin bench`).

One job a module: the settings (knobs), what each runs and measures (probe), the
timing pass (timing), the Pareto fronts (fronts) and the sweep itself (measure); its
files and table: twin.tools.sweep_report.

For each *setting* (one knob turned away from the default scenario: dome resolution, time
step, settle tolerance, render resolution, anti-aliasing, each effect on or off) the same
*probe* runs in one process, through `SimEnvironment` directly (no recording, no disk I/O,
so the stage timings are the simulation's own):

1. a reduced tap set on the rectangle's straight edge (the paper's §III-A2 protocol at
   fewer orientations): trains the paper's PCA + GP model (twin.sensing.perception);
2. a reduced multi-directional slide set (§III-C: the same orientations, 4 directions,
   8 samples per slide): the pins of these frames give the **pin error**, and the model
   trained in 1. predicts θ̂ and l̂ on them: the **perception error**;
3. closed-loop contour following of the rectangle (§III-D) with that model: the
   **contour error**. The loop is `twin.runs.contour_run.run_contour`'s, step for step, without
   the recorder (so no PNG writing lands in the timings); the metrics are computed by
   `twin.runs.contour_metrics.contour_metrics` itself.

Figures per setting (units in the column names; the CSV's columns:
twin.tools.sweep_report.CSV_COLUMNS):

* time per frame (ms), split into physics (`env.move_to` into the frame: move +
  settle), render (`env.observe`: the frame, or the projection without `render`),
  tracking (`PinReader.read`) and perception (one single-frame
  `PerceptionModel.predict`); the sum is `total_ms`. CPU ms of one process (all its
  threads). Physics, render and tracking come from the **timing pass** (`time_settings`):
  after the parallel accuracy jobs, every setting replays the slide probe's first
  orientations alone on the machine, in rounds (each round every setting once), best of
  TIMING_REPEATS rounds; timed inside the parallel jobs instead, physics-identical
  settings spread over 12–18 ms. Each setting's time against the default's, best against
  best and the range of the ratio within one round, is in the `*_x_default` columns. Perception
  (≈ 1 ms, the same model size for every setting) is the accuracy job's mean. The
  accuracy jobs' wall-clock figures (every slide and contour frame, contention included)
  are in the `*_wall_ms` columns. Resets, lifts between slides and the tap probe are not
  timed.
* pin error (px RMS over all pins and slide frames, at 640×480 — pins of other
  resolutions are rescaled as `PerceptionModel` does): the setting's pins as the
  pipeline sees them (tracked from frames when rendering, projected otherwise) against
  the **reference setting's true pins** at the same commanded poses. Split into the
  physics part (the setting's true pins vs the reference's) and the tracking part (the
  setting's tracked pins vs its own true pins).
* settling error (px RMS over all pins and slide frames, at 640×480): the setting's true
  pins against the pins it was settling towards, settled on to convergence at the same
  frame (`SensorPhysics.converged_pins`; not timed, and the simulation then continues as
  if it had not happened). The pin error cannot see what a settle tolerance costs: ≈ 4 px
  of it is the coarse grid's discretisation, which hides the tenths of a px a settle
  tolerance leaves (docs/accuracy-cost.md). Not measured (None) without contact.
* perception error on the slide probe: orientation RMS (deg, wrapped) and lateral RMS
  (mm) of the PCA + GP model trained on the setting's own tap probe.
* contour error on the rectangle: mean distance of the sensor path from the contour
  (mm), the contour's orientation RMS (deg), steps and how the run ended (loop closed,
  step limit, lost the contour, or out of the arm's reach: run_contour's stop rules).

The reference setting is the `reference` fidelity level with projected pins (no render:
exact pins, so its pin error is 0 by construction). The compliant dome's settings
(`compliant_*`, twin.world.dome.compliant) are measured against their own reference,
`compliant_reference`: the two models' pins are not one another's truth, so pin errors
are compared within a dome model only, while the θ and contour fronts (errors against
the true orientation and the true contour) place both models together. The plain
solid without the skin (`compliant_plain_solid`) changes the material itself, so it has
no pin error; its time, θ and contour figures are placed as any other's.
**Pareto front** (primary): a setting is on it when no *peer* setting dominates it, i.e.
is no slower and no worse in every physics-accuracy figure (pin error *and* settling
error, `PRIMARY`) and better beyond the noise margins in time or in one of them
(`dominates`; in time, round by round of the timing pass: a setting that is faster in
one round and slower in another is neither); the θ and contour fronts weigh one figure
each against time. The contour
front places only the runs that complete the contour (`contour_completed_mm`): one that
loses it is no alternative, however fast.
Peers (`peers`) produce the same output from the same sensor:
* settings that render camera frames (and so exercise the tracker, as the real sensor
  does) are compared with each other, and settings with projected pins with each other.
  Projected pins skip the tracker and so always look "more accurate" than rendered ones,
  but rendering is there to exercise the tracker on camera frames, not to be accurate;
* rendered settings are compared only at the same camera resolution. The resolution is the
  simulated camera's spec (the real TacTip's is 640×480, and sim-vs-real comparisons and
  models trained on one run on the other need the same one), not a fidelity choice: a
  320×240 twin is faster because it simulates a different camera. The sweep still
  measures it, to show what a cheaper camera would cost in tracking error.
`on_front_all` ignores both splits.

A setting that fails (PhysicsError, LostPinsError, …) is reported with its error and
stage, counted in every output, and makes the command exit 1; the others still run.
"""
