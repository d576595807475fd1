"""Set-up shared by every test process (each xdist worker imports this first)."""

import signal
from collections.abc import Iterator
from pathlib import Path

import pytest

from twin.runs.interrupts import STOP_SIGNALS
from twin.runs.parallel import one_blas_thread

# like the CLI and its workers: one BLAS thread per process (twin.runs.parallel.one_blas_thread)
one_blas_thread()

# Tests send Ctrl-C to the commands they start, as a terminal would. A suite started in the
# background of a non-interactive shell (nohup …&, some CI runners) inherits SIGINT
# ignored, and so would those commands (an ignored signal stays ignored across exec);
# handled here, it is back to the default in every process a test starts.
signal.signal(signal.SIGINT, signal.default_int_handler)


def _signal_state() -> dict[str, object]:
    """The signal dispositions a test or a library can change for the tests after it on the
    same process: SIGINT's and SIGTERM's Python handlers, whether this (the main) thread
    blocks them and whether the kernel has a handler for them (a library can replace
    Python's behind its back), and whether the kernel ignores SIGPIPE (Python ignores it,
    so that a write to a closed pipe raises instead of killing the process)."""
    state: dict[str, object] = {}
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    caught, ignored = _kernel_masks()
    for signum in STOP_SIGNALS:
        name = signal.Signals(signum).name
        state[f"{name} handler"] = signal.getsignal(signum)
        state[f"{name} blocked"] = signum in blocked
        if caught is not None:
            state[f"{name} caught by the kernel"] = bool(caught >> (signum - 1) & 1)
    state["SIGPIPE handler"] = signal.getsignal(signal.SIGPIPE)
    if ignored is not None:
        state["SIGPIPE ignored by the kernel"] = bool(ignored >> (signal.SIGPIPE - 1) & 1)
    return state


def _kernel_masks() -> tuple[int | None, int | None]:
    """The process's caught and ignored signal masks as the kernel has them (Linux:
    /proc/self/status; None elsewhere)."""
    masks = {}
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(("SigCgt:", "SigIgn:")):
                masks[line[:6]] = int(line.split()[1], 16)
    except OSError:
        pass
    return masks.get("SigCgt"), masks.get("SigIgn")


#: this process's signal state once set up, which every test must find and leave
SIGNALS_AT_START = _signal_state()


def _signals_changed() -> dict[str, tuple[object, object]]:
    """What differs from SIGNALS_AT_START (name: (then, now)), which is then put back:
    the mask and the handlers (setting a handler sets the kernel's too)."""
    now = _signal_state()
    changed = {key: (then, now[key]) for key, then in SIGNALS_AT_START.items() if now[key] is not then}
    if changed:
        for signum in (*STOP_SIGNALS, signal.SIGPIPE):
            name = signal.Signals(signum).name
            if f"{name} blocked" in SIGNALS_AT_START:
                how = signal.SIG_BLOCK if SIGNALS_AT_START[f"{name} blocked"] else signal.SIG_UNBLOCK
                signal.pthread_sigmask(how, [signum])
            handler = SIGNALS_AT_START[f"{name} handler"]
            if handler is not None:  # None: set outside Python, which cannot be put back from here
                signal.signal(signum, handler)
    return changed


@pytest.fixture(autouse=True)
def _signals_kept() -> Iterator[None]:
    """Every test finds the process's signals as they were set up and leaves them so. A
    change reaches the tests after it on the same xdist worker: a Ctrl-C test handing a held
    SIGINT on to its default action, or a write to a closed pipe with SIGPIPE not ignored,
    kills the whole worker without a word, far from what changed it (gmsh's initialize
    does both: tests/world/bonded_gel.py). A change fails the test it is found at, naming
    it (one found at the start was made by a fixture set up for that test, or before it),
    and is put back."""
    changed = _signals_changed()
    assert not changed, f"signals found changed before the test (then, now): {changed}"
    yield
    changed = _signals_changed()
    assert not changed, f"the test left signals changed (then, now): {changed}"
