"""Where the twin's shipped data and its caches live.

Shipped data (the MJCF/mesh assets and the scenario files) is package data: a wheel
carries it under ``twin/_data`` and it is read through ``importlib.resources``. In a
source checkout the same files are the repository's top-level ``assets/`` and
``scenarios/`` folders, which the package finds beside itself.

Caches (trained tap models, the compliant dome's influence matrices) go to the user
cache directory (``platformdirs``), or to ``$TWIN_CACHE`` when that is set; never into
the source tree. Each cache entry is keyed on what it depends on, the package version and
the code that computes it (`code_digest`: an edit to the code misses the cache, one to a
comment or docstring does not); a kind of cached arrays keeps at most KIND_LIMIT_BYTES, the
least recently used going first, and a search's candidates (`searching`: a calibration's
materials) are kept apart, so that they never push out what users run.
"""

from __future__ import annotations

import ast
import contextlib
import contextvars
import functools
import hashlib
import io
import json
import os
import warnings
import zipfile
from collections.abc import Callable, Iterator
from importlib import metadata, resources
from pathlib import Path

import numpy as np
import platformdirs

from twin.core.files import replace_file

PACKAGE = "tactip-twin"
CACHE_ENV = "TWIN_CACHE"


def data_root() -> Path:
    """The folder holding ``assets/`` and ``scenarios/``: package data in a wheel, the
    repository root in a source checkout."""
    packaged = resources.files("twin") / "_data"
    if packaged.is_dir():
        return Path(str(packaged))
    checkout = Path(__file__).resolve().parents[2]
    if (checkout / "assets").is_dir():
        return checkout
    raise FileNotFoundError("the twin's assets are missing: neither twin/_data nor a source checkout's assets/")


def asset_path(*parts: str) -> Path:
    """A shipped asset, e.g. ``asset_path("irb120", "irb120.xml")``."""
    return data_root().joinpath("assets", *parts)


def scenario_path(name: str) -> Path:
    """A shipped scenario file by name (``taps_rectangle`` or ``taps_rectangle.yaml``)."""
    return data_root() / "scenarios" / (name if name.endswith(".yaml") else f"{name}.yaml")


def shipped_scenarios() -> list[Path]:
    """Every shipped scenario file, sorted by name."""
    return sorted((data_root() / "scenarios").glob("*.yaml"))


def cache_dir() -> Path:
    """The twin's cache directory: ``$TWIN_CACHE`` or the user cache directory."""
    override = os.environ.get(CACHE_ENV)
    return Path(override) if override else platformdirs.user_cache_path(PACKAGE)


def package_version() -> str:
    """The installed version of the twin (part of every cache key)."""
    try:
        return metadata.version(PACKAGE)
    except metadata.PackageNotFoundError:
        return "0+unknown"


@functools.cache
def code_digest(*paths: Path) -> str:
    """16 hex digits that change with the code in `paths` (Python files, or folders read
    recursively in name order) and not with its comments, docstrings or layout: the hash
    of each module's syntax tree with the docstrings taken out, and of its path relative
    to the folder named."""
    digest = hashlib.sha256()
    for root in paths:
        root = Path(root)
        files = sorted(root.rglob("*.py")) if root.is_dir() else [root]
        for file in files:
            tree = ast.parse(file.read_text(encoding="utf-8"), filename=str(file))
            for node in ast.walk(tree):
                body = getattr(node, "body", None)
                if (
                    isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                    and body
                    and isinstance(body[0], ast.Expr)
                    and isinstance(body[0].value, ast.Constant)
                    and isinstance(body[0].value.value, str)
                ):
                    node.body = body[1:] or [ast.Pass()]
            digest.update(str(file.relative_to(root) if root.is_dir() else file.name).encode())
            digest.update(ast.dump(tree).encode())
    return digest.hexdigest()[:16]


#: What one kind of cached arrays may keep on disk (B); beyond it the least recently used
#: entries go (entries of older package versions and code are never used again).
KIND_LIMIT_BYTES = 2 * 2**30
#: What a search's candidates may keep of one kind (B; `searching`).
SEARCH_LIMIT_BYTES = 512 * 2**20
#: The folder inside a kind's that holds a search's candidates (`searching`).
SEARCH_FOLDER = "search"

