"""Holding Ctrl-C (SIGINT) and SIGTERM back while a run does something that must not be
cut: writing a sample's line, handing a worker's chunk over, waiting for workers to start.

A blocked signal mask does not hold them. The kernel gives a process-wide signal to any
thread that does not block it, and Python then runs the handler on the main thread at
its next bytecode, whatever the main thread's mask. Libraries start such threads before
any run code does (EGL's, OpenBLAS's, tqdm's), so a main thread that blocks the signals
is interrupted anyway. They are held by handler instead: while held, a signal is noted,
and the holder hands it on (`HeldSignals.deliver`) where an interruption can be taken.

Child processes are another matter: they inherit the mask of the thread that starts
them, and a worker that inherits the signals blocked cannot be killed by a Ctrl-C meant
for its parent while it starts (`stop_signals_blocked`).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

#: The signals that stop a run: Ctrl-C and SIGTERM (twin.core.errors.Terminated)
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class HeldSignals:
    """SIGINT and SIGTERM noted while held, not handled (`signals_held`)."""

    def __init__(self) -> None:
        self._noted: list[int] = []
        self._previous: dict[int, object] = {}

    def _note(self, signum: int, frame) -> None:
        self._noted.append(signum)

    def _hold(self) -> None:
        """Note the signals from now on; the handlers in place are kept for `deliver`."""
        self._previous = {s: signal.signal(s, self._note) for s in STOP_SIGNALS}

    def _release(self) -> None:
        """Put the handlers back and hand on what is still noted."""
        for signum, handler in self._previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)
        self.deliver()

    def deliver(self) -> None:
        """Hand the signals noted so far to the handlers in place before: a SIGINT raises
        KeyboardInterrupt here, a SIGTERM what the program's handler raises
        (twin.core.errors.Terminated). Nothing noted, nothing happens."""
        noted, self._noted = self._noted, []
        for signum in dict.fromkeys(noted):
            handler = self._previous[signum]
            if callable(handler):
                handler(signum, None)
            elif handler != signal.SIG_IGN:  # the default action (or a handler set outside Python): as if not held
                signal.signal(signum, signal.SIG_DFL)
                signal.raise_signal(signum)


@contextlib.contextmanager
def signals_held() -> Iterator[HeldSignals]:
    """Inside, SIGINT and SIGTERM are noted, not handled; `deliver()` hands them on where
    the caller chooses, and on leaving the rest are handed on to the handlers restored.
    Nested holds hand theirs to the outer one. Off the main thread, where Python runs no
    handler, there is nothing to hold."""
    held = HeldSignals()
    if threading.current_thread() is not threading.main_thread():
        yield held
        return
    held._hold()
    try:
        yield held
    finally:
        held._release()


@contextlib.contextmanager
def stop_signals_blocked() -> Iterator[None]:
    """Inside, this thread blocks SIGINT and SIGTERM, and so does every process it starts
    (a forkserver, and the workers forked from it), for good: a Ctrl-C to the process
    group then stops the parent alone, which decides what the workers finish."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
