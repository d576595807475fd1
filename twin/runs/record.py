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

import contextlib
import fcntl
import json
import os
import platform
import socket
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import cv2
import numpy as np

from twin.core.environment import Observation
from twin.core.errors import UserError, interruption
from twin.core.files import remove_leftovers, replace_file
from twin.core.poses import Pose
from twin.runs.interrupts import signals_held

FORMAT_VERSION = 1
#: The recorder's lock file in a run directory (twin.runs.record.RunRecorder)
LOCK_FILE = ".lock"
#: Bytes the lock file holds while a run records, given back to write the final status on a full disk
RESERVE_BYTES = 256 * 2**10
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
    finalised even when the run is interrupted or fails.

    The recorder holds an exclusive lock on the directory (LOCK_FILE) for as long as it is
    open: a second recorder of the same directory is refused (UserError naming it). The
    lock file also holds RESERVE_BYTES that are given back when a write fails, so that a
    full disk still gets its final run.json ("failed", the error named)."""

    def __init__(
        self,
        out_dir: Path,
        scenario,
        seed: int,
        backend: str,
        camera=None,
        extra: dict | None = None,
        resume: bool = False,
    ) -> None:
        self.out_dir = Path(out_dir)
        self.frames_dir = self.out_dir / "frames"
        self._images = ThreadPoolExecutor(max_workers=1)  # PNG encoding overlaps the simulation
        self._pending: list[tuple[Future | None, bytes]] = []  # sample lines waiting for their frame
        self._samples: int | None = None
        self._lock: int | None = None
        try:
            if resume:
                self._lock_directory()
                self._reopen()
                return
            try:
                self.out_dir.mkdir(parents=True, exist_ok=True)
            except FileExistsError:
                raise UserError(f"{self.out_dir}: exists and is not a folder; choose another --out") from None
            except OSError as err:
                raise UserError(f"{self.out_dir}: cannot create the run folder ({err.strerror})") from None
            self._lock_directory()
            if (self.out_dir / "samples.jsonl").exists() or (self.out_dir / "run.json").exists():
                raise UserError(f"{self.out_dir}: already holds a run; choose another --out (or --resume it)")
            self.meta = {
                "format_version": FORMAT_VERSION,
                "scenario": scenario.model_dump(),
                "scenario_file": scenario.source,
                "seed": seed,
                "backend": backend,
                "versions": package_versions(),
                "camera": None
                if camera is None
                else {"width": camera.width, "height": camera.height, "intrinsics": camera.intrinsics.tolist()},
                "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "status": "running",
                "process": _this_process(),
                **(extra or {}),
            }
            self._write_meta()
            self._samples = os.open(self.out_dir / "samples.jsonl", os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
            self.count = 0
        except BaseException:
            self._release()
            raise

    @classmethod
    def resume(cls, out_dir: Path) -> RunRecorder:
        """Reopen an unfinished run for appending after its last complete sample (a torn
        last line, and samples whose frame file is missing, are dropped)."""
        return cls(out_dir, None, 0, "", resume=True)

    def _lock_directory(self) -> None:
        """Take the directory's exclusive lock (UserError if another process holds it) and
        fill its reserve."""
        path = self.out_dir / LOCK_FILE
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        except OSError as err:
            raise UserError(f"{self.out_dir}: cannot lock the run folder ({err.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise UserError(
                f"{self.out_dir}: another twin process is recording into this folder; choose another --out"
            ) from None
        self._lock = fd
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, bytes(RESERVE_BYTES), 0)
        except OSError as err:
            raise OSError(err.errno, f"cannot write in the run folder ({err.strerror})", str(path)) from None

    def _release(self) -> None:
        """Drop the lock (and its reserve); the lock file goes too."""
        if self._lock is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.out_dir / LOCK_FILE)
        os.close(self._lock)
        self._lock = None

    def _free_reserve(self) -> None:
        if self._lock is not None:
            with contextlib.suppress(OSError):
                os.ftruncate(self._lock, 0)

    def _reopen(self) -> None:
        run = load_run(self.out_dir)
        if run.state == "completed":
            raise UserError(f"{self.out_dir}: this run is complete; nothing to resume")
        keep = len(run.samples)
        while (
            keep
            and run.samples[keep - 1]["frame"] is not None
            and not (self.out_dir / run.samples[keep - 1]["frame"]).is_file()
        ):
            keep -= 1
        for folder in (self.out_dir, self.frames_dir):
            remove_leftovers(folder)  # what a killed writer left half-written
        path = self.out_dir / "samples.jsonl"
        lines = path.read_bytes().split(b"\n") if path.exists() else []
        replace_file(path, b"".join(line + b"\n" for line in lines[:keep]))
        self.meta = run.meta
        self.meta.setdefault("resumes", []).append(
            {"at_sample": keep, "previous_status": run.state, "time": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        )
        self.meta.update(status="running", process=_this_process())
        for key in ("error", "finished", "samples"):
            self.meta.pop(key, None)
        self._write_meta()
        self._samples = os.open(path, os.O_WRONLY | os.O_APPEND)
        self.count = keep

    def _write_meta(self) -> None:
        replace_file(self.out_dir / "run.json", json.dumps(jsonable(self.meta), indent=1).encode())

    def set_rest_pins(self, pins_px: np.ndarray | None) -> None:
        """Record the run's pins at rest (127×2 px) once, in run.json at once (an
        interrupted run keeps them)."""
        if pins_px is None or "rest_pins_px" in self.meta:
            return
        self.meta["rest_pins_px"] = np.asarray(pins_px, float)
        self._write_meta()

    def add(
        self,
        observation: Observation,
        target: Pose,
        labels: dict,
        pins_px: np.ndarray | None = None,
        found: np.ndarray | None = None,
    ) -> int:
        """Record one sample; returns its index. Its line is written once its frame file
        is (the line of the sample before it at the latest when the next one is added)."""
        index = self.count
        frame_name = None
        written = None
        if observation.frame is not None:
            self.frames_dir.mkdir(exist_ok=True)
            frame_name = f"frames/{index:06d}.png"
            bgr = observation.frame[..., ::-1]
            written = self._images.submit(_write_png, self.out_dir / frame_name, bgr)
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
        self._write_lines()
        self._pending.append((written, (json.dumps(jsonable(row)) + "\n").encode()))
        self.count += 1
        return index

    def _write_lines(self) -> None:
        """Append the pending sample lines, each after its frame file is complete."""
        while self._pending:
            written, line = self._pending[0]
            if written is not None:
                written.result()
            with signals_held():  # a Ctrl-C or SIGTERM lands after a whole line, not inside it
                try:
                    _append(self._samples, line)
                except OSError as err:  # named: the descriptor's error does not say which file
                    raise OSError(err.errno, err.strerror, str(self.out_dir / "samples.jsonl")) from None
                self._pending.pop(0)

    def close(self, status: str = "completed", error: str | None = None, summary: dict | None = None) -> None:
        """Write what is pending and the final status. A write that fails makes the status
        "failed" (the error named) and is raised once the status is written; what was
        written before it stays readable (`twin run --resume` completes it)."""
        if self._samples is None:
            return
        failure: BaseException | None = None
        try:
            self._write_lines()
        except BaseException as err:  # noqa: BLE001  (the status is written whatever stopped the lines)
            failure = err
            if isinstance(err, KeyboardInterrupt):
                status, error = "interrupted", error or str(err) or "SIGINT"
            else:
                status, error = "failed", f"{type(err).__name__}: {err}"
            self._pending.clear()
        finally:
            self._images.shutdown(wait=True, cancel_futures=True)
            os.close(self._samples)
            self._samples = None
        self.count = min(self.count, _complete_lines(self.out_dir / "samples.jsonl"))
        self.meta.update(status=status, samples=self.count, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
        if error:
            self.meta["error"] = error
        if summary:
            self.meta["summary"] = summary
        try:
            try:
                self._write_meta()
            except OSError:
                self._free_reserve()  # a full disk: the reserve makes room for the final status
                self._write_meta()
        finally:
            self._release()
        if failure is not None:
            raise failure

    def __enter__(self) -> RunRecorder:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close("completed")
        elif (stop := interruption(exc)) is not None:
            self.close("interrupted", str(stop) or "SIGINT")
            if stop is not exc:
                raise stop from None  # the interruption, not the SystemError it arrived as
        else:
            self.close("failed", f"{exc_type.__name__}: {exc}")


def resume_hint(run_dir: Path) -> str:
    """How to finish the unfinished run in `run_dir`, in words for a message."""
    return f"continue it with: twin run --resume {run_dir}"


def _append(fd: int, data: bytes) -> None:
    """Append `data` whole, or nothing: a write that fails part-way is cut back off."""
    start = os.lseek(fd, 0, os.SEEK_END)
    try:
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view) :]
    except BaseException:
        with contextlib.suppress(OSError):
            os.ftruncate(fd, start)
        raise


def _complete_lines(path: Path) -> int:
    """Complete (newline-ended) lines of `path`; 0 if it cannot be read."""
    try:
        return path.read_bytes().count(b"\n")
    except OSError:
        return 0


def _write_png(path: Path, bgr: np.ndarray) -> None:
    """Write a frame under a temporary name, then rename: a frame file that exists is whole."""
    ok, png = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:
        raise OSError(f"could not encode the frame {path}")
    replace_file(path, png.tobytes())


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

    def subset(self, keep) -> Run:
        """This run with only some of its samples: at the indices `keep` (in that order) or
        where the boolean mask `keep` is true."""
        keep = np.asarray(keep)
        indices = np.flatnonzero(keep) if keep.dtype == bool else keep.astype(int)
        return Run(self.path, self.meta, [self.samples[k] for k in indices])

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
        """ "completed", "interrupted", "failed", "running" (its process is alive) or
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
        return (
            f"{self.path}: run did not finish ({why.get(self.state, self.state)}; {len(self.samples)} samples); "
            f"{resume_hint(self.path)}"
        )

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


