"""Ctrl-C and SIGTERM held while a run must not be cut (twin.runs.interrupts): real signals,
sent to this process, land where the holder hands them on and nowhere else."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from twin.core.errors import Terminated
from twin.runs.interrupts import HeldSignals, signals_held, stop_signals_blocked


def _send(signum: int, held: HeldSignals) -> None:
    """`signum` to this whole process, then wait (at most 10 s) until `held` has noted it:
    the thread the kernel hands it to may not run at once on a loaded machine, and a
    signal handled only after the hold ends would land outside the test."""
    os.kill(os.getpid(), signum)
    deadline = time.monotonic() + 10.0
    while signum not in held._noted:
        assert time.monotonic() < deadline, f"{signal.Signals(signum).name} not noted within 10 s"
        time.sleep(0.001)


def test_a_held_ctrl_c_lands_where_it_is_delivered() -> None:
    reached = []
    with signals_held() as held:
        _send(signal.SIGINT, held)
        reached.append("after the signal")
        with pytest.raises(KeyboardInterrupt):
            held.deliver()
        held.deliver()  # handed on once
    assert reached == ["after the signal"]


def test_one_not_delivered_lands_on_leaving_and_the_handlers_are_back() -> None:
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        with signals_held() as held:
            _send(signal.SIGINT, held)
    assert signal.getsignal(signal.SIGINT) is before


def test_a_nested_hold_hands_its_signal_to_the_outer_one() -> None:
    with signals_held() as outer:
        with signals_held() as inner:
            _send(signal.SIGINT, inner)
        outer_got_it = True  # the inner hold's leaving did not raise
        with pytest.raises(KeyboardInterrupt):
            outer.deliver()
    assert outer_got_it


def test_sigterm_goes_to_the_programs_own_handler() -> None:
    def terminated(signum, frame):
        raise Terminated("SIGTERM")

    previous = signal.signal(signal.SIGTERM, terminated)
    try:
        with signals_held() as held:
            _send(signal.SIGTERM, held)
            with pytest.raises(Terminated):
                held.deliver()
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_held_even_when_another_thread_takes_the_signal() -> None:
    """The kernel gives a process-wide signal to a thread that does not block it; with the
    main thread blocking it, that is the other thread, and Python still runs the handler
    on the main thread: a mask alone would not have held it."""
    stop = threading.Event()
    taker = threading.Thread(target=stop.wait)
    taker.start()
    reached = []
    try:
        with signals_held() as held, stop_signals_blocked():
            _send(signal.SIGINT, held)
            reached.append("the block's end")
    except KeyboardInterrupt:
        reached.append("interrupted on leaving")
    finally:
        stop.set()
        taker.join()
    assert reached == ["the block's end", "interrupted on leaving"]


def test_off_the_main_thread_nothing_is_held() -> None:
    seen = []

    def in_a_thread() -> None:
        with signals_held() as held:
            held.deliver()
            seen.append(signal.getsignal(signal.SIGINT))

    thread = threading.Thread(target=in_a_thread)
    thread.start()
    thread.join()
    assert seen == [signal.getsignal(signal.SIGINT)]


def _sigterm_inside_a_c_callback() -> None:
    """What the interpreter raises where SIGTERM's handler ran inside a C extension's
    callback that then returned normally (numba's dispatcher unpickling a function)."""
    try:
        raise Terminated("SIGTERM")
    except Terminated as err:
        raise SystemError("<function _numba_unpickle> returned a result with an exception set") from err


def test_a_sigterm_arriving_as_a_systemerror_is_still_a_sigterm(tmp_path, capsys) -> None:
    """The CLI exits 143 for it, not 1 (an internal error), and a run it stops is marked
    interrupted by SIGTERM, its samples kept, with Terminated raised on."""
    from twin.core.scenario import load_scenario
    from twin.runs.record import RunRecorder, load_run
    from twin.tools.boundary import EXIT_SIGTERM, guarded

    assert guarded(_sigterm_inside_a_c_callback) == EXIT_SIGTERM
    assert "stopped by SIGTERM" in capsys.readouterr().err
    with pytest.raises(Terminated):
        with RunRecorder(tmp_path / "run", load_scenario("rectangle_render"), seed=0, backend="sim"):
            _sigterm_inside_a_c_callback()
    run = load_run(tmp_path / "run")
    assert run.meta["status"] == "interrupted" and run.meta["error"] == "SIGTERM"
    with pytest.raises(SystemError):  # any other SystemError stays what it is
        with RunRecorder(tmp_path / "other", load_scenario("rectangle_render"), seed=0, backend="sim"):
            raise SystemError("a real fault")
    assert load_run(tmp_path / "other").meta["status"] == "failed"
