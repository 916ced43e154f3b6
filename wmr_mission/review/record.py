"""A run's or a campaign's record is never written over by a file the user names.

``view --out`` and ``export --out`` write a file wherever they are told; this is
their one check, symbolic links followed. (``run --out`` and ``sweep --out``
name a directory, which they only ever take new or empty:
wmr_mission.output.rundir.prepare_run_dir.)
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Final

from wmr_mission.campaign.sweep import CAMPAIGN_FILE, RUNS_FILE
from wmr_mission.output.rundir import (
    ANIMATION_FILE,
    CLAIM_FILE,
    MANIFEST_FILE,
    SUMMARY_FILE,
    TRAJECTORY_FILE,
    TRANSITIONS_FILE,
)

__all__ = ["record_file_refusal"]

_RUN: Final = (TRAJECTORY_FILE, SUMMARY_FILE, TRANSITIONS_FILE, MANIFEST_FILE, ANIMATION_FILE)
_CAMPAIGN: Final = (RUNS_FILE, CAMPAIGN_FILE, MANIFEST_FILE)
# The figures a run or a campaign draws into its directory (png, svg, pdf).
_FIGURES: Final = (".png", ".svg", ".pdf")


def _record_of(directory: Path) -> tuple[str, tuple[str, ...]] | None:
    """What ``directory`` is the record of, and the names of its files."""
    if any((directory / name).is_file() for name in _CAMPAIGN[:2]):
        return "campaign", (*_CAMPAIGN, CLAIM_FILE)
    if any((directory / name).is_file() for name in (*_RUN, CLAIM_FILE)):
        return "run", (*_RUN, CLAIM_FILE)
    return None


def record_file_refusal(target: Path) -> str | None:
    """One line refusing ``target`` when writing it would replace a file of a run's
    or a campaign's record (its data, its figures, its claim), else None."""
    final = target.resolve()
    record = _record_of(final.parent)
    if record is None:
        return None
    kind, names = record
    if final.name not in names and final.suffix.lower() not in _FIGURES:
        return None
    linked = final != Path(os.path.abspath(target))
    through = f" (through a symbolic link: {final})" if linked else ""
    return (
        f"{target}: is {final.name} of the {kind} in {final.parent}{through}; "
        "a record is never written over: choose another --out"
    )