#: The most bytes of run.json and samples.jsonl that are read (B)
MAX_META_BYTES = 64 * 2**20
MAX_SAMPLES_BYTES = 4 * 2**30
_STATUSES = ("running", "completed", "interrupted", "failed")
_NUMERIC_LABEL_SUFFIXES = ("_deg", "_mm", "_px", "_n")


def load_run(path: str | Path) -> Run:
    """Read a run directory (complete, interrupted or killed): only complete sample lines
    (ending in a newline) are read; a line cut by a kill is left out. Every field is
    checked for type and shape: UserError naming the file, the line and the field
    otherwise; a frame must be a file inside the run directory."""
    path = Path(path)
    meta_file = path / "run.json"
    if not meta_file.is_file():
        raise UserError(f"{path}: not a run directory (no run.json)")
    meta = _check_meta(_read_json(meta_file, MAX_META_BYTES), meta_file)
    samples = []
    samples_file = path / "samples.jsonl"
    if samples_file.exists():
        if not samples_file.is_file() or samples_file.stat().st_size > MAX_SAMPLES_BYTES:
            raise UserError(f"{samples_file}: not a samples file (a file of at most {MAX_SAMPLES_BYTES} B)")
        root = path.resolve()
        complete = _read_bytes(samples_file).split(b"\n")[:-1]  # after the last newline: a torn line or nothing
        for n, line in enumerate(complete, 1):
            try:
                row = json.loads(line)
            except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
                raise UserError(f"{samples_file}: line {n} is not valid JSON") from None
            samples.append(_check_sample(row, f"{samples_file}: line {n}", root))
    return Run(path, meta, samples)


