"""The run record: one format for sim and real runs, written as the run goes.

A run directory holds
  run.json        metadata: scenario (as validated), seed, backend, package versions,
                  camera model, start/end time, the recording process (host, pid),
                  status ("running", "completed", "interrupted", "failed"), the error
                  if any, the resumes (sample index and time of each); rest_pins_px
                  (127×2 px: the pins of the no-contact reference the tracker starts from)
  samples.jsonl   one JSON object per sample, appended and flushed immediately:
                  index, time (s), target and measured pose (mm/deg, work frame),
                  labels (protocol-specific: theta_deg, lateral_mm, depth_mm,
                  direction_deg, on_object, step …), pins_px (127×2 px or null),
                  found (127 bools or null), frame (file name or null), truth (sim only)
  frames/NNNNNN.png   the camera frame of a sample, when rendered or filmed
An interrupted run keeps every sample written so far; `load_run` reads any of them.

The final status is the run's end marker: it is written when the run ends in any way
the process sees (completed, failed, SIGINT, SIGTERM). A run killed outright (SIGKILL,
power loss) keeps "running" with the pid of a process that is gone: `Run.state` then
reads "killed", and readers say the run did not finish. Frames are written to a
temporary name and renamed, so a frame file that exists is complete; a sample line is
complete when it ends in a newline. `RunRecorder.resume` reopens a run after its last
complete sample (twin.runs.run.resume_run).
"""
from __future__ import annotations

import json
import os
import platform
import signal
import socket
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import cv2
import numpy as np

from twin.core.environment import Observation
from twin.core.errors import UserError
from twin.core.poses import Pose

FORMAT_VERSION = 1
_PACKAGES = ("tactip-twin", "mujoco", "numpy", "scipy", "scikit-learn", "opencv-contrib-python-headless", "trimesh")


def package_versions() -> dict[str, str]:
    versions = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def jsonable(value):
    if isinstance(value, np.ndarray):
        return (np.round(value, 6) if value.dtype.kind == "f" else value).tolist()
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    if isinstance(value, Pose):
        return [round(float(v), 6) for v in value.as_array()]
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    return value


