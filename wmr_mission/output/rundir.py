"""The run directory: create it, write a run's files (``reader`` reads them back).

| file | content |
|---|---|
| ``trajectory.csv`` | one row per sample (``wmr_mission.record.CSV_COLUMNS``) |
| ``manifest.json`` | mission file and hash, resolved mission, seed, versions, environment, run |
| ``transitions.json`` | each phase change |
| ``summary.json`` | metrics; written after the data: its presence means the data is complete |
| ``*.png``, ``animation.gif`` | figures (optional), drawn last |

Every file is written to a temporary file in the same directory, synced, and
renamed over its final name, so an interrupted run never leaves a half-written
file under a final name.

``trajectory.csv``: floats are written as ``%.12g``; a missing value (NaN,
e.g. ``x_ref`` outside track phases) is written ``nan`` and infinities
``inf``/``-inf``, which every CSV reader (numpy, pandas, Python ``float``)
reads back. ``phase`` holds the phase name; lines end with ``\\n``.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import os
import socket
from collections.abc import Callable, Iterator, Mapping, Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from wmr_mission.output.environment import environment, package_versions
from wmr_mission.output.files import atomic_path, json_text, write_json
from wmr_mission.record import INTEGER_COLUMNS, csv_columns
from wmr_mission.terminal import shown
from wmr_mission.verdicts.check import Check, margin_fields
from wmr_mission.verdicts.metrics import check_expectations, summarize
from wmr_mission.verdicts.recovery import recovery_record
from wmr_mission.verdicts.signals import mark_first_violations

if TYPE_CHECKING:
    from wmr_mission.record import RunRecord, Transition

TRAJECTORY_FILE = "trajectory.csv"
MANIFEST_FILE = "manifest.json"
TRANSITIONS_FILE = "transitions.json"
SUMMARY_FILE = "summary.json"
ANIMATION_FILE = "animation.gif"

_FLOAT_FORMAT = "%.12g"
# Rows formatted per `%` operation: one C-level formatting call per block keeps
# a 360 000-sample run to about a second and a half, and a block's Python
# numbers to a few megabytes.
_ROWS_PER_BLOCK = 4_000


# Its message leaves out the run directory: callers print `RUN_DIR: message`.
class RunDirExistsError(FileExistsError):
    """The run directory exists and holds files: a run never overwrites another."""


# Created exclusively in a run directory before the simulation starts, removed
# once summary.json is written: two runs never share a directory.
CLAIM_FILE = ".wmr-mission-run"
# Bytes of trajectory.csv per sample (17 columns of up to 19 characters), and of
# the figures and JSON files: the estimate checked against the free space.
_BYTES_PER_SAMPLE = 250
_BYTES_OTHER = 4_000_000


def default_run_dir(mission_name: str, now: datetime) -> Path:
    """``runs/<mission-name>-<YYYYmmdd-HHMMSS>``."""
    return Path("runs") / f"{mission_name}-{now:%Y%m%d-%H%M%S}"


def prepare_run_dir(path: str | os.PathLike[str], *, suffix_on_collision: bool = False) -> Path:
    """Create and claim the run directory before a long run; return it.

    The directory is created, or taken when it exists and is empty, and claimed
    by creating ``CLAIM_FILE`` exclusively in it: of two runs aimed at one
    directory at the same moment, exactly one gets it. The other gets
    ``RunDirExistsError``, or with ``suffix_on_collision`` the first free
    ``<path>-2``, ``<path>-3``, .... Creating the claim also proves the
    directory writable before anything is simulated.
    """
    run_dir = Path(path)
    if run_dir.is_symlink() and not run_dir.exists():
        raise RunDirExistsError(
            f"is a symbolic link to {os.readlink(run_dir)}, which does not exist; "
            "create the target or choose another --out"
        )
    record = _record_above(run_dir)
    if record is not None:
        raise RunDirExistsError(
            f"is inside the record in {record}, which keeps its own files; choose another --out"
        )
    for above in run_dir.parents:  # the nearest that exists: a file there is no place
        if above.is_dir():
            break
        # (looked at again: a run beside this one may have just made it a directory)
        if (above.exists() or above.is_symlink()) and not above.is_dir():
            message = f"{shown(str(above))} is not a directory; choose another --out"
            raise NotADirectoryError(message)
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    for number in range(1, 10_000):
        candidate = run_dir if number == 1 else run_dir.with_name(f"{run_dir.name}-{number}")
        try:
            _claim(candidate)
        except RunDirExistsError:
            if not suffix_on_collision:
                raise
            continue
        return candidate
    raise RunDirExistsError("every suffix up to -9999 is taken; choose another --out")


def _record_above(run_dir: Path) -> Path | None:
    """The record ``run_dir`` would be made in, up to two levels up, if any: a
    run's (its trajectory.csv and manifest.json), or any being written (its
    claim). A campaign's or falsification's directory takes runs (a replay
    line run from it writes ``runs/...`` there)."""
    for directory in list(Path(os.path.realpath(run_dir)).parents)[:2]:  # a loop: as it is
        if (directory / CLAIM_FILE).exists() or (
            (directory / MANIFEST_FILE).is_file() and (directory / TRAJECTORY_FILE).is_file()
        ):
            return directory
    return None


def _claim(run_dir: Path) -> None:
    try:
        run_dir.mkdir()
    except FileExistsError:
        if not run_dir.is_dir():
            raise RunDirExistsError("exists and is not a directory; choose another --out") from None
    claim = run_dir / CLAIM_FILE
    try:
        descriptor = os.open(claim, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except FileExistsError:
        raise RunDirExistsError(_claimed_by(claim)) from None
    try:  # who claims it, for a later run to tell a live claim from a killed one's
        os.write(descriptor, f"{os.getpid()} {socket.gethostname()}\n".encode())
    except OSError:  # a full disk: no claim left behind to refuse every later run
        os.close(descriptor)
        drop_claim(run_dir)
        raise
    os.close(descriptor)
    if any(entry.name != CLAIM_FILE for entry in run_dir.iterdir()):
        claim.unlink()
        raise RunDirExistsError(
            "run directory exists and is not empty; "
            "choose another --out or remove it (runs are never overwritten)"
        )


def _claimed_by(claim: Path) -> str:
    """Why a directory with ``claim`` cannot be taken: a run writing into it,
    or one killed (``kill -9``, a machine that stopped) before it could."""
    try:
        pid, host = claim.read_text(encoding="utf-8").split()
        os.kill(int(pid), 0) if host == socket.gethostname() else None
    except ProcessLookupError:
        return (
            f"a run killed before it finished (process {pid} is gone) left its claim "
            f"({CLAIM_FILE}) here, and what it had not written is lost; "
            "choose another --out, or remove the directory"
        )
    except (OSError, ValueError, OverflowError):  # unreadable, or an older version's: as before
        pass
    return "another run is writing into this directory"


def drop_claim(directory: Path) -> None:
    """Remove the claim of a run's, campaign's or falsification's directory,
    its record written. A directory made read-only, or replaced, meanwhile
    keeps it: the fault that stopped the writing is the one said, never this."""
    with contextlib.suppress(OSError):
        (directory / CLAIM_FILE).unlink(missing_ok=True)


def release_run_dir(run_dir: Path) -> None:
    """Remove the claim; remove the directory too when nothing was written into it."""
    drop_claim(run_dir)
    with contextlib.suppress(OSError):  # it holds the run's files
        run_dir.rmdir()


def space_needed(max_samples: int) -> int:
    """Bytes a run of at most ``max_samples`` samples may write (an upper estimate)."""
    return _BYTES_OTHER + _BYTES_PER_SAMPLE * max_samples


# --- trajectory.csv -------------------------------------------------------


def _csv_field(text: str) -> str:
    # RFC 4180 quoting, only for names that need it.
    if any(c in text for c in ',"\r\n') or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def trajectory_csv_blocks(result: RunRecord) -> Iterator[str]:
    """``trajectory.csv`` in pieces: the header line, then blocks of lines, so a
    long run is never held in memory as one text."""
    names = np.array([_csv_field(p.name) for p in result.phases] or [""], dtype=object)
    written = csv_columns(result)
    formats = [
        "%s" if name == "phase" else "%d" if name in INTEGER_COLUMNS else _FLOAT_FORMAT
        for name in written
    ]
    yield ",".join(written) + "\n"
    row_format = ",".join(formats) + "\n"
    width = len(written)
    for start in range(0, result.samples, _ROWS_PER_BLOCK):
        block = slice(start, start + _ROWS_PER_BLOCK)
        rows = len(result.t[block])
        # The block's values in row order: each column's values slotted into
        # one list by a slice (in C), not a tuple built value by value in Python.
        values: list[Any] = [None] * (rows * width)
        for j, name in enumerate(written):
            if name == "phase":
                column = names[np.asarray(result.phase[block], dtype=np.int64)]
            elif name in INTEGER_COLUMNS:
                column = np.asarray(getattr(result, name)[block], dtype=np.int64)
            else:
                column = np.asarray(getattr(result, name)[block], dtype=np.float64)
            values[j::width] = column.tolist()
        yield row_format * rows % tuple(values)


def trajectory_csv_text(result: RunRecord) -> str:
    """The whole ``trajectory.csv``: header line then one line per sample."""
    return "".join(trajectory_csv_blocks(result))


def write_trajectory(
    result: RunRecord, path: Path, progress: Callable[[int], None] | None = None
) -> Path:
    """Write ``trajectory.csv`` block by block (atomically, like every run file);
    ``progress(rows)`` after each block with the rows written so far."""
    with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8", newline="") as out:
        for number, block in enumerate(trajectory_csv_blocks(result)):  # the header first
            out.write(block)
            if progress is not None:
                progress(min(number * _ROWS_PER_BLOCK, result.samples))
    return path


# --- JSON -----------------------------------------------------------------


def transitions_record(transitions: Sequence[Transition]) -> list[dict[str, Any]]:
    """One record per phase change; ``lap`` only where the phase entered is in a repeat."""
    return [
        {
            "time": tr.time,
            "from": tr.from_phase,
            "to": tr.to_phase,
            "condition": tr.condition,
            "value": tr.value,
            **({} if tr.lap is None else {"lap": tr.lap}),
            **({} if tr.reaction is None else {"reaction": tr.reaction}),
            **({} if tr.why is None else {"why": tr.why}),
        }
        for tr in transitions
    ]


def run_record(result: RunRecord) -> dict[str, Any]:
    """What ``load_run`` needs besides the CSV, transitions and summary."""
    return {
        "mission_name": result.mission_name,
        "dt": result.dt,
        "phases": [
            {
                "name": phase.name,
                "kind": phase.kind,
                "target": list(phase.target) if phase.target is not None else None,
                "constraints": [
                    {"region": region, "side": side} for region, side in phase.constraints
                ],
                "near": list(phase.near) if phase.near is not None else None,
                "points": [list(point) for point in phase.points],
                "color": phase.color,
                # only where an update changed a target: other runs keep their bytes
                **({"targets": [list(t) for t in phase.targets]} if phase.targets else {}),
            }
            for phase in result.phases
        ],
        "limits": {"v": result.limits[0], "omega": result.limits[1]},
        "error_bounds": {
            state: list(bound)
            for state, bound in zip(("x", "y", "theta"), result.error_bounds, strict=True)
        },
        "regions": result.regions,
    } | (
        {"constraint_margin": result.constraint_margin}
        if any(phase.constraints for phase in result.phases)
        else {}
    )


def manifest_record(
    result: RunRecord,
    *,
    mission_sha256: str,
    resolved_mission: Mapping[str, Any],
    mission_file: str | None,
) -> dict[str, Any]:
    return {
        "mission_file": mission_file,
        "mission_sha256": mission_sha256,
        "resolved_mission": resolved_mission,
        "seed": result.seed,
        "versions": package_versions(),
        # What else decides the bytes, and its fingerprint (wmr_mission.output.environment).
        "environment": environment(result.loop_compiled),
        # How the loop ran, known only for a run simulated in this process
        # (one rebuilt from its directory carries no timing).
        "loop": loop_build(result.loop_compiled) if result.loop_ns > 0 else None,
        "run": run_record(result),
        # Another plant than our simulator: which, its versions and settings.
        **({} if result.backend is None else {"backend": result.backend}),
    }


def loop_build(compiled: bool | None = None) -> str:
    """How a run's loop ran (``compiled``: RunRecord.loop_compiled), or with
    None how this process runs it: ``compiled`` by numba, or ``plain Python``
    (a short run, a plug-in of plain Python objects, ``WMR_MISSION_NO_JIT=1``,
    no numba), a hundred times slower per sample: summary.json's
    ``loop_us_per_sample`` is read against it."""
    from wmr_mission.kernels import jit

    return "compiled" if (jit.loaded() if compiled is None else compiled) else "plain Python"


def summary_record(result: RunRecord, mission: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The content of ``summary.json``: every metric and, with a mission (default:
    ``result.mission``), each of its `expect` thresholds with its verdict."""
    if mission is None:
        mission = result.mission
    if result.judged is not None and mission is result.mission:
        mark_first_violations(result.judged, result)  # once: kept with the judged summary
        # Judged at the end of the run; a stop since names its signal in the message.
        summary = copy.deepcopy(result.judged)  # a caller's edit never reaches the result
        summary["outcome"], summary["message"] = result.outcome.value, result.message
        checks = [Check.read(record) for record in summary.get("expectations") or []]
        summary.update(margin_fields(checks, result.outcome.value))
        summary["recovery"] = recovery_record(result.transitions, result.succeeded)
        return summary
    summary = summarize(result, mission)
    checks = []
    if mission is not None and isinstance(mission.get("expect"), Mapping):
        checks = check_expectations(summary, mission)
        summary["expectations"] = [check.record() for check in checks]
        if mission is result.mission:  # kept for the figures (verdicts.png), not computed twice
            result.judged = copy.deepcopy(summary)
    summary.update(margin_fields(checks, result.outcome.value))
    summary["recovery"] = recovery_record(result.transitions, result.succeeded)
    return summary


