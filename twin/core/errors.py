"""Exceptions shared by every stage. The CLI maps UserError to exit code 2."""

from __future__ import annotations


class TwinError(Exception):
    """Base of every error the twin raises on purpose."""


class UserError(TwinError):
    """Bad input from the user: a malformed scenario, a missing file, a bad value.

    The message names the file, the field and the offending value; the CLI prints it
    without a traceback and exits with code 2.
    """


class UnreachablePoseError(UserError):
    """A sensor pose that the arm cannot reach or that violates the joint limits."""


class PhysicsError(TwinError):
    """The simulation went wrong (diverged, penetrated, never settled, warned).

    Raised by the per-frame checks; never swallowed. The message names the scenario,
    the step, the pose and what failed.
    """


class SafetyError(UserError):
    """A command the hardware safety limits refuse; nothing was sent to the robot."""


class HardwareError(TwinError):
    """The real rig failed: robot connection lost, camera gave no or a stale frame."""


class WorkerLostError(TwinError):
    """A local worker process ended without finishing its job (killed: the kernel's
    out-of-memory killer sends SIGKILL). The run stops at once (records kept); the message
    names the process and how it ended."""

    def going_on(self, how: str) -> WorkerLostError:
        """The same loss, its message ending with how the caller's work goes on (`how`)."""
        return WorkerLostError(f"{self}; {how} (with fewer --workers where memory ran out)")


class LostPinsError(TwinError):
    """Too many pins could not be tracked in a frame: the run stops (records kept)."""


class MistrackedPinsError(LostPinsError):
    """A simulated frame's tracked pins lie off their true positions (a pin took a
    neighbour's blob): the run stops (records kept). Only a simulation knows; a real
    sensor's tracker cannot tell."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (job schedulers, Ray, `timeout`, `kill`): handled like Ctrl-C — the run
    stops, keeps everything recorded and is marked "interrupted"; the CLI exits 143."""


def interruption(err: BaseException | None) -> KeyboardInterrupt | None:
    """The Ctrl-C or SIGTERM behind `err`, or None. A signal's handler raises in whatever
    Python code runs when it arrives, including a callback inside a C extension (numba's
    dispatcher unpickling a function), which then reports a SystemError caused by it."""
    while isinstance(err, SystemError):
        err = err.__cause__ or err.__context__
    return err if isinstance(err, KeyboardInterrupt) else None
