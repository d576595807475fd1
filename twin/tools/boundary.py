"""The command line's one error boundary: every way a command can end becomes an exit
code and one line on stderr, never a traceback.

| ends with                                   | exit | stderr                                          |
|---------------------------------------------|------|-------------------------------------------------|
| success                                     | 0    |                                                 |
| a user's mistake (UserError, bad argument,  | 2    | `error: ` + the file, field or value            |
| a path that cannot be written or read)      |      |                                                 |
| a failed run (TwinError), a full disk       | 1    | `failed: ` + what failed                        |
| an internal fault (any other exception)     | 1    | `internal error: ` + its type, and the log file |
|                                             |      | that holds its traceback (LOG_ENV or the cache) |
| Ctrl-C / SIGTERM                            | 130 / 143 | what was kept                              |
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import socket
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path

from twin.core.errors import Terminated, TwinError, UserError, interruption
from twin.core.resources import cache_dir

#: exit codes (README "What you can run")
EXIT_OK, EXIT_FAILED, EXIT_USER_ERROR, EXIT_SIGINT, EXIT_SIGTERM = 0, 1, 2, 130, 143
#: where internal faults' tracebacks go: this folder, else cache_dir()/logs
LOG_ENV = "TWIN_LOG_DIR"
#: OSErrors that say the path (or address) the user gave is wrong (exit 2); the others (a full disk, an
#: I/O error) are the machine's (exit 1)
_USER_PATH_ERRORS = {
    errno.ENOENT,
    errno.ENOTDIR,
    errno.EISDIR,
    errno.EACCES,
    errno.EPERM,
    errno.EROFS,
    errno.EEXIST,
    errno.ENAMETOOLONG,
    errno.ELOOP,
    errno.EINVAL,
    errno.ENXIO,
    errno.ENODEV,
    errno.ETXTBSY,
    errno.EADDRINUSE,
    errno.EADDRNOTAVAIL,
}
#: the longest value quoted back in a message (characters)
_QUOTE_MAX = 60


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose mistakes are a UserError (one line, exit 2), not usage and exit."""

    def error(self, message: str):
        raise UserError(f"{self.prog}: {message}")

    def exit(self, status: int = 0, message: str | None = None):
        """--help and --version end here: their exit is the parser's, not a plug-in's sys.exit."""
        if message:
            print(message, file=sys.stderr, end="")
        raise ParserExit(status)


class ParserExit(Exception):  # noqa: N818  (an ending, like SystemExit, not an error)
    """The parser finished the command itself (--help): exit with `status`."""

    def __init__(self, status: int) -> None:
        super().__init__(status)
        self.status = status


def quoted(value: object) -> str:
    """`value` as a message quotes it: repr, cut to _QUOTE_MAX characters."""
    text = repr(value)
    return text if len(text) <= _QUOTE_MAX else text[: _QUOTE_MAX - 1] + "…"


