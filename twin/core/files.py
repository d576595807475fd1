"""Writing a file whole or not at all: under a temporary name in the same folder, then
renamed over the target, so a reader, a kill or a full disk never leaves half of one."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

#: What a temporary file's name ends with (`replace_file`); leftovers of a killed writer
#: carry it and are safe to delete.
TEMPORARY_SUFFIX = ".tmp"


def replace_file(path: Path, data: bytes | str) -> Path:
    """Write `data` (text as UTF-8) to `path` under a temporary name, then rename it over
    `path`: the file is whole, or as it was. Returns `path`."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}{TEMPORARY_SUFFIX}")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data.encode() if isinstance(data, str) else data)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path


def remove_leftovers(folder: Path) -> int:
    """Delete the temporary files a killed `replace_file` left in `folder`; how many."""
    removed = 0
    for leftover in Path(folder).glob(f".*{TEMPORARY_SUFFIX}"):
        with contextlib.suppress(OSError):
            leftover.unlink()
            removed += 1
    return removed
