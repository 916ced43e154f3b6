"""SIGINT and SIGTERM, caught so that a command stops with its record written.

While a :class:`StopSignals` is active, each signal is noted and, as it
comes, acted on by the mode the command is in:

* ``RAISE`` (the default): ``KeyboardInterrupt`` at once, as Ctrl-C does, so
  that SIGTERM stops a command the way Ctrl-C does;
* ``GENTLE``, a campaign's runs: the first signal only sets
  :attr:`StopSignals.stopped`, and the campaign stops between two tasks,
  keeping every finished run; a second raises;
* ``HOLD``, while the record of what ran is written: noted only, so that no
  signal cuts the record; the command looks at :attr:`StopSignals.stopped`
  after.

The command then exits 128 + the first signal's number (130, 143), as a
shell reports it. Outside the main thread (a library call from a thread)
signals cannot be handled and stay as they are.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Sequence
from typing import Any, Final, Literal

__all__ = ["GENTLE", "HOLD", "RAISE", "STOP_SIGNALS", "StopSignals"]

STOP_SIGNALS: Final = (signal.SIGINT, signal.SIGTERM)

Mode = Literal["raise", "gentle", "hold"]
RAISE: Final = "raise"
GENTLE: Final = "gentle"
HOLD: Final = "hold"


class StopSignals:
    """``signals`` caught while active (by default Ctrl-C only, as for a library call)."""

    def __init__(self, signals: Sequence[int] = (signal.SIGINT,)) -> None:
        self.signals = tuple(signals)
        self.received: list[int] = []
        self.mode: Mode = RAISE
        # Told of the first signal as it comes (a campaign says at once that it stops).
        self.notify: Callable[[], None] | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            self._previous = {n: signal.signal(n, self._on_signal) for n in self.signals}
        return self

    def __exit__(self, *_: object) -> None:
        for number, handler in self._previous.items():
            signal.signal(number, handler)
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
        if len(self.received) == 1 and self.notify is not None:
            self.notify()
        if self.mode == HOLD or (self.mode == GENTLE and len(self.received) == 1):
            return
        raise KeyboardInterrupt
