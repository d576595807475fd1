"""One process at a time: an exclusive lock on a file, held for a block, that another
process waits for (POSIX `flock`; it ends with the process that holds it, however that
process ends)."""

from __future__ import annotations

import contextlib
import fcntl
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from twin.core.errors import UserError


@contextlib.contextmanager
def held_exclusively(path: Path, on_wait: Callable[[], None] | None = None) -> Iterator[None]:
    """Hold the exclusive lock on `path` (created if missing, never deleted: a deleted
    lock file would let a third process lock a new file while the second holds the old)
    for the block; if another process holds it, call `on_wait` once, then wait for it.
    UserError where the file cannot be made."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as err:
        raise UserError(f"{path}: cannot take the lock ({err.strerror})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if on_wait is not None:
                on_wait()
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing the last descriptor drops the lock