def _read_bytes(file: Path) -> bytes:
    try:
        return file.read_bytes()
    except OSError as err:
        raise UserError(f"{file}: cannot be read ({err.strerror or type(err).__name__})") from None


def _read_json(file: Path, max_bytes: int):
    if file.stat().st_size > max_bytes:
        raise UserError(f"{file}: {file.stat().st_size} B; at most {max_bytes} B are read")
    try:
        return json.loads(_read_bytes(file))
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise UserError(f"{file}: not valid JSON") from None
    except RecursionError:
        raise UserError(f"{file}: not a run's metadata (nested too deep)") from None


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _check_numbers(value, shape: tuple[int, ...], where: str, field: str, finite: bool = True) -> None:
    """`value` is a nested list of numbers of `shape` (-1: any length), finite if asked."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise UserError(f"{where}: field {field!r} must be numbers of shape {shape}") from None
    if (
        array.ndim != len(shape)
        or any(n not in (-1, m) for n, m in zip(shape, array.shape))
        or (array.size and not _all_numbers(value))
    ):
        raise UserError(f"{where}: field {field!r} must be numbers of shape {shape}, got shape {array.shape}")
    if finite and not np.all(np.isfinite(array)):
        raise UserError(f"{where}: field {field!r} holds NaN or ±inf")


def _all_numbers(value) -> bool:
    if isinstance(value, list):
        return all(_all_numbers(v) for v in value)
    return _is_number(value)


def _check_meta(meta, where: Path) -> dict:
    """run.json's fields that readers rely on, checked for type and range."""
    if not isinstance(meta, dict):
        raise UserError(f"{where}: not a run's metadata (a JSON object), got {type(meta).__name__}")
    if meta.get("format_version") != FORMAT_VERSION:
        raise UserError(
            f"{where}: format_version {str(meta.get('format_version'))[:20]}, this twin reads {FORMAT_VERSION}"
        )
    scenario = meta.get("scenario")
    if not (
        isinstance(scenario, dict)
        and isinstance(scenario.get("name"), str)
        and isinstance(scenario.get("protocol"), dict)
        and isinstance(scenario["protocol"].get("kind"), str)
        and isinstance(scenario.get("fidelity"), str)
    ):
        raise UserError(f"{where}: field 'scenario' must be the run's scenario (name, fidelity, protocol.kind)")
    seed = meta.get("seed")
    if not (isinstance(seed, int) and not isinstance(seed, bool) and 0 <= seed <= 2**32 - 1):
        raise UserError(f"{where}: field 'seed' must be an integer in [0, 2**32 - 1], got {str(seed)[:20]}")
    if meta.get("backend") not in ("sim", "hardware"):
        raise UserError(f"{where}: field 'backend' must be 'sim' or 'hardware'")
    if meta.get("status", "running") not in _STATUSES:
        raise UserError(f"{where}: field 'status' must be one of {', '.join(_STATUSES)}")
    if not isinstance(meta.get("scenario_file", ""), str):
        raise UserError(f"{where}: field 'scenario_file' must be a string")
    camera = meta.get("camera")
    if camera is not None:
        if not isinstance(camera, dict) or not all(
            isinstance(camera.get(k, 640), int) and 1 <= camera.get(k, 640) <= 10_000 for k in ("width", "height")
        ):
            raise UserError(f"{where}: field 'camera' must hold width and height in [1, 10000] px")
    if meta.get("rest_pins_px") is not None:
        _check_numbers(meta["rest_pins_px"], (127, 2), str(where), "rest_pins_px", finite=False)
    if not isinstance(meta.get("process", {}), dict):
        raise UserError(f"{where}: field 'process' must be an object (host, pid)")
    return meta