_search_limit: contextvars.ContextVar[int | None] = contextvars.ContextVar("twin_cache_search", default=None)


@contextlib.contextmanager
def searching(limit_bytes: int = SEARCH_LIMIT_BYTES) -> Iterator[None]:
    """Inside, what `cached_arrays` computes is stored as a search's candidate (a
    calibration trying one dome material after another, each used about once): in the
    kind's SEARCH_FOLDER, which keeps at most `limit_bytes` (B) by its own
    least-recently-used rule, so that a search never evicts the kind's own entries (the
    models a user runs; a hold-angle calibration's 100 candidates of 47 MB each would).
    Entries are found in either folder, inside and outside."""
    token = _search_limit.set(limit_bytes)
    try:
        yield
    finally:
        _search_limit.reset(token)


def cached_arrays(
    kind: str,
    key: dict,
    compute: Callable[[], dict[str, np.ndarray]],
    shapes: dict[str, tuple[int, ...]],
    max_bytes: int = 256 * 2**20,
    refresh: bool = False,
    kind_limit_bytes: int = KIND_LIMIT_BYTES,
) -> dict[str, np.ndarray]:
    """Arrays computed once and kept in ``cache_dir()/kind``, keyed on `key` (JSON: what
    they depend on) and the package version. An entry that is missing, unreadable or not
    of the expected `shapes` is computed again and rewritten, and so is every entry when
    `refresh`; one larger than `max_bytes` (B) is computed every time instead of stored; a
    cache directory that cannot be written only warns. Entries are written to a temporary
    file and renamed, so parallel workers computing the same entry never read half of one.
    A stored entry makes room: the kind's least recently used entries (by modification
    time, which a load renews) are deleted until the kind holds at most `kind_limit_bytes`
    (B). Inside `searching`, what is computed goes to the kind's SEARCH_FOLDER instead,
    with that folder's own limit; an entry is found in either folder."""
    payload = json.dumps({"key": key, "version": package_version()}, sort_keys=True, default=str)
    home = cache_dir() / kind / f"{hashlib.sha256(payload.encode()).hexdigest()[:16]}.npz"
    search = home.parent / SEARCH_FOLDER / home.name
    search_limit = _search_limit.get()
    path, limit = (home, kind_limit_bytes) if search_limit is None else (search, search_limit)
    for place in () if refresh else (home, search):
        if place.exists():
            arrays = _load(place, shapes)
            if arrays is not None:
                return arrays
            with contextlib.suppress(OSError):
                place.unlink()  # damaged: replaced by the entry computed now
    arrays = compute()
    if sum(a.nbytes for a in arrays.values()) <= max_bytes:
        archive = io.BytesIO()
        np.savez(archive, **arrays)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            replace_file(path, archive.getvalue())
        except OSError as err:
            warnings.warn(f"{path}: could not store the cache entry ({err})", stacklevel=2)
        else:
            _evict_least_recently_used(path.parent, path, limit)
    return arrays


def _load(path: Path, shapes: dict[str, tuple[int, ...]]) -> dict[str, np.ndarray] | None:
    """The arrays stored at `path`, its use recorded (a load renews its modification time);
    None, with a warning, where it is unreadable or not of `shapes`."""
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = {name: stored[name] for name in shapes}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
        warnings.warn(f"{path}: unreadable cache entry ({err}); computing it again", stacklevel=2)
        return None
    if not all(arrays[name].shape == tuple(shape) for name, shape in shapes.items()):
        warnings.warn(f"{path}: cache entry of the wrong shape; computing it again", stacklevel=2)
        return None
    with contextlib.suppress(OSError):
        os.utime(path)  # used now: the last to go
    return arrays


def _evict_least_recently_used(folder: Path, keep: Path, limit_bytes: int) -> None:
    """Delete the oldest entries of `folder` (never `keep`) until it holds ≤ `limit_bytes`.
    Another process may delete the same file first: that is not an error."""
    entries = []
    for entry in folder.glob("*.npz"):
        with contextlib.suppress(OSError):
            info = entry.stat()
            entries.append((info.st_mtime, info.st_size, entry))
    total = sum(size for _, size, _ in entries)
    for _, size, entry in sorted(entries):
        if total <= limit_bytes:
            break
        if entry != keep:
            with contextlib.suppress(OSError):
                entry.unlink()
            total -= size
