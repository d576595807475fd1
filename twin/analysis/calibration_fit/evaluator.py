"""A calibration's model of the recorded pins: physics candidates simulated in parallel
(cached), the camera solved by least squares for each, the whitened residuals (the pins',
then the edge figures' where weighted), χ² and the pin RMS (px)."""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from twin.analysis.calibration_fit.data import GROUPS, Data
from twin.analysis.calibration_fit.figures import EdgeFigureTarget
from twin.analysis.calibration_fit.settings import CAMERA
from twin.analysis.calibration_fit.space import Space
from twin.core.errors import PhysicsError, UserError
from twin.core.resources import searching
from twin.core.scenario import Scenario
from twin.core.sensor import N_PINS
from twin.runs.parallel import WorkerPool
from twin.runs.replay import replay_batch


@dataclass(frozen=True)
class FailedSimulation:
    """A candidate the physics could not simulate (its PhysicsError's message)."""

    message: str


def _replay_candidate(scenario: Scenario, seed: int, batch: list) -> list | FailedSimulation:
    """`replay_batch` for one candidate of the search: the dome matrices it computes are
    cached as a search's (twin.core.resources.searching), apart from the models users run.
    A candidate whose simulation fails its physics checks (a deep tap past the contact
    force limit) comes back as a FailedSimulation: the search counts it infeasible and
    records why, instead of the whole calibration ending on one of its candidates."""
    with searching():
        try:
            return replay_batch(scenario, seed, batch)
        except PhysicsError as err:
            return FailedSimulation(str(err))


