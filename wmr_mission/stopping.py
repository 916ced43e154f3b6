"""SIGINT and SIGTERM, caught so that a command stops with its record written.

While a :class:`StopSignals` is active, each signal is noted and, as it
comes, acted on by the mode the command is in:

* ``RAISE`` (the default): ``KeyboardInterrupt`` at once, as Ctrl-C does, so
  that SIGTERM stops a command the way Ctrl-C does;
* ``GENTLE``, a campaign's runs: the first signal only sets
  :attr:`StopSignals.stopped`, and the campaign stops between two tasks,
  keeping every finished run; a second raises;
* ``HOLD``, while the record of what ran is written, or while code runs that
  a ``KeyboardInterrupt`` must not strike (numba's dispatcher loses or delays
  one raised inside it; an import turns one into an ``ImportError`` that
  libraries swallow): noted only; the command looks at
  :attr:`StopSignals.stopped` or :func:`stop_owed` after.

A stop that a mode other than GENTLE's first signal would raise is *owed*
(:attr:`StopSignals.owed`) from the moment it comes, whether it was held or
raised and swallowed on its way: a run checks :func:`stop_owed` between
chunks of samples (wmr_mission.sim.runner), so no stop is ever lost.
:func:`mode` sets the mode of every active :class:`StopSignals` but a
campaign's for a stretch of code.

A stop raised where Python cannot propagate it, inside a callback from C
(numba compiling a kernel calls llvmlite's ctypes callbacks), is dropped
there without the "Exception ignored" report Python would print; it is owed
all the same.

The command then exits 128 + the first signal's number (130, 143), as a
shell reports it. Outside the main thread (a library call from a thread)
signals cannot be handled and stay as they are.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Final, Literal

__all__ = ["GENTLE", "HOLD", "RAISE", "STOP_SIGNALS", "StopSignals", "mode", "stop_owed"]

STOP_SIGNALS: Final = (signal.SIGINT, signal.SIGTERM)

Mode = Literal["raise", "gentle", "hold"]
RAISE: Final = "raise"
GENTLE: Final = "gentle"
HOLD: Final = "hold"


class StopSignals:
    """``signals`` caught while active (by default Ctrl-C only, as for a library call)."""

    def __init__(self, signals: Sequence[int] = (signal.SIGINT,), mode: Mode = RAISE) -> None:
        self.signals = tuple(signals)
        self.received: list[int] = []
        # Set before the handlers are: a signal the instant they are installed
        # acts by this mode (set after, a stop there raised where none may).
        self.mode: Mode = mode
        # Told of the first signal as it comes (a campaign says at once that it stops).
        self.notify: Callable[[], None] | None = None
        # A signal came that stops the command, raised or held (see the module).
        self.owed = False
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            self._previous = {n: signal.signal(n, self._on_signal) for n in self.signals}
            if not _active:
                _hooks.append(sys.unraisablehook)
                sys.unraisablehook = _owed_stop_is_not_reported
            _active.append(self)
        return self

    def __exit__(self, *_: object) -> None:
        for number, handler in self._previous.items():
            signal.signal(number, handler)
        if self._previous:
            _active.remove(self)
            if not _active:
                sys.unraisablehook = _hooks.pop()
        self._previous = {}

    @property
    def stopped(self) -> bool:
        return bool(self.received)

    @property
    def name(self) -> str:
        """How the stop is told: ``Ctrl-C`` for SIGINT, else the signal's name."""
        number = self.received[0] if self.received else signal.SIGINT
        return "Ctrl-C" if number == signal.SIGINT else signal.Signals(number).name

    @property
    def exit_code(self) -> int:
        """128 + the first signal's number (130 when the stop was a
        ``KeyboardInterrupt`` raised without a signal)."""
        return 128 + (self.received[0] if self.received else signal.SIGINT)

    def _on_signal(self, number: int, frame: object) -> None:
        self.received.append(number)
        first = len(self.received) == 1
        if first and self.notify is not None:
            self.notify()
        if self.mode == GENTLE and first:
            return
        self.owed = True
        if self.mode == HOLD:
            return
        raise KeyboardInterrupt


# The StopSignals active in the main thread, the innermost last.
_active: list[StopSignals] = []
# sys.unraisablehook as it was before the first of them.
_hooks: list[Callable[[Any], object]] = []


def _owed_stop_is_not_reported(unraisable: Any) -> None:
    """A stop raised where it cannot propagate, inside a callback from C (numba
    compiling or loading a kernel calls llvmlite's ctypes callbacks), is
    dropped there: Python would print it as "Exception ignored ...
    KeyboardInterrupt" with a traceback. It is owed all the same, and taken
    at the command's next :func:`stop_owed`. Anything else is reported as before."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt) and any(s.owed for s in _active):
        return
    (_hooks[-1] if _hooks else sys.__unraisablehook__)(unraisable)


def stop_owed() -> bool:
    """Whether an active :class:`StopSignals` received a stop it has to honour."""
    if _active:
        # Run the handlers of signals caught but not yet handled: Python runs
        # them in the main thread only when it notices, and a signal that
        # another thread took (the process has threads Python did not start,
        # e.g. numpy's BLAS) went unnoticed for seconds, or to the end of a
        # run. pthread_kill checks for them after sending; signal 0 sends nothing.
        signal.pthread_kill(threading.main_thread().ident or 0, 0)
    return any(stop.owed for stop in _active)


@contextmanager
def mode(chosen: Mode) -> Iterator[None]:
    """Every active :class:`StopSignals` in ``chosen`` mode (RAISE or HOLD) for
    the block, a campaign's (GENTLE) left as it is; the modes restored after."""
    changed = [(stop, stop.mode) for stop in _active if stop.mode != GENTLE]
    for stop, _ in changed:
        stop.mode = chosen
    try:
        yield
    finally:
        for stop, before in changed:
            stop.mode = before
