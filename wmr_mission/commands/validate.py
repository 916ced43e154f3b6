"""``wmr-mission validate``: check mission and campaign files without running them."""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Literal

from wmr_mission.commands import start_up_done
from wmr_mission.spec.checks import importing_entries
from wmr_mission.spec.loader import Diagnostic, unreadable
from wmr_mission.terminal import shown

__all__ = ["validate_files"]

MISSION_SUFFIXES = (".yaml", ".yml")


def _summary(diagnostics: Sequence[Diagnostic], strict: bool) -> str:
    counts = {s: sum(d.severity == s for d in diagnostics) for s in ("error", "warning", "note")}
    counted = [_count(n, severity) for severity, n in counts.items() if n]
    if counts["error"] == 0 and not (strict and counts["warning"]):
        return "ok" if not counted else f"ok ({', '.join(counted)})"
    if counts["error"] == 0:
        return f"{', '.join(counted)}: warnings are errors under --strict"
    if not any(d.stage == "semantics" for d in diagnostics):
        # The checks across fields need a mission whose every field is sound.
        counted.append("checks across fields (observability, timing, paths) run once fixed")
    return ", ".join(counted)


def _count(number: int, word: str) -> str:
    return f"{number} {word}{'s' if number != 1 else ''}"


# An argument that names nothing: a usage error (exit 2), said with the
# others; the files given are checked all the same.
MISSING = "no such file or directory"
# A directory without mission files: an invalid argument (exit 1), not a usage error.
NO_FILES = "no mission files (*.yaml, *.yml) below it"


def mission_files(paths: Sequence[Path]) -> tuple[list[Path], list[Diagnostic]]:
    """Files as given; a directory stands for every ``*.yaml`` and ``*.yml`` below
    it, in sorted order."""
    files: list[Path] = []
    problems = []
    for path in paths:
        try:  # said with the others, so that --format json has it
            path.stat()
        except OSError as error:  # none, or not to be looked at (EACCES, a link loop)
            why = MISSING if isinstance(error, FileNotFoundError) else error.strerror
            problems.append(Diagnostic(str(path), 0, 0, str(why or error).lower()))
            continue
        if not path.is_dir():
            files.append(path)
            continue
        found = sorted(p for p in path.rglob("*") if p.suffix in MISSION_SUFFIXES and p.is_file())
        if not found:
            problems.append(Diagnostic(str(path), 0, 0, NO_FILES))
        files += found
    return files, problems


def validate_files(
    paths: Sequence[Path],
    fmt: Literal["text", "json"] | str = "text",
    check_entries: bool = False,
    strict: bool = False,
) -> int:
    """Check every file; 0 when all are valid (warnings allowed unless
    ``strict``; notes always), 1 otherwise, 2 when an argument names nothing
    or a file cannot be read, a device (the others checked all the same).

    A directory stands for every ``*.yaml`` and ``*.yml`` below it. A ``type:
    python`` entry is checked for its syntax only, unless ``check_entries``:
    then it is imported, as a run imports it (its module's code runs).

    text: each diagnostic as ``FILE:LINE:COL: message``, then one ``FILE: ok``
    (or a count) line per file, all on stdout, the report of the command (so
    that ``> report.txt`` keeps all of it, as with a linter). json: one
    document on stdout with every file, its validity and its diagnostics.
    """
    files, problems = mission_files(paths)
    reports = []
    all_valid = not problems
    cannot_read = False  # a file named that cannot be read (a device): an I/O fault
    if fmt == "text":
        for problem in problems:
            sys.stdout.write(f"{problem}\n")
    for path in files:
        from wmr_mission.campaign.load import check_file  # a mission or a campaign

        with importing_entries() if check_entries else nullcontext():
            diagnostics = check_file(path)
        start_up_done()  # the first file has imported and built what the others use
        failing = ("error", "warning") if strict else ("error",)
        valid = not any(d.severity in failing for d in diagnostics)
        all_valid = all_valid and valid
        cannot_read = cannot_read or unreadable(diagnostics)
        reports.append((str(path), valid, diagnostics))
        if fmt == "text":
            for diagnostic in diagnostics:
                sys.stdout.write(f"{diagnostic}\n")
            # one line, whatever the file's name holds (as the diagnostics above)
            sys.stdout.write(f"{shown(str(path), None)}: {_summary(diagnostics, strict)}\n")
    if fmt == "json":
        document = {
            "valid": all_valid,
            "strict": strict,
            "problems": [d._asdict() for d in problems],
            "files": [
                {
                    "file": name,
                    "valid": valid,
                    "diagnostics": [d._asdict() for d in diagnostics],
                }
                for name, valid, diagnostics in reports
            ],
        }
        sys.stdout.write(json.dumps(document, indent=2) + "\n")
    if cannot_read or any(problem.message != NO_FILES for problem in problems):
        return 2  # a path that names nothing, or cannot be looked at or read: a usage error
    return 0 if all_valid else 1
