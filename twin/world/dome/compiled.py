"""Numerical kernels compiled to machine code (numba, nopython), for the compliant dome's
per-increment work: many small vector operations that cost more in numpy than the
arithmetic they do.

The machine code is cached in the twin's cache folder (``numba/`` beside the other caches,
`twin.core.resources.cache_dir`; ``$NUMBA_CACHE_DIR`` takes its place where set): compiled
at the first call on a machine and loaded by every later process. numba checks it against
the source file's time stamp, so an edit to a kernel recompiles it.
"""

from __future__ import annotations

from collections.abc import Callable

import numba

from twin.core.resources import cache_dir

if not numba.config.CACHE_DIR:
    numba.config.CACHE_DIR = str(cache_dir() / "numba")


def compiled(function: Callable) -> Callable:
    """`function` compiled by numba in nopython mode, its machine code cached (module doc)."""
    return numba.njit(cache=True)(function)
