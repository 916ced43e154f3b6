"""The commands of the command line (wmr_mission.cli), a module each."""

from __future__ import annotations

import gc


def start_up_done() -> None:
    """The command has imported and checked what it needs: from here on
    Python's cyclic collector works, on what the command makes next.

    wmr_mission.cli.main turns the collector off as a command starts: the
    imports and the building of the mission's models make few cycles, and
    its collections would trace the objects imported again and again, numpy's
    and pydantic's among them (docs/performance.md, Start-up). What start-up
    made is frozen, never traced again."""
    if not gc.isenabled():
        gc.freeze()
        gc.enable()