class Evaluator:
    """Simulates physics candidates (in parallel, on one pool kept for the whole
    calibration) and solves the camera for each."""

    def __init__(self, space: Space, data: Data, pool: WorkerPool) -> None:
        self.space, self.data, self.pool = space, data, pool
        self.simulations = 0
        #: candidates whose simulation failed its physics checks: {"values", "error"}
        self.failures: list[dict] = []
        self.sim_seconds = 0.0
        self._cache: dict[tuple, np.ndarray] = {}
        self.cache_size = 32
        #: parallel slots to fill: the local workers, or (with a Ray cluster) --workers as its CPU count
        self.parallelism = pool.workers
        #: N: the recorded samples; simulated tips hold theirs first, then any still replay's
        self.n_recorded = len(data.pins)
        self.valid = np.isfinite(data.pins).all(axis=2)  # (N, 127)
        #: the pins in the residual vector: found, in a frame of non-zero weight
        self.weighed = self.valid & (data.weights > 0)[:, None]
        settings = space.settings
        weight = settings.weights.edge_figures
        #: the edge figures' target where they are weighted (sheared-tap runs only), else None
        self.figures = (
            EdgeFigureTarget.of(
                data.records,
                data.run_index,
                weight,
                settings.edge_figure_resamples,
                settings.optimiser.seed,
                [data.still_rows(r) for r in range(len(data.records))],
                settings.edge_signal_shift == "apart",
                settings.edge_theta_plane == "recorded",
                settings.edge_figure_bins == "pooled",
            )
            if weight > 0
            else None
        )
        #: the cluster of each entry of the residual vector: the sample of each pin's x and y,
        #: then one of its own for each edge figure
        self.row_sample = np.repeat(np.nonzero(self.weighed)[0], 2)
        if self.figures is not None:
            self.row_sample = np.concatenate([self.row_sample, len(data.pins) + np.arange(self.figures.n_residuals)])
        self.rest = data.group == GROUPS.index("rest")
        self.fit_rest = space.settings.rest_pins and bool(self.rest.any())
        #: rest offsets (127, 2) px to use instead of the closed form (held-out runs: the fit's layout)
        self.fixed_offsets: np.ndarray | None = None
        #: camera parameters fitted to the no-contact frames again at every camera (`tie`); none: off
        self.tied: list[str] = []
        self._tie_start: dict[str, float] = {}
        self._tie_prior_about: dict[str, float] = {}
        self._tie_cache: dict[tuple, dict[str, float]] = {}

    def simulate(self, candidates: list[dict[str, float]]) -> list[np.ndarray | None]:
        """Pin tips (N, 127, 3) m for each physics candidate, in recorded-sample order, then
        those of the still replays where the data has them (`Data.still_rows`; a
        candidate simulated before is not simulated again); None for one whose simulation
        failed its physics checks (recorded in `failures`). A candidate is read for the
        physics parameters the dome model has (`Space.modelled`), at their defaults where
        it does not name them; anything else in it is ignored."""
        full = [{n: c.get(n, self.space.defaults[n]) for n in self.space.modelled} for c in candidates]
        keys = [tuple((n, round(v, 12)) for n, v in c.items()) for c in full]
        todo = list(dict.fromkeys(k for k in keys if k not in self._cache))
        if todo:
            for k, tips in zip(todo, self._simulate([dict(k) for k in todo])):
                self._cache[k] = tips
                while len(self._cache) > self.cache_size:
                    self._cache.pop(next(iter(self._cache)))
        return [self._cache[k] for k in keys]

    def _simulate(self, candidates: list[dict[str, float]]) -> list[np.ndarray | None]:
        t0 = time.perf_counter()
        seed = self.space.scenario.seed
        scenarios = [self.space.physics_scenario(c) for c in candidates]
        # one job per candidate and batch of chunks: as few environments built as keep every worker busy
        moves = [m for _, m in self.data.chunks]
        n_batches = max(1, min(len(moves), -(-self.parallelism // len(candidates))))
        batches = [moves[b::n_batches] for b in range(n_batches)]
        jobs = [(s, seed, batch) for s in scenarios for batch in batches]
        # an interrupted generation is not kept (the checkpoint holds whole ones): no waiting for its running jobs
        results = list(self.pool.map_ordered(_replay_candidate, jobs, keep_running=False))
        out: list[np.ndarray | None] = []
        for c in range(len(candidates)):
            done = results[c * n_batches : (c + 1) * n_batches]
            failed = [d for d in done if isinstance(d, FailedSimulation)]
            if failed:
                self.failures.append({"values": candidates[c], "error": failed[0].message})
                out.append(None)
                continue
            in_order = [done[i % n_batches][i // n_batches] for i in range(len(moves))]
            per_run: dict[int, list] = {}
            for (r, _), (_, pins) in zip(self.data.chunks, in_order):
                per_run.setdefault(r, []).append(pins)
            out.append(np.concatenate([np.concatenate(per_run[r])[idx] for r, idx in enumerate(self.data.sim_index)]))
        self.simulations += len(candidates)
        self.sim_seconds += time.perf_counter() - t0
        return out

    def tie(self, names: list[str], start: dict[str, float], prior_about: dict[str, float]) -> None:
        """From now on, fit the camera parameters `names` to the no-contact frames again for
        every camera the predictions use (settings camera_tied_to_rest): from `start`, their
        priors about `prior_about` (the twin's values, as for the camera start)."""
        self.tied = list(names)
        self._tie_start = {n: start[n] for n in names}
        self._tie_prior_about = {n: prior_about[n] for n in names}
        self._tie_cache.clear()

    def camera_values(self, tips: np.ndarray, values: dict[str, float]) -> dict[str, float]:
        """`values` with the tied camera parameters (`tie`) fitted to the no-contact frames'
        pins for the other camera parameters' values and these tips; `values` when none are tied."""
        if not self.tied:
            return values
        full = {**self.space.defaults, **values}
        rest_tips = np.ascontiguousarray(tips[: self.n_recorded][self.rest])
        key = (
            tuple(round(full[n], 12) for n in CAMERA if n not in self.tied),
            hashlib.blake2b(rest_tips.tobytes(), digest_size=16).hexdigest(),
        )
        if key not in self._tie_cache:
            start = {**full, **self._tie_start}
            fitted = self.solve_rest_camera(tips, self.tied, start, prior_about=self._tie_prior_about)["values"]
            if len(self._tie_cache) >= 256:
                self._tie_cache.pop(next(iter(self._tie_cache)))
            self._tie_cache[key] = fitted
        return {**values, **self._tie_cache[key]}

    def predict(self, tips: np.ndarray, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """(predicted pins (N, 127, 2) px, rest offsets (127, 2) px) for pin tips and values
        (the rows of `simulate`'s tips: still replays' after the N recorded samples'); tied
        camera parameters (`tie`) fitted to the no-contact frames for the camera in `values`."""
        values = self.camera_values(tips, values)
        camera = self.space.calibration(values).camera_model(self.space.scenario.camera_model().nominal())
        proj = camera.project_tool_points(tips.reshape(-1, 3)).reshape(tips.shape[0], N_PINS, 2)
        offsets = np.zeros((N_PINS, 2))
        if self.fixed_offsets is not None:
            offsets = self.fixed_offsets
        elif self.fit_rest:
            w = (self.data.weights[self.rest][:, None] * self.valid[self.rest])[..., None]
            diff = np.nan_to_num(self.data.pins[self.rest] - proj[: self.n_recorded][self.rest])
            offsets = (w * diff).sum(axis=0) / np.maximum(w.sum(axis=0), 1e-12)
        else:
            base = self.space.scenario.calibration()
            if base is not None:
                offsets = base.rest_offsets_px(self.space.scenario.sensor.camera.width)
        return proj + offsets, offsets

    def residuals(
        self, tips: np.ndarray, values: dict[str, float], priors: bool = True, figures: bool = True
    ) -> np.ndarray:
        """Whitened residual vector: √w (recorded − predicted) / noise_px of the weighed pins,
        then (`figures`, where weighted) the edge figures' misses, then (`priors`) the priors."""
        pred, _ = self.predict(tips, values)
        recorded = pred[: self.n_recorded]
        r = (self.data.pins - recorded) * (np.sqrt(self.data.weights)[:, None, None] / self.space.settings.noise_px)
        blocks = [r[self.weighed].ravel()]
        if figures and self.figures is not None:
            blocks.append(self.figures.residuals(pred))
        if priors:
            blocks.append(self.space.prior_residuals(values))
        return np.concatenate(blocks)

    def figure_table(self, tips: np.ndarray, values: dict[str, float]) -> list[dict] | None:
        """The edge figures, recorded and twin, with their misses (None where not weighted)."""
        return None if self.figures is None else self.figures.table(self.predict(tips, values)[0])

    def solve_camera(self, tips: np.ndarray, physics: dict[str, float], start: dict[str, float]) -> dict[str, float]:
        """The physics values plus the least-squares camera values for these pin tips."""
        names = self.space.camera
        if not names:
            return dict(physics)

        # the pins alone (the figures, a second of analysis each, would make every least-squares step one);
        # the objective then takes the figures at the camera solved here
        def fun(unit: np.ndarray) -> np.ndarray:
            return self.residuals(tips, {**physics, **self.space.from_unit(names, unit)}, figures=False)

        x0 = np.clip(self.space.to_unit(names, start), 0.0, 1.0)
        sol = least_squares(fun, x0, bounds=(0.0, 1.0), x_scale="jac", diff_step=1e-6, xtol=1e-10, ftol=1e-10)
        return {**physics, **self.space.from_unit(names, sol.x)}

    def solve_rest_camera(
        self, tips: np.ndarray, names: list[str], values: dict[str, float], prior_about: dict[str, float] | None = None
    ) -> dict:
        """The camera parameters `names` fitted to the no-contact frames' pins as the pin lattice
        projected, without rest offsets (least squares within their bounds, from `values`):
        a start for a camera unlike the twin's, which the rest offsets (≤ 50 px) cannot absorb.
        The parameters' priors (settings prior_std, about `prior_about`, else `values`) apply: a dome's pins at rest
        are met nearly as well by a near camera as by a far one with a strong radial
        distortion, and a prior on the distortion settles it. Returns {"values", "std" (Gauss–Newton, s² from the fit), "rms_px" (Euclidean per pin)}."""
        pins, valid = self.data.pins[self.rest], self.valid[self.rest]
        w = np.sqrt(self.data.weights[self.rest])[:, None, None] / self.space.settings.noise_px
        space = self.space

        def diff(unit: np.ndarray) -> np.ndarray:
            camera = space.calibration({**values, **space.from_unit(names, unit)}).camera_model(
                space.scenario.camera_model().nominal()
            )
            return pins - camera.project_tool_points(tips[: self.n_recorded][self.rest].reshape(-1, 3)).reshape(
                pins.shape
            )

        about = values if prior_about is None else prior_about
        priors = [(n, about[n], space.settings.parameters[n].prior_std) for n in names]
        priors = [(n, v, std) for n, v, std in priors if std]

        def fun(unit: np.ndarray) -> np.ndarray:
            fitted = space.from_unit(names, unit)
            prior = [(fitted[n] - v) / std for n, v, std in priors]
            return np.concatenate([(diff(unit) * w)[valid].ravel(), prior])

        x0 = np.clip(space.to_unit(names, values), 0.0, 1.0)
        sol = least_squares(fun, x0, bounds=(0.0, 1.0), x_scale="jac", diff_step=1e-6, xtol=1e-12, ftol=1e-12)
        r = sol.fun[: sol.fun.size - len(priors)]
        s2 = float(r @ r) / max(1, r.size - len(names))
        cov = np.linalg.pinv(sol.jac.T @ sol.jac) * s2
        return {
            "values": space.from_unit(names, sol.x),
            "std": {n: float(np.sqrt(max(cov[i, i], 0.0)) * space.range[n]) for i, n in enumerate(names)},
            "at_bound": [n for n, v in space.from_unit(names, sol.x).items() if space.at_bound(n, v)],
            "rms_px": float(np.sqrt(np.mean(np.sum(diff(sol.x)[valid] ** 2, axis=1)))),
        }

    def simulate_one(self, values: dict[str, float], what: str) -> np.ndarray:
        """`simulate` of one candidate that must succeed (the twin as given, the fitted
        point): UserError naming `what` and the physics error otherwise."""
        tips = self.simulate([values])[0]
        if tips is None:
            raise UserError(f"{what} cannot be simulated on these runs: {self.failures[-1]['error']}")
        return tips

    def chi2(self, tips: np.ndarray, values: dict[str, float]) -> float:
        return float(np.sum(self.residuals(tips, values) ** 2))

    def rms(self, tips: np.ndarray, values: dict[str, float]) -> dict:
        """Pin RMS (px, Euclidean per pin) overall, per group and per run."""
        pred, _ = self.predict(tips, values)
        pred = pred[: self.n_recorded]
        err2 = np.sum((self.data.pins - pred) ** 2, axis=2)

        def rms(mask: np.ndarray) -> float | None:
            e = err2[mask][self.valid[mask]]
            return float(np.sqrt(e.mean())) if e.size else None

        all_ = np.ones(len(err2), bool)
        return {
            "overall": rms(all_),
            "groups": {g: rms(self.data.group == k) for k, g in enumerate(GROUPS) if (self.data.group == k).any()},
            "runs": {str(p): rms(self.data.run_index == r) for r, p in enumerate(self.data.runs)},
            "per_pin": np.sqrt(np.nanmean(np.where(self.valid, err2, np.nan), axis=0)).tolist(),
            "mean_residual": np.nanmean(
                np.where(self.valid[..., None], self.data.pins - pred, np.nan), axis=0
            ).tolist(),
        }