def _check_sample(row, where: str, root: Path) -> dict:
    """One sample line's fields checked for type and shape; its frame inside `root`."""
    if not isinstance(row, dict):
        raise UserError(f"{where}: a sample is a JSON object, got {type(row).__name__}")
    missing = [k for k in ("target", "pose", "labels", "pins_px", "frame") if k not in row]
    if missing:
        raise UserError(f"{where}: sample without the fields {', '.join(missing)}")
    if not _is_number(row.get("time", 0.0)) or not np.isfinite(row.get("time", 0.0)):
        raise UserError(f"{where}: field 'time' must be a finite number (s)")
    for field in ("target", "pose"):
        _check_numbers(row[field], (6,), where, field)
    if row["pins_px"] is not None:
        _check_numbers(row["pins_px"], (127, 2), where, "pins_px", finite=False)
    found = row.get("found")
    if found is not None and not (
        isinstance(found, list) and len(found) == 127 and all(isinstance(f, bool) for f in found)
    ):
        raise UserError(f"{where}: field 'found' must be 127 true/false values or null")
    labels = row["labels"]
    if not isinstance(labels, dict):
        raise UserError(f"{where}: field 'labels' must be an object")
    for key, value in labels.items():
        if isinstance(value, (dict, list)) or (key.endswith(_NUMERIC_LABEL_SUFFIXES) and not _is_number(value)):
            raise UserError(
                f"{where}: label {key[:40]!r} must be a number"
                if key.endswith(_NUMERIC_LABEL_SUFFIXES)
                else f"{where}: label {key[:40]!r} must be a number, true/false or text"
            )
    truth = row.get("truth")
    if truth is not None and not isinstance(truth, dict):
        raise UserError(f"{where}: field 'truth' must be an object or null")
    if row["frame"] is not None:
        row["frame"] = frame_inside(root, row["frame"], where)
    return row


def frame_inside(root: Path, frame, where: str) -> str:
    """`frame` (a sample's frame file name) if it names a file inside the run directory
    `root` (resolved, links followed); UserError naming the sample otherwise."""
    if not isinstance(frame, str) or not frame or "\0" in frame or len(frame) > 255:
        raise UserError(f"{where}: field 'frame' must be a file name inside the run directory or null")
    name = Path(frame)
    inside = not name.is_absolute() and ".." not in name.parts
    if inside:
        try:
            (root / name).resolve().relative_to(root)
        except (ValueError, OSError, RuntimeError):
            inside = False
    if not inside:
        raise UserError(f"{where}: field 'frame' names a file outside the run directory; refused")
    return frame
