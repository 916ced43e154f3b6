"""A record (a run's, a campaign's, a falsification's) is never written over by
a file the user names.

``view --out`` and ``export --out`` write a file where they are told; this is
their one check, symbolic links followed: inside a record, they write neither
over its files, its figures nor any file it holds (a falsification's failing
missions, a campaign's worst runs), nor one record's output into another
record's directory, where it would pass for that record's; outside one, they
write over no file but an earlier output of their own kind (a report over a
report: not a mission, a table or a script the user named by mistake), and
never a device or a pipe (``--out /dev/null``); a symbolic link is written
through, never replaced.
(``run --out`` and ``sweep --out`` name a directory, which they only ever take
new or empty: wmr_mission.output.rundir.prepare_run_dir.)
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Final

from wmr_mission.campaign.falsify.files import EVALUATIONS_FILE, FALSIFY_FILE
from wmr_mission.campaign.sweep import CAMPAIGN_FILE, RUNS_FILE
from wmr_mission.output.rundir import (
    ANIMATION_FILE,
    CLAIM_FILE,
    MANIFEST_FILE,
    SUMMARY_FILE,
    TRAJECTORY_FILE,
    TRANSITIONS_FILE,
)

__all__ = ["record_file_refusal", "written_at"]

# Each kind of record: the files that tell it (any one), and the files it holds.
_RUN: Final = (TRAJECTORY_FILE, SUMMARY_FILE, TRANSITIONS_FILE, MANIFEST_FILE, ANIMATION_FILE)
_KINDS: Final = (
    ("campaign", (RUNS_FILE, CAMPAIGN_FILE), (RUNS_FILE, CAMPAIGN_FILE, MANIFEST_FILE)),
    (
        "falsification",
        (EVALUATIONS_FILE, FALSIFY_FILE),
        (EVALUATIONS_FILE, FALSIFY_FILE, MANIFEST_FILE),
    ),
    ("run", (*_RUN, CLAIM_FILE), _RUN),
)
# The figures a record draws into its directory (png, svg, pdf).
_FIGURES: Final = (".png", ".svg", ".pdf")
# What view and export write: such a file already in a record is an earlier
# output, written over again; any other file there is the record's.
_OUTPUTS: Final = (".html", ".mcap", ".parquet")
# How far above a file its record may be: a falsification's failing/N.yaml.
_DEPTH: Final = 2


def _record_of(directory: Path) -> tuple[str, tuple[str, ...]] | None:
    """What ``directory`` is the record of, and the names of its files."""
    for kind, tells, names in _KINDS:
        if any((directory / name).is_file() for name in tells):
            return kind, (*names, CLAIM_FILE)
    return None


def written_at(target: Path) -> Path:
    """Where an output named ``target`` is written: through its symbolic links,
    never in place of one (a loop of links left as it is: writing there fails
    in one line)."""
    return Path(os.path.realpath(target))


def record_file_refusal(
    target: Path,
    source: Path,
    default_name: str,
    earlier: Callable[[Path], bool] | None = None,
) -> str | None:
    """One line refusing ``target`` when writing it would replace a file of a
    record, put the output of ``source`` (named ``default_name`` by default)
    into another record's directory, or replace a file that is not an earlier
    output of that kind (its suffix not ``default_name``'s, or, where
    ``earlier`` is given, a file it does not tell for one), or replace what is
    not a file at all: a device, a pipe (``/dev/null``); else None. The
    output is written at ``target.resolve()``: through a symbolic link, never
    in place of it (:func:`written_at`)."""
    final = written_at(target)
    if final.is_symlink():  # what realpath leaves a link is a loop of them
        return (
            f"{target}: is a loop of symbolic links, which the output would replace: "
            "choose another --out"
        )
    linked = final != Path(os.path.abspath(target))
    through = f" (through a symbolic link: {final})" if linked else ""
    if final.exists() and not (final.is_file() or final.is_dir()):
        return (
            f"{target}: is not a file (a device, a pipe or a socket){through}, which the "
            "output would replace: choose another --out"
        )
    for directory in list(final.parents)[:_DEPTH]:
        record = _record_of(directory)
        if record is None:
            continue
        kind, names = record
        own = directory == final.parent
        where = "" if own else f" (in {final.parent.name}/)"
        held = final.is_file() and final.suffix.lower() not in _OUTPUTS
        if held or (own and (final.name in names or final.suffix.lower() in _FIGURES)):
            return (
                f"{target}: is {final.name} of the {kind} in {directory}{where}{through}; "
                "a record is never written over: choose another --out"
            )
        if directory != source.resolve():
            return (
                f"{target}: is in the directory of the {kind} in {directory}{where}{through}, "
                f"which keeps its own outputs, not {source}'s; choose another --out"
            )
        break
    suffix = Path(default_name).suffix
    if final.is_file() and (
        final.suffix.lower() != suffix or (earlier is not None and not earlier(final))
    ):
        return (
            f"{target}: is a file already, not an earlier {suffix} output{through}; "
            "it is never written over: choose another --out, or remove it first"
        )
    return None
