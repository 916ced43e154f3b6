"""How a campaign's command (``sweep``, ``falsify``) takes SIGINT and SIGTERM.

Once the command's runs have started, it stops them itself and keeps what
finished (its own ``StopSignals`` modes, wmr_mission.stopping). A signal
before the first run has nothing to keep: the command says so in one line
and exits 128 + the signal's number.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

from wmr_mission.stopping import STOP_SIGNALS, StopSignals, stop_owed

__all__ = ["stoppable"]


def stoppable(campaign_path: Path, command: Callable[[StopSignals], int]) -> int:
    """The exit code of ``command(stop)``, run with SIGINT and SIGTERM caught in
    ``stop``; a stop before its first run exits 130 or 143 with one line."""
    stop = StopSignals(STOP_SIGNALS)
    try:  # outside the block: a signal the instant the handlers are set is caught too
        with stop:
            if stop_owed():  # held since the command started
                raise KeyboardInterrupt
            return command(stop)
    except KeyboardInterrupt:
        print(
            f"{campaign_path}: interrupted by {stop.name} before the first run; "
            "nothing was written",
            file=sys.stderr,
        )
        return stop.exit_code