class RunRecorder:
    """Appends samples to a run directory; use as a context manager so the status is
    finalised even when the run is interrupted or fails."""

    def __init__(self, out_dir: Path, scenario, seed: int, backend: str, camera=None, extra: dict | None = None,
                 resume: bool = False) -> None:
        self.out_dir = Path(out_dir)
        self.frames_dir = self.out_dir / "frames"
        self._images = ThreadPoolExecutor(max_workers=1)  # PNG encoding overlaps the simulation
        self._pending = []
        if resume:
            self._reopen()
            return
        self.out_dir.mkdir(parents=True, exist_ok=True)
        if (self.out_dir / "samples.jsonl").exists():
            raise UserError(f"{self.out_dir}: already holds a run; choose another --out (or --resume it)")
        self.meta = {
            "format_version": FORMAT_VERSION,
            "scenario": scenario.model_dump(),
            "scenario_file": scenario.source,
            "seed": seed,
            "backend": backend,
            "versions": package_versions(),
            "camera": None if camera is None else {"width": camera.width, "height": camera.height,
                                                   "intrinsics": camera.intrinsics.tolist()},
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "status": "running",
            "process": _this_process(),
            **(extra or {}),
        }
        self._write_meta()
        self._samples = open(self.out_dir / "samples.jsonl", "w")
        self.count = 0

    @classmethod
    def resume(cls, out_dir: Path) -> "RunRecorder":
        """Reopen an unfinished run for appending after its last complete sample (a torn
        last line, and samples whose frame file is missing, are dropped)."""
        return cls(out_dir, None, 0, "", resume=True)

    def _reopen(self) -> None:
        run = load_run(self.out_dir)
        if run.state == "running":
            raise UserError(f"{self.out_dir}: this run is still being recorded by process {run.meta['process']['pid']}")
        if run.state == "completed":
            raise UserError(f"{self.out_dir}: this run is complete; nothing to resume")
        keep = len(run.samples)
        while keep and run.samples[keep - 1]["frame"] is not None and not (self.out_dir / run.samples[keep - 1]["frame"]).is_file():
            keep -= 1
        path = self.out_dir / "samples.jsonl"
        with open(path, "rb") as fh:
            lines = fh.read().split(b"\n")
        with open(path, "wb") as fh:
            fh.write(b"".join(line + b"\n" for line in lines[:keep]))
        self.meta = run.meta
        self.meta.setdefault("resumes", []).append({"at_sample": keep, "previous_status": run.state,
                                                    "time": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
        self.meta.update(status="running", process=_this_process())
        for key in ("error", "finished", "samples"):
            self.meta.pop(key, None)
        self._write_meta()
        self._samples = open(path, "a")
        self.count = keep

    def _write_meta(self) -> None:
        tmp = self.out_dir / "run.json.tmp"
        tmp.write_text(json.dumps(jsonable(self.meta), indent=1))
        tmp.replace(self.out_dir / "run.json")

    def set_rest_pins(self, pins_px: np.ndarray | None) -> None:
        """Record the run's pins at rest (127×2 px) once, in run.json at once (an
        interrupted run keeps them)."""
        if pins_px is None or "rest_pins_px" in self.meta:
            return
        self.meta["rest_pins_px"] = np.asarray(pins_px, float)
        self._write_meta()

    def add(self, observation: Observation, target: Pose, labels: dict, pins_px: np.ndarray | None = None,
            found: np.ndarray | None = None) -> int:
        """Record one sample; returns its index."""
        index = self.count
        frame_name = None
        if observation.frame is not None:
            self.frames_dir.mkdir(exist_ok=True)
            frame_name = f"frames/{index:06d}.png"
            bgr = observation.frame[..., ::-1]
            self._pending.append(self._images.submit(_write_png, self.out_dir / frame_name, bgr))
        pins = pins_px if pins_px is not None else observation.pins_px
        row = {
            "index": index,
            "time": observation.time,
            "target": target,
            "pose": observation.pose,
            "labels": labels,
            "pins_px": pins,
            "found": None if found is None else found.astype(bool),
            "frame": frame_name,
            "truth": observation.truth,
        }
        line = json.dumps(jsonable(row)) + "\n"
        with _signals_held():  # a Ctrl-C or SIGTERM lands after the line and its count, not between
            self._samples.write(line)
            self._samples.flush()
            self.count += 1
        return index

    def close(self, status: str = "completed", error: str | None = None, summary: dict | None = None) -> None:
        if self._samples.closed:
            return
        for job in self._pending:
            job.result()
        self._images.shutdown()
        self._samples.close()
        self.meta.update(status=status, samples=self.count, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
        if error:
            self.meta["error"] = error
        if summary:
            self.meta["summary"] = summary
        self._write_meta()

    def __enter__(self) -> "RunRecorder":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close("completed")
        elif issubclass(exc_type, KeyboardInterrupt):
            self.close("interrupted", str(exc) or "SIGINT")
        else:
            self.close("failed", f"{exc_type.__name__}: {exc}")


@contextmanager
def _signals_held():
    """Hold SIGINT and SIGTERM back (delivered on exit) for a few statements that must not be split."""
    held = {signal.SIGINT, signal.SIGTERM}
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _write_png(path: Path, bgr: np.ndarray) -> None:
    """Write a frame under a temporary name, then rename: a frame file that exists is whole."""
    tmp = path.with_suffix(".tmp.png")
    if not cv2.imwrite(str(tmp), bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1]):
        raise OSError(f"could not write {path}")
    os.replace(tmp, path)


def _this_process() -> dict:
    return {"host": socket.gethostname(), "pid": os.getpid()}


def _alive(process: dict | None) -> bool:
    """True if `process` (host, pid) is a live process on this host."""
    if not process or process.get("host") != socket.gethostname():
        return False
    try:
        os.kill(int(process["pid"]), 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@dataclass
class Run:
    """A recorded run loaded back: metadata and per-sample arrays."""

    path: Path
    meta: dict
    samples: list[dict]

    @property
    def pins_px(self) -> np.ndarray:
        """(N, 127, 2) px; NaN where a sample has no pins."""
        return np.array([self.sample_pins(k) for k in range(len(self.samples))]).reshape(-1, 127, 2)

    def sample_pins(self, index: int) -> np.ndarray:
        """(127, 2) px of one sample; NaN when it has none."""
        pins = self.samples[index]["pins_px"]
        return np.full((127, 2), np.nan) if pins is None else np.asarray(pins, float)

    @property
    def rest_pins_px(self) -> np.ndarray:
        """(127, 2) px: the pins at rest; runs recorded before rest pins were kept fall back
        on their first sample's pins."""
        rest = self.meta.get("rest_pins_px")
        if rest is not None:
            return np.asarray(rest, float)
        return self.sample_pins(0) if self.samples else np.full((127, 2), np.nan)

    @property
    def targets(self) -> np.ndarray:
        return np.array([s["target"] for s in self.samples])

    @property
    def poses(self) -> np.ndarray:
        return np.array([s["pose"] for s in self.samples])

    @property
    def state(self) -> str:
        """"completed", "interrupted", "failed", "running" (its process is alive) or
        "killed" (status still "running" but the recording process is gone: no end marker)."""
        status = self.meta.get("status", "running")
        if status != "running":
            return status
        return "running" if _alive(self.meta.get("process")) else "killed"

    @property
    def finished(self) -> bool:
        """True only for a run that recorded its whole protocol."""
        return self.state == "completed"

    def unfinished_note(self) -> str | None:
        """A line saying this run did not finish (None if it did), for readers to print."""
        if self.finished:
            return None
        why = {"killed": "killed before it finished (no end marker)", "running": "still being recorded"}
        return (f"{self.path}: run did not finish ({why.get(self.state, self.state)}; {len(self.samples)} samples); "
                f"continue it with: twin run --resume {self.path}")

    def label(self, key: str) -> np.ndarray:
        return np.array([s["labels"].get(key, np.nan) for s in self.samples])

    @property
    def resolution(self) -> tuple[int, int]:
        """(width, height) px of the run's camera (640×480 for runs recorded without one)."""
        camera = self.meta.get("camera") or {}
        return int(camera.get("width", 640)), int(camera.get("height", 480))

    def frame(self, index: int) -> np.ndarray | None:
        name = self.samples[index]["frame"]
        if name is None:
            return None
        image = cv2.imread(str(self.path / name), cv2.IMREAD_COLOR)
        return None if image is None else image[..., ::-1]


def load_run(path: str | Path) -> Run:
    """Read a run directory (complete, interrupted or killed): only complete sample lines
    (ending in a newline) are read; a line cut by a kill is left out."""
    path = Path(path)
    meta_file = path / "run.json"
    if not meta_file.is_file():
        raise UserError(f"{path}: not a run directory (no run.json)")
    try:
        meta = json.loads(meta_file.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise UserError(f"{meta_file}: not valid JSON ({err})") from None
    samples = []
    samples_file = path / "samples.jsonl"
    if samples_file.exists():
        complete = samples_file.read_bytes().split(b"\n")[:-1]  # after the last newline: a torn line or nothing
        for n, line in enumerate(complete, 1):
            try:
                samples.append(json.loads(line))
            except (json.JSONDecodeError, UnicodeDecodeError):
                raise UserError(f"{samples_file}: line {n} is not valid JSON") from None
    return Run(path, meta, samples)