def write_run(
    result: RunRecord,
    out_dir: str | os.PathLike[str],
    *,
    mission_sha256: str | None = None,
    resolved_mission: Mapping[str, Any] | None = None,
    mission_file: str | None = None,
    plots: bool,
    animate: bool,
    formats: Sequence[str] = ("png",),
    progress: Callable[[int], None] | None = None,
) -> list[Path]:
    """Write the run directory (made by ``prepare_run_dir``); return the files written.

    The data first, then ``summary.json`` (and the claim is removed), then the
    figures (``write_figures``), so a figure that cannot be drawn never loses
    the data or the summary. ``resolved_mission`` defaults to ``result.mission``;
    ``mission_sha256`` (the mission file's hash) to the hash of that resolved
    mission's JSON. When it has an ``expect`` section, the summary also lists
    each expectation and whether it was met. Figures are written in each of ``formats``.
    ``progress``: told the rows of ``trajectory.csv`` written (``write_trajectory``).
    """
    resolved = resolved_mission if resolved_mission is not None else (result.mission or {})
    if mission_sha256 is None:
        mission_sha256 = hashlib.sha256(json_text(resolved).encode("utf-8")).hexdigest()
    run_dir = Path(out_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    written = [
        write_trajectory(result, run_dir / TRAJECTORY_FILE, progress),
        write_json(
            run_dir / MANIFEST_FILE,
            manifest_record(
                result,
                mission_sha256=mission_sha256,
                resolved_mission=resolved,
                mission_file=mission_file,
            ),
        ),
        write_json(run_dir / TRANSITIONS_FILE, transitions_record(result.transitions)),
        write_json(run_dir / SUMMARY_FILE, summary_record(result, resolved)),
    ]
    drop_claim(run_dir)  # the record is complete
    return written + write_figures(result, run_dir, plots=plots, animate=animate, formats=formats)


def write_figures(
    result: RunRecord, run_dir: Path, *, plots: bool, animate: bool, formats: Sequence[str]
) -> list[Path]:
    """The four figures in each of ``formats`` and, with ``animate``, the
    animation; return the files written."""
    written = []
    if plots:
        from wmr_mission.output.figures import draw_all

        written += draw_all(result, run_dir, formats)
    if animate:
        from wmr_mission.output.animation import write_animation

        written.append(write_animation(result, run_dir / ANIMATION_FILE))
    return written
