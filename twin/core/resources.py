"""Where the twin's shipped data and its caches live.

Shipped data (the MJCF/mesh assets and the scenario files) is package data: a wheel
carries it under ``twin/_data`` and it is read through ``importlib.resources``. In a
source checkout the same files are the repository's top-level ``assets/`` and
``scenarios/`` folders, which the package finds beside itself.

Caches (trained tap models, compliance matrices) go to the user cache directory
(``platformdirs``), or to ``$TWIN_CACHE`` when that is set; never into the source tree.
Each cache entry is keyed on what it depends on, not on source text.
"""
from __future__ import annotations

import os
from importlib import metadata, resources
from pathlib import Path

import platformdirs

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
