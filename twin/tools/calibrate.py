"""`twin calibrate`: fit the twin's parameters to recorded runs of one sensor.

    twin calibrate RUN [RUN…] --scenario S --out DIR [--settings F] [--workers N | --cluster ADDR]

The model of a recorded pin (px) in sample i, pin k:

    pin_ik = camera(θ_cam).project(tip_ik(θ_phys)) + rest_k

* tip_ik(θ_phys): the simulated pin tip (tool frame) at the sample's target pose, reached
  along the run's own path (twin.runs.replay), for the physics parameters θ_phys: dome
  material, skin–stimulus friction, TCP offset. Every evaluation re-simulates the runs
  (projected pins, no rendering), in parallel over chunks and candidates.
* camera(θ_cam): intrinsics, distortion, pose in the tool (twin.core.sensor.CameraModel).
* rest_k: the rest layout's offset from the lattice, in closed form: the weighted mean,
  over the no-contact frames (target z ≤ 0 in the work frame), of recorded minus projected
  pins (the least-squares solution for given θ). Without no-contact frames it stays 0 and
  the report says so.

Objective: χ² = Σ w_i |pin_ik − recorded_ik|² / σ² + Σ ((θ − θ_default)/prior_std)², with σ
= settings.noise_px and per-frame weights w by group (rest, contact, sliding). The
expensive, noisy physics parameters are searched by CMA-ES (`cma`; one alone, which pycma
cannot search, by a shrinking grid: BracketSearch); for each candidate the cheap, smooth
camera parameters are solved by least squares (scipy, trust region) — a separable
("variable projection") problem, so the search covers only the few physics dimensions.
Stop rule: the best χ² improved by less than `tol_relative` over `patience` generations
(converged) or `max_generations` reached (not converged: exit 1, best point kept).
Each generation is checkpointed (DIR/checkpoint.pkl, DIR/history.jsonl); a calibration
started again with the same runs, scenario and settings resumes from it.

Uncertainty: J is the Jacobian of the whitened residuals at the optimum (central
differences; physics columns by simulation). Each parameter's standard error is the larger
of the Gauss–Newton s²(JᵀJ)⁻¹ (s² the reduced χ²) and the cluster-robust sandwich with the
samples as clusters (a frame's pins share their errors). A parameter is identifiable from
these runs when that error is below `identifiable_fraction` of its bounds' range, its
whole range moves the pins by more than the fit's pin RMS, and its Jacobian column is not
nearly in the span of the others (variance inflation ≤ `max_variance_inflation`); one that
is not is reported as such, with the reasons, and left at its default in the calibration
file, not silently fitted (_uncertainty says why each test).
"""
from __future__ import annotations

import hashlib
import math
import json
import pickle
import time
from dataclasses import dataclass, field
from pathlib import Path

import cma
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.optimize import least_squares
from tqdm import tqdm

from twin.core.calibration import Calibration, CameraCalibration, write_calibration
from twin.core.errors import TwinError, UserError
from twin.core.resources import asset_path, searching
from twin.core.scenario import Scenario, scenario_from_dict
from twin.core.sensor import N_PINS
from twin.core.validation import read_yaml, validate_mapping
from twin.runs.parallel import WorkerPool
from twin.runs.record import Run, load_run
from twin.runs.replay import replay_batch, replay_chunks
from twin.tools.calibration_report import write_report
from twin.tools.compare import pair_samples
from twin.world.dome.material import dome_material_of
from twin.world.scene import dome_params, load_scenario_stimulus

CAMERA = ("camera.focal_px", "camera.cx_px", "camera.cy_px", "camera.k1", "camera.k2", "camera.p1", "camera.p2",
          "camera.x_mm", "camera.y_mm", "camera.z_mm", "camera.rx_deg", "camera.ry_deg", "camera.rz_deg")
PHYSICS = ("material.young_kpa", "material.poisson", "material.membrane_young_mpa", "material.skin_held_deg",
           "friction", "tcp.x_mm", "tcp.y_mm", "tcp.z_mm")
PARAMETERS = CAMERA + PHYSICS
GROUPS = ("rest", "contact", "sliding")
#: scenario fields a recorded run must share with the calibration scenario
SHARED_FIELDS = ("object", "placement", "work_frame")
RENDER_EFFECTS = {"render", "camera_noise", "lighting"}
SETTINGS_FILE = ("tactip", "calibration_settings.yaml")