def bounded_int(lo: int, hi: int, unit: str) -> Callable[[str], int]:
    """An argparse type: an integer in [lo, hi] `unit`."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{quoted(text)} is not an integer") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{value} is outside [{lo}, {hi}] {unit}".rstrip())
        return value

    parse.__name__ = f"integer in [{lo}, {hi}]"
    return parse


def bounded_float(lo: float, hi: float, unit: str, open_lo: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number in [lo, hi] (or (lo, hi]) `unit`."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{quoted(text)} is not a number") from None
        if not math.isfinite(value) or value > hi or value < lo or (open_lo and value == lo):
            raise argparse.ArgumentTypeError(f"{value} is outside {'(' if open_lo else '['}{lo:g}, {hi:g}] {unit}")
        return value

    parse.__name__ = f"number in [{lo:g}, {hi:g}]"
    return parse


def output_file(path: Path, what: str, suffix: str) -> Path:
    """`path` if a `suffix` file can be written there (checked before any work: the suffix,
    its folder, created if missing, no link, not a folder itself); UserError naming it
    otherwise. A probe file is created and removed where none exists yet."""
    if "\0" in str(path):
        raise UserError(f"{what} {quoted(str(path))}: a path cannot hold a NUL character")
    if path.suffix.lower() != suffix:
        raise UserError(f"{what} {path}: name a {suffix} file")
    if path.is_symlink():
        raise UserError(f"{what} {path}: is a symbolic link; name the file itself")
    if path.is_dir():
        raise UserError(f"{what} {path}: is a folder; name a file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UserError(f"{what} {path}: its folder cannot be created ({err.strerror or type(err).__name__})") from None
    if path.exists():
        if not path.is_file() or not os.access(path, os.W_OK):
            raise UserError(f"{what} {path}: exists and cannot be overwritten")
        return path
    try:
        with open(path, "xb"):
            pass
        path.unlink()
    except OSError as err:
        raise UserError(f"{what} {path}: cannot be written ({err.strerror})") from None
    return path


def output_folder(path: Path, what: str) -> Path:
    """`path`, created if missing, checked before any work: UserError naming it where it
    is not a folder that can be written (a file, a file's child, a link out, /proc/...)."""
    if "\0" in str(path):
        raise UserError(f"{what} {quoted(str(path))}: a path cannot hold a NUL character")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UserError(
            f"{what} {path}: cannot be created as a folder ({err.strerror or type(err).__name__})"
        ) from None
    if not path.is_dir() or not os.access(path, os.W_OK | os.X_OK):
        raise UserError(f"{what} {path}: not a folder that can be written")
    return path


def guarded(call: Callable[[], int | None]) -> int:
    """Run a command; return its exit code, every ending mapped as the module says."""
    try:
        try:
            return int(call() or 0)
        except SystemError as err:  # a signal's handler raised inside a C extension's callback
            raise (interruption(err) or err) from None
    except ParserExit as done:
        return done.status
    except Terminated:
        print("stopped by SIGTERM; everything recorded so far is kept", file=sys.stderr)
        return EXIT_SIGTERM
    except KeyboardInterrupt:
        print("interrupted; everything recorded so far is kept", file=sys.stderr)
        return EXIT_SIGINT
    except UserError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_USER_ERROR
    except TwinError as err:
        print(f"failed: {type(err).__name__}: {err}", file=sys.stderr)
        return EXIT_FAILED
    except OSError as err:
        user = err.errno in _USER_PATH_ERRORS or isinstance(err, socket.gaierror)  # gaierror: an unknown --host
        where = f"{err.filename}: " if err.filename else ""
        print(f"{'error' if user else 'failed'}: {where}{err.strerror or err}", file=sys.stderr)
        return EXIT_USER_ERROR if user else EXIT_FAILED
    except ValueError as err:
        if "null byte" not in str(err):  # os and pathlib refuse a NUL in a path with a ValueError
            return _internal(err)
        print("error: a path or name given holds a NUL character", file=sys.stderr)
        return EXIT_USER_ERROR
    except SystemExit as stop:  # sys.exit() called by code the command ran (a plug-in controller)
        print(
            f"error: the command was ended from inside by sys.exit({quoted(stop.code)}) (a plug-in?); "
            "nothing after it ran",
            file=sys.stderr,
        )
        return EXIT_USER_ERROR
    except Exception as err:  # noqa: BLE001  (the boundary: an internal fault, its traceback to the log)
        return _internal(err)


def _internal(err: BaseException) -> int:
    """Report an internal fault: one line, its traceback to a log file; EXIT_FAILED."""
    print(f"internal error: {type(err).__name__}: {_first_line(err)} ({_log_traceback()})", file=sys.stderr)
    return EXIT_FAILED


def _first_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    line = text[0] if text else ""
    return line if len(line) <= 200 else line[:199] + "…"


def _log_traceback() -> str:
    """Write the exception being handled, with its traceback, to a new log file; "traceback
    in FILE", or why it could not be written."""
    folder = Path(os.environ.get(LOG_ENV) or cache_dir() / "logs")
    path = folder / f"twin-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.log"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with open(path, "a") as log:
            log.write(f"twin {' '.join(sys.argv[1:])}\n{traceback.format_exc()}\n")
    except OSError as err:
        return f"no log: {folder} cannot be written ({err.strerror})"
    return f"traceback in {path}"