class CalibrationNotConverged(TwinError):
    """The stop rule was not met within max_generations (exit 1); best point and history kept."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ParameterSetting(_Strict):
    """One parameter: fitted or not, default (None = the scenario's value), bounds, prior (its unit)."""

    fit: bool = False
    default: float | None = None
    lower: float
    upper: float
    prior_std: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _ordered(self) -> "ParameterSetting":
        if not self.lower < self.upper:
            raise ValueError(f"lower {self.lower} must be below upper {self.upper}")
        return self


# The settings' values live in the shipped file alone (assets/tactip/calibration_settings.yaml,
# which a --settings file is merged over): these models state their types and ranges, not defaults.
class Weights(_Strict):
    rest: float = Field(ge=0)
    contact: float = Field(ge=0)
    sliding: float = Field(ge=0)


class OptimiserSettings(_Strict):
    popsize: int | None = Field(ge=4, le=1000)
    sigma0: float = Field(gt=0, le=1, description="fraction of each parameter's range")
    max_generations: int = Field(ge=1, le=10000)
    tol_relative: float = Field(gt=0, lt=1)
    patience: int = Field(ge=1, le=1000)
    tol_bracket: float = Field(gt=0, lt=1, description="one physics parameter: the bracket's stop width, "
                                                      "fraction of its range")
    seed: int = Field(ge=1)


class CalibrationSettings(_Strict):
    """What `twin calibrate` fits and how (assets/tactip/calibration_settings.yaml)."""

    parameters: dict[str, ParameterSetting]
    rest_pins: bool
    weights: Weights
    noise_px: float = Field(gt=0, le=50)
    identifiable_fraction: float = Field(gt=0, le=10)
    max_variance_inflation: float = Field(ge=1)
    optimiser: OptimiserSettings

    @model_validator(mode="after")
    def _known(self) -> "CalibrationSettings":
        unknown = sorted(set(self.parameters) - set(PARAMETERS))
        if unknown:
            raise ValueError(f"unknown parameters {unknown}; known: {', '.join(PARAMETERS)}")
        return self

    @property
    def fitted(self) -> list[str]:
        return [n for n in PARAMETERS if n in self.parameters and self.parameters[n].fit]


def load_settings(path: Path | None) -> CalibrationSettings:
    """The shipped defaults, with `path`'s entries merged over them (per parameter)."""
    data = read_yaml(asset_path(*SETTINGS_FILE), "calibration settings")
    source = str(asset_path(*SETTINGS_FILE))
    if path is not None:
        user = read_yaml(path, "calibration settings") or {}
        if not isinstance(user, dict):
            raise UserError(f"{path}: calibration settings are a mapping of fields")
        for key, value in user.items():
            if key in ("parameters", "weights", "optimiser") and isinstance(value, dict):
                for name, entry in value.items():
                    old = data.get(key, {}).get(name)
                    data.setdefault(key, {})[name] = {**old, **entry} if isinstance(old, dict) and isinstance(entry, dict) else entry
            else:
                data[key] = value
        source = str(path)
    return validate_mapping(CalibrationSettings, data, source, "calibration settings")


# ---------------------------------------------------------------------------- parameters
def scenario_values(scenario: Scenario) -> dict[str, float]:
    """Every parameter's current value in `scenario` (its camera, dome, stimulus, calibration)."""
    cam = scenario.camera_model()
    k = cam.intrinsics
    calibration = scenario.calibration() or Calibration()
    values = {"camera.focal_px": cam.focal_px, "camera.cx_px": k[0, 2], "camera.cy_px": k[1, 2]}
    values.update(zip(("camera.k1", "camera.k2", "camera.p1", "camera.p2"), cam.distortion))
    values.update(zip(("camera.x_mm", "camera.y_mm", "camera.z_mm"), cam.offset_mm))
    values.update(zip(("camera.rx_deg", "camera.ry_deg", "camera.rz_deg"), cam.rotation_deg))
    values.update({f"material.{n}": v for n, v in dome_material_of(dome_params(scenario)).items()})
    values["friction"] = load_scenario_stimulus(scenario).friction
    values.update(zip(("tcp.x_mm", "tcp.y_mm", "tcp.z_mm"), calibration.tcp_offset_mm))
    return {n: float(v) for n, v in values.items()}


@dataclass
class Space:
    """The fitted parameters, their defaults, bounds and priors; maps values to calibrations."""

    scenario: Scenario
    settings: CalibrationSettings
    defaults: dict[str, float] = field(init=False)

    def __post_init__(self) -> None:
        values = scenario_values(self.scenario)
        self.defaults = {}
        for name in PARAMETERS:
            s = self.settings.parameters.get(name)
            if name not in values:  # a material parameter this dome model does not have
                if s is not None and s.fit:
                    raise UserError(f"calibration settings: field 'parameters.{name}': the {self.scenario.dome} dome "
                                    "has no such parameter; set fit: false")
                self.defaults[name] = math.nan
                continue
            value = values[name] if s is None or s.default is None else s.default
            if s is not None and s.fit and not s.lower <= value <= s.upper:
                raise UserError(f"calibration settings: field 'parameters.{name}': default {value:.6g} lies outside "
                                f"the bounds [{s.lower:g}, {s.upper:g}]")
            self.defaults[name] = float(value)
        #: the physics parameters this scenario's dome model has (the others' defaults are NaN)
        self.modelled = [n for n in PHYSICS if not math.isnan(self.defaults[n])]
        self.fitted = self.settings.fitted
        self.camera = [n for n in self.fitted if n in CAMERA]
        self.physics = [n for n in self.fitted if n in PHYSICS]
        p = self.settings.parameters
        self.lower = {n: p[n].lower for n in self.fitted}
        self.range = {n: p[n].upper - p[n].lower for n in self.fitted}

    def to_unit(self, names: list[str], values: dict[str, float]) -> np.ndarray:
        return np.array([(values[n] - self.lower[n]) / self.range[n] for n in names])

    def from_unit(self, names: list[str], unit: np.ndarray) -> dict[str, float]:
        return {n: float(self.lower[n] + u * self.range[n]) for n, u in zip(names, unit)}

    def prior_residuals(self, values: dict[str, float]) -> np.ndarray:
        p = self.settings.parameters
        return np.array([(values[n] - self.defaults[n]) / p[n].prior_std for n in self.fitted if p[n].prior_std])

    def calibration(self, values: dict[str, float], rest_offsets: np.ndarray | None = None) -> Calibration:
        """The calibration file for `values` (fitted ones; the rest at their defaults)."""
        v = {**self.defaults, **values}
        cam = self.scenario.sensor.camera
        base = self.scenario.calibration() or Calibration()
        camera = CameraCalibration(
            width=cam.width, height=cam.height, focal_px=v["camera.focal_px"],
            principal_point_px=[v["camera.cx_px"], v["camera.cy_px"]],
            distortion={k: v[f"camera.{k}"] for k in ("k1", "k2", "p1", "p2")},
            offset_mm=[v["camera.x_mm"], v["camera.y_mm"], v["camera.z_mm"]],
            rotation_deg=[v["camera.rx_deg"], v["camera.ry_deg"], v["camera.rz_deg"]])
        material = {n.split(".", 1)[1]: v[n] for n in self.modelled if n.startswith("material.")}
        offsets = base.rest_pin_offsets_px if rest_offsets is None else np.round(rest_offsets, 4).tolist()
        return Calibration(camera=camera, rest_pin_offsets_px=offsets, dome_material=material, friction=v["friction"],
                           tcp_offset_mm=[v["tcp.x_mm"], v["tcp.y_mm"], v["tcp.z_mm"]], notes=base.notes)

    def physics_scenario(self, values: dict[str, float]) -> Scenario:
        """The calibration scenario simulating `values`' physics, pins projected (no rendering)."""
        cal = self.calibration(values)
        physics_only = Calibration(dome_material=cal.dome_material, friction=cal.friction, tcp_offset_mm=cal.tcp_offset_mm)
        effects = [e for e in self.scenario.effects if e not in RENDER_EFFECTS]
        sensor = {"camera": self.scenario.sensor.camera.model_dump(), "calibration": physics_only}
        return self.scenario.with_changes(effects=effects, sensor=sensor, backend="sim")


# ---------------------------------------------------------------------------- data
@dataclass
class Data:
    """The recorded pins to fit, paired with the chunks that simulate them."""

    runs: list[Path]
    pins: np.ndarray          # (N, 127, 2) px recorded (NaN where not found)
    group: np.ndarray         # (N,) index into GROUPS
    run_index: np.ndarray     # (N,)
    chunks: list[tuple[int, list]]  # (run number, moves) to simulate
    weights: np.ndarray       # (N,) per-frame weight of its group
    sim_index: list[np.ndarray] = field(default_factory=list)  # per run: recorded sample -> simulated row


def _group(scenario: Scenario, sample: dict) -> int:
    if sample["target"][2] <= 0.0:
        return GROUPS.index("rest")
    return GROUPS.index("sliding" if scenario.protocol.kind in ("slides", "contour") else "contact")


def load_data(run_dirs: list[Path], scenario: Scenario, weights: Weights) -> Data:
    """Read and check the runs against the calibration scenario (UserError naming the run
    and field: another object, placement, work frame or camera; no samples; no pins)."""
    pins, group, run_index, chunks, records = [], [], [], [], []
    cam = scenario.sensor.camera
    for r, path in enumerate(run_dirs):
        run = load_run(path)
        recorded = scenario_from_dict(run.meta["scenario"], str(path / "run.json"))
        for name in SHARED_FIELDS:
            if getattr(recorded, name) != getattr(scenario, name):
                raise UserError(f"{path}: recorded with scenario field '{name}' = {getattr(recorded, name)!r}, but the "
                                f"calibration scenario {scenario.source} has {getattr(scenario, name)!r}: runs of "
                                "different scenarios cannot be fitted together")
        if (recorded.sensor.camera.width, recorded.sensor.camera.height) != (cam.width, cam.height):
            raise UserError(f"{path}: recorded with a {recorded.sensor.camera.width}×{recorded.sensor.camera.height} "
                            f"camera (field 'sensor.camera'), the calibration scenario has {cam.width}×{cam.height}")
        if not run.samples:
            raise UserError(f"{path}: the run has no samples")
        for i, s in enumerate(run.samples):
            if s.get("pins_px") is None:
                raise UserError(f"{path}: sample {i} has no pins (field 'pins_px' is null; frame "
                                f"{s.get('frame')!r}): records without frames or pins cannot be fitted")
        pins.append(run.pins_px)
        group.extend(_group(recorded, s) for s in run.samples)
        run_index.extend([r] * len(run.samples))
        chunks.extend((r, c) for c in replay_chunks(run, recorded))
        records.append(run)
    group = np.array(group)
    data = Data(list(run_dirs), np.concatenate(pins), group, np.array(run_index), chunks,
                np.array([getattr(weights, g) for g in GROUPS])[group])
    # pair each recorded sample with its simulated row by target pose (twin compare's pairing)
    for r, run in enumerate(records):
        targets = [m.pose.as_array() for rr, c in chunks if rr == r for m in c if m.record]
        simulated = Run(run.path, run.meta, [{"target": t} for t in targets])
        pairs = dict(pair_samples(run, simulated))
        missing = [i for i in range(len(run.samples)) if i not in pairs]
        if missing:
            raise UserError(f"{run.path}: samples {missing[:5]} have target poses its protocol does not reach "
                            "(an edited or foreign record)")
        data.sim_index.append(np.array([pairs[i] for i in range(len(run.samples))]))
    return data


# ---------------------------------------------------------------------------- evaluation
def _replay_candidate(scenario: Scenario, seed: int, batch: list) -> list:
    """`replay_batch` for one candidate of the search: the dome matrices it computes are
    cached as a search's (twin.core.resources.searching), apart from the models users run."""
    with searching():
        return replay_batch(scenario, seed, batch)


class Evaluator:
    """Simulates physics candidates (in parallel, on one pool kept for the whole
    calibration) and solves the camera for each."""

    def __init__(self, space: Space, data: Data, pool: WorkerPool) -> None:
        self.space, self.data, self.pool = space, data, pool
        self.simulations = 0
        self.sim_seconds = 0.0
        self._cache: dict[tuple, np.ndarray] = {}
        self.cache_size = 32
        #: parallel slots to fill: the local workers, or (with a Ray cluster) --workers as its CPU count
        self.parallelism = pool.workers
        self.valid = np.isfinite(data.pins).all(axis=2)  # (N, 127)
        #: the sample of each entry of the residual vector (x and y of each valid pin)
        self.row_sample = np.repeat(np.nonzero(self.valid)[0], 2)
        self.rest = data.group == GROUPS.index("rest")
        self.fit_rest = space.settings.rest_pins and bool(self.rest.any())

    def simulate(self, candidates: list[dict[str, float]]) -> list[np.ndarray]:
        """Pin tips (N, 127, 3) m for each physics candidate, in recorded-sample order (a
        candidate simulated before is not simulated again). A candidate is read for the
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

    def _simulate(self, candidates: list[dict[str, float]]) -> list[np.ndarray]:
        t0 = time.perf_counter()
        seed = self.space.scenario.seed
        scenarios = [self.space.physics_scenario(c) for c in candidates]
        # one job per candidate and batch of chunks: as few environments built as keep every worker busy
        moves = [m for _, m in self.data.chunks]
        n_batches = max(1, min(len(moves), -(-self.parallelism // len(candidates))))
        batches = [moves[b::n_batches] for b in range(n_batches)]
        jobs = [(s, seed, batch) for s in scenarios for batch in batches]
        results = list(self.pool.map_ordered(_replay_candidate, jobs))
        out = []
        for c in range(len(candidates)):
            done = results[c * n_batches:(c + 1) * n_batches]
            in_order = [done[i % n_batches][i // n_batches] for i in range(len(moves))]
            per_run: dict[int, list] = {}
            for (r, _), (_, pins) in zip(self.data.chunks, in_order):
                per_run.setdefault(r, []).append(pins)
            out.append(np.concatenate([np.concatenate(per_run[r])[idx] for r, idx in enumerate(self.data.sim_index)]))
        self.simulations += len(candidates)
        self.sim_seconds += time.perf_counter() - t0
        return out

    def predict(self, tips: np.ndarray, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """(predicted pins (N, 127, 2) px, rest offsets (127, 2) px) for pin tips and values."""
        camera = self.space.calibration(values).camera_model(self.space.scenario.camera_model().nominal())
        proj = camera.project_tool_points(tips.reshape(-1, 3)).reshape(tips.shape[0], N_PINS, 2)
        offsets = np.zeros((N_PINS, 2))
        if self.fit_rest:
            w = (self.data.weights[self.rest][:, None] * self.valid[self.rest])[..., None]
            diff = np.nan_to_num(self.data.pins[self.rest] - proj[self.rest])
            offsets = (w * diff).sum(axis=0) / np.maximum(w.sum(axis=0), 1e-12)
        else:
            base = self.space.scenario.calibration()
            if base is not None:
                offsets = base.rest_offsets_px(self.space.scenario.sensor.camera.width)
        return proj + offsets, offsets

    def residuals(self, tips: np.ndarray, values: dict[str, float], priors: bool = True) -> np.ndarray:
        """Whitened residual vector: √w (recorded − predicted) / noise_px, then the priors."""
        pred, _ = self.predict(tips, values)
        r = (self.data.pins - pred) * (np.sqrt(self.data.weights)[:, None, None] / self.space.settings.noise_px)
        r = r[self.valid].ravel()
        return np.concatenate([r, self.space.prior_residuals(values)]) if priors else r

    def solve_camera(self, tips: np.ndarray, physics: dict[str, float], start: dict[str, float]) -> dict[str, float]:
        """The physics values plus the least-squares camera values for these pin tips."""
        names = self.space.camera
        if not names:
            return dict(physics)

        def fun(unit: np.ndarray) -> np.ndarray:
            return self.residuals(tips, {**physics, **self.space.from_unit(names, unit)})

        x0 = np.clip(self.space.to_unit(names, start), 0.0, 1.0)
        sol = least_squares(fun, x0, bounds=(0.0, 1.0), x_scale="jac", diff_step=1e-6, xtol=1e-10, ftol=1e-10)
        return {**physics, **self.space.from_unit(names, sol.x)}

    def chi2(self, tips: np.ndarray, values: dict[str, float]) -> float:
        return float(np.sum(self.residuals(tips, values) ** 2))

    def rms(self, tips: np.ndarray, values: dict[str, float]) -> dict:
        """Pin RMS (px, Euclidean per pin) overall, per group and per run."""
        pred, _ = self.predict(tips, values)
        err2 = np.sum((self.data.pins - pred) ** 2, axis=2)

        def rms(mask: np.ndarray) -> float | None:
            e = err2[mask][self.valid[mask]]
            return float(np.sqrt(e.mean())) if e.size else None

        all_ = np.ones(len(err2), bool)
        return {"overall": rms(all_), "groups": {g: rms(self.data.group == k) for k, g in enumerate(GROUPS)
                                                  if (self.data.group == k).any()},
                "runs": {str(p): rms(self.data.run_index == r) for r, p in enumerate(self.data.runs)},
                "per_pin": np.sqrt(np.nanmean(np.where(self.valid, err2, np.nan), axis=0)).tolist(),
                "mean_residual": np.nanmean(np.where(self.valid[..., None], self.data.pins - pred, np.nan), axis=0).tolist()}


# ---------------------------------------------------------------------------- fit
def _key(runs: list[Path], scenario: Scenario, settings: CalibrationSettings) -> str:
    fixed = settings.model_dump(mode="json")
    fixed["optimiser"].pop("max_generations")  # raising it continues a calibration that ran out of generations
    text = json.dumps([[str(Path(r).resolve()) for r in runs], scenario.model_dump(mode="json"), fixed],
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _save_checkpoint(out: Path, state: dict) -> None:
    tmp = out / "checkpoint.pkl.tmp"
    tmp.write_bytes(pickle.dumps(state))
    tmp.replace(out / "checkpoint.pkl")


class BracketSearch:
    """The search of one physics parameter (unit interval), with CMA-ES's ask / tell / stop.

    Each generation evaluates `points` values evenly spaced inside the bracket, as one
    batch (in parallel); the next bracket spans the best value so far and its two grid
    neighbours, so it shrinks by (points + 1) / 2 per generation. It looks at its whole
    bracket each time, so the small steps in χ² where the skin's lattice gains a node do
    not trap it, and it stops when the bracket is narrower than `tol_unit` of the range."""

    def __init__(self, points: int, start_unit: float, start_value: float, tol_unit: float) -> None:
        self.points, self.tol_unit = points, tol_unit
        self.low, self.high = 0.0, 1.0
        self.best_unit, self.best_value = start_unit, start_value

    @property
    def step(self) -> float:
        """The grid's spacing inside the bracket (unit)."""
        return (self.high - self.low) / (self.points + 1)

    def ask(self) -> list[np.ndarray]:
        return [np.array([self.low + k * self.step]) for k in range(1, self.points + 1)]

    def tell(self, units: list[np.ndarray], values: list[float]) -> None:
        k = int(np.argmin(values))
        if values[k] < self.best_value:
            self.best_unit, self.best_value = float(units[k][0]), float(values[k])
        step = self.step
        self.low, self.high = max(0.0, self.best_unit - step), min(1.0, self.best_unit + step)

    def stop(self) -> dict[str, float]:
        width = self.high - self.low
        return {f"bracket {width:.2g} of the range, below {self.tol_unit:g}": width} if width < self.tol_unit else {}


def _optimise(ev: Evaluator, out: Path, key: str, progress: bool) -> dict:
    """CMA-ES over the physics parameters, or a BracketSearch where there is one (camera
    solved per candidate); returns the state: best values, χ², generations, stop reason,
    converged."""
    space, opt = ev.space, ev.space.settings.optimiser
    names = space.physics
    history_file = out / "history.jsonl"
    checkpoint = out / "checkpoint.pkl"
    if checkpoint.exists():
        state = pickle.loads(checkpoint.read_bytes())
        if state["key"] != key:
            raise UserError(f"{out}: holds a checkpoint of another calibration (other runs, scenario or settings); "
                            "choose another --out")
    else:
        start = {n: space.defaults[n] for n in space.fitted}
        tips = ev.simulate([{n: space.defaults[n] for n in names}])[0]
        best = ev.solve_camera(tips, {n: space.defaults[n] for n in names}, start)
        state = {"key": key, "es": None, "generation": 0, "best": best, "best_chi2": ev.chi2(tips, best),
                 "trace": [], "converged": not names, "stop": "no physics parameters: camera solved by least squares"
                 if not names else None}
        history_file.write_text(json.dumps({"generation": 0, "values": best, "chi2": state["best_chi2"]}) + "\n")
        if names:
            popsize = opt.popsize or 4 + int(3 * np.log(max(len(names), 2)))
            if len(names) == 1:  # pycma does not run in 1-D (CMA-ES/pycma#86, #302)
                state["es"] = BracketSearch(popsize, float(space.to_unit(names, space.defaults)[0]), state["best_chi2"],
                                            opt.tol_bracket)
            else:
                state["es"] = cma.CMAEvolutionStrategy(space.to_unit(names, space.defaults), opt.sigma0, {
                    "bounds": [0.0, 1.0], "popsize": popsize, "seed": opt.seed, "verbose": -9, "tolfun": 0.0,
                    "tolflatfitness": 3})
        _save_checkpoint(out, state)
    es = state["es"]
    bar = tqdm(total=opt.max_generations, initial=state["generation"], desc="calibrate", unit="gen", disable=not progress or es is None)
    while es is not None and not state["converged"] and state["generation"] < opt.max_generations:
        units = es.ask()
        physics = [space.from_unit(names, np.asarray(u)) for u in units]
        tips_all = ev.simulate(physics)
        fitted = [ev.solve_camera(t, p, state["best"]) for t, p in zip(tips_all, physics)]
        chi2 = [ev.chi2(t, v) for t, v in zip(tips_all, fitted)]
        es.tell(units, chi2)
        state["generation"] += 1
        k = int(np.argmin(chi2))
        if chi2[k] < state["best_chi2"]:
            state["best"], state["best_chi2"] = fitted[k], chi2[k]
        state["trace"].append(state["best_chi2"])
        with history_file.open("a") as f:
            for v, c in zip(fitted, chi2):
                f.write(json.dumps({"generation": state["generation"], "values": v, "chi2": c}) + "\n")
        trace = state["trace"]
        if len(trace) > opt.patience and trace[-1 - opt.patience] - trace[-1] <= opt.tol_relative * trace[-1 - opt.patience]:
            state["converged"] = True
            state["stop"] = (f"best χ² improved by less than {opt.tol_relative:g} (relative) over "
                             f"{opt.patience} generations")
        elif es.stop():
            state["converged"] = True
            state["stop"] = f"{type(es).__name__} stop: {', '.join(es.stop())}"
        _save_checkpoint(out, state)
        bar.update(1)
        bar.set_postfix(chi2=f"{state['best_chi2']:.4g}")
    bar.close()
    if not state["converged"] and state["stop"] is None:
        state["stop"] = f"max_generations ({opt.max_generations}) reached before the stop rule was met"
    return state


def _jacobian(ev: Evaluator, values: dict[str, float], tips: np.ndarray) -> np.ndarray:
    """d(whitened data residuals)/d(parameter) for every fitted parameter (central differences:
    physics by simulation, 5 % of the range; camera 1e-4 of the range)."""
    space = ev.space
    cols = []
    physics_steps = {n: 0.05 * space.range[n] for n in space.physics}
    plus_minus = []
    for n in space.physics:
        for sign in (1, -1):
            plus_minus.append({m: values[m] for m in space.physics} | {n: values[n] + sign * physics_steps[n]})
    sims = ev.simulate(plus_minus) if plus_minus else []
    for n in space.fitted:
        if n in space.physics:
            i = space.physics.index(n)
            rp = ev.residuals(sims[2 * i], values, priors=False)
            rm = ev.residuals(sims[2 * i + 1], values, priors=False)
            cols.append((rp - rm) / (2 * physics_steps[n]))
        else:
            h = 1e-4 * space.range[n]
            rp = ev.residuals(tips, {**values, n: values[n] + h}, priors=False)
            rm = ev.residuals(tips, {**values, n: values[n] - h}, priors=False)
            cols.append((rp - rm) / (2 * h))
    return np.column_stack(cols) if cols else np.zeros((0, 0))


def _robust_variances(jac: np.ndarray, r: np.ndarray, sample: np.ndarray, info: np.ndarray, s2: float) -> np.ndarray:
    """Per parameter, the larger of the Gauss–Newton variance s²·info⁻¹ and the
    cluster-robust (sandwich) one info⁻¹ M info⁻¹ · G/(G−1), with the meat M =
    Σ_s J_sᵀ r_s r_sᵀ J_s summed over the samples s (the clusters) and G the samples with
    pins. `info` is JᵀJ (plus the priors' information); units: the parameters' squared."""
    bread = np.linalg.pinv(info, rcond=1e-12)
    scores = np.zeros((int(sample.max(initial=-1)) + 1, jac.shape[1]))
    np.add.at(scores, sample, jac * r[:, None])  # J_sᵀ r_s per sample
    clusters = len(np.unique(sample))
    sandwich = bread @ (scores.T @ scores) @ bread * (clusters / max(clusters - 1, 1))
    return np.maximum(np.diag(sandwich), np.diag(bread) * s2)


def _variance_inflation(scaled: np.ndarray) -> np.ndarray:
    """VIF_i = 1/(1 − R_i²) per column: R_i² is the share of column i (its length) that the
    best combination of the other columns reproduces (inf for a zero column or one inside
    their span)."""
    norms = np.linalg.norm(scaled, axis=0)
    unit = scaled / np.where(norms > 0, norms, 1.0)
    vif = np.full(scaled.shape[1], np.inf)
    for i in np.nonzero(norms > 1e-12 * max(norms.max(initial=0.0), 1e-300))[0]:
        others = np.delete(unit, i, axis=1)
        rest = unit[:, i] - others @ np.linalg.lstsq(others, unit[:, i], rcond=None)[0] if others.shape[1] else unit[:, i]
        vif[i] = 1.0 / max(float(rest @ rest), 1e-300)
    return vif


def _uncertainty(ev: Evaluator, values: dict[str, float], tips: np.ndarray) -> dict:
    """Standard errors, resolution, variance inflation and identifiability per parameter.

    A fitted parameter is identifiable from these runs when all three hold (a "no" lists
    the ones that failed, and the parameter is left at its default):

    1. error: its data-only standard error is below `identifiable_fraction` of its bounds'
       range. The error is cluster-robust, samples as clusters (_robust_variances): the
       254 residuals of one frame share its contact, tracking and model errors, so the
       Gauss–Newton s²(JᵀJ)⁻¹, which counts them as independent, is too small (friction
       from 4 taps: ±0.04 stated, 0.6 off). The sandwich lets a sample's residuals
       correlate freely; with few samples it is itself noisy (rank ≤ G − 1, so it can come
       out below the Gauss–Newton error), hence the larger of the two.
    2. resolution: its resolution (the change that moves the pins by the fit's pin RMS)
       is below its bounds' range, i.e. the whole range moves the pins by more than the
       residual. Errors shared across samples (a tracker's per-pin bias, the twin's model
       error) do not average out over frames, while the standard error of (1) falls as
       1/√samples: a parameter whose whole range is lost in the residual of every frame
       is not told apart from them by fitting more frames of the same kind.
    3. collinearity: its variance inflation 1/(1 − R²) is at most `max_variance_inflation`,
       R² the share of its Jacobian column that the other columns reproduce. Above it
       (default 100: under 10 % of the column is its own), its effect can be traded for
       the others', and a model error along the shared direction moves it √VIF times more
       than a parameter with a column of its own; the noise-based errors of (1) do not see
       a model error.
    """
    space = ev.space
    if not space.fitted:
        return {"parameters": {}, "singular_values": [], "reduced_chi2": None}
    jac = _jacobian(ev, values, tips)
    r = ev.residuals(tips, values, priors=False)
    n_offsets = 2 * N_PINS if ev.fit_rest else 0
    dof = max(1, r.size - len(space.fitted) - n_offsets)
    s2 = float(np.sum(r ** 2) / dof)
    ranges = np.array([space.range[n] for n in space.fitted])
    scaled = jac * ranges  # per unit of the bounds' range
    singular = np.linalg.svd(scaled, compute_uv=False)
    vif = _variance_inflation(scaled)
    info = jac.T @ jac
    p = space.settings.parameters
    prior = np.diag([1.0 / p[n].prior_std ** 2 if p[n].prior_std else 0.0 for n in space.fitted])
    data_var = _robust_variances(jac, r, ev.row_sample, info, s2)
    post_var = _robust_variances(jac, r, ev.row_sample, info + prior, s2)
    settings = space.settings
    fit_rms = np.sqrt(s2) * settings.noise_px * np.sqrt(2.0)  # px, Euclidean per pin
    out = {}
    for i, n in enumerate(space.fitted):
        column = float(np.linalg.norm(jac[:, i]))
        data_std = float(np.sqrt(max(data_var[i], 0.0))) if column > 1e-12 else float("inf")
        std = float(np.sqrt(max(post_var[i], 0.0))) if column > 1e-12 else float("inf")
        # how much the pin RMS (px, Euclidean per pin) changes per unit of the parameter
        per_unit = column * settings.noise_px * np.sqrt(2.0 / max(1, r.size))
        resolution = float(fit_rms / max(per_unit, 1e-300))
        why = []
        if not data_std < settings.identifiable_fraction * space.range[n]:
            why.append(f"standard error {data_std:.2g} ≥ {settings.identifiable_fraction:g} × the range {space.range[n]:g}")
        if not resolution < space.range[n]:
            why.append(f"resolution {resolution:.2g} ≥ the range {space.range[n]:g}")
        if not vif[i] <= settings.max_variance_inflation:
            why.append(f"variance inflation {vif[i]:.3g} > {settings.max_variance_inflation:g}")
        out[n] = {"value": values[n], "default": space.defaults[n], "std": std,
                  "data_std": data_std, "pin_rms_px_per_unit": float(per_unit), "bounds": [p[n].lower, p[n].upper],
                  "identifiable": not why, "not_identifiable_because": why,
                  "resolution": resolution, "variance_inflation": float(vif[i]),
                  "at_bound": bool(min(values[n] - p[n].lower, p[n].upper - values[n]) < 1e-6 * space.range[n])}
    return {"parameters": out, "singular_values": singular.tolist(), "reduced_chi2": s2,
            "condition_number": float(singular.max() / max(singular.min(), 1e-300))}


def calibrate(run_dirs: list[Path], scenario: Scenario, out: Path, settings: CalibrationSettings,
              workers: int | None = None, cluster: str | None = None, progress: bool = True) -> dict:
    """Fit the twin to the runs (module docstring); writes DIR/calibration.yaml (converged) or
    DIR/best_calibration.yaml (not: raises CalibrationNotConverged after writing), the
    report (report.json, report.md, residuals.png), history.jsonl and checkpoint.pkl.
    workers / cluster: as twin.runs.parallel.WorkerPool, one pool for all the simulations."""
    with WorkerPool(workers, cluster) as pool:
        return _calibrate(run_dirs, scenario, out, settings, pool, progress)


def _calibrate(run_dirs: list[Path], scenario: Scenario, out: Path, settings: CalibrationSettings, pool: WorkerPool,
               progress: bool) -> dict:
    wall = time.perf_counter()
    if scenario.backend != "sim":
        scenario = scenario.with_changes(backend="sim")
    data = load_data([Path(r) for r in run_dirs], scenario, settings.weights)
    space = Space(scenario, settings)
    out.mkdir(parents=True, exist_ok=True)
    ev = Evaluator(space, data, pool)
    before_tips = ev.simulate([space.defaults])[0]
    before_values = dict(space.defaults)
    # "before" is the twin as the scenario has it: its rest layout, not one fitted to these runs
    ev.fit_rest, fit_rest = False, ev.fit_rest
    before = ev.rms(before_tips, before_values)
    ev.fit_rest = fit_rest
    state = _optimise(ev, out, _key(run_dirs, scenario, settings), progress)
    best = state["best"]
    best_tips = ev.simulate([best])[0]
    uncertainty = _uncertainty(ev, best, best_tips)
    # what the data cannot identify goes back to its default, and the camera is solved again without it
    final = dict(best)
    dropped = [n for n, u in uncertainty["parameters"].items() if not u["identifiable"]]
    for n in dropped:
        final[n] = space.defaults[n]
    final_tips = best_tips
    if any(n in space.physics for n in dropped):
        final_tips = ev.simulate([final])[0]
    if dropped and space.camera:
        keep = [n for n in space.camera if n not in dropped]
        space.camera = keep
        final = ev.solve_camera(final_tips, {n: v for n, v in final.items() if n not in keep}, final)
    _, offsets = ev.predict(final_tips, final)
    calibration = space.calibration(final, offsets if ev.fit_rest else None)
    after = ev.rms(final_tips, final)
    name = "calibration.yaml" if state["converged"] else "best_calibration.yaml"
    write_calibration(calibration, out / name)
    result = {
        "status": "converged" if state["converged"] else "not converged", "stop_reason": state["stop"],
        "runs": [str(r) for r in run_dirs], "scenario": scenario.source, "calibration_file": str(out / name),
        "samples": int(len(data.pins)), "samples_per_group": {g: int((data.group == k).sum()) for k, g in enumerate(GROUPS)},
        "fitted": space.fitted, "not_identifiable": dropped,
        "rest_pins": ("fitted from %d no-contact frames" % int(ev.rest.sum())) if ev.fit_rest else
                     ("not fitted: no no-contact frames (target z <= 0) in the runs" if settings.rest_pins else "not fitted (settings)"),
        "before": before, "after": after, "uncertainty": uncertainty, "generations": state["generation"],
        "best_chi2": state["best_chi2"], "simulations": ev.simulations,
        "simulated_frames_per_s": ev.simulations * len(data.pins) / max(ev.sim_seconds, 1e-9),
        "evaluations_per_s": ev.simulations / max(ev.sim_seconds, 1e-9),
        "wall_time_s": time.perf_counter() - wall, "workers": pool.workers, "cluster": pool.cluster,
    }
    write_report(result, out)
    if not state["converged"]:
        raise CalibrationNotConverged(f"{state['stop']}; the best point is in {out / name}, the history in "
                                      f"{out / 'history.jsonl'} (run again with the same --out to continue)")
    return result
