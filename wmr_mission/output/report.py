"""The short plain-text table printed at the end of ``wmr-mission run``.

Laid out within :data:`WIDTH` columns (fewer on a narrower terminal). A
table whose cells fit at their full width is laid out here; one that must
wrap a long cell inside its column is laid out by rich, whose import and
layout cost a run 0.02-0.03 s of CPU (docs/performance.md, Start-up). Both
lay a fitting table out alike, character for character.
"""

from __future__ import annotations

import io
import math
import os
import shutil
from typing import TYPE_CHECKING, Any

from wmr_mission.verdicts.check import beside

if TYPE_CHECKING:
    from wmr_mission.record import PhaseRecord, RunRecord

WIDTH = 100
# Widest the verdict column grows, so that the key metrics keep their lines.
VERDICT_WIDTH = 21
# (header, right-aligned): numbers right-aligned.
Columns = tuple[tuple[str, bool], ...]  # each header, and whether its cells go right
_COLUMNS: Columns = (
    ("phase", False),
    ("kind", False),
    ("duration", True),
    ("key metric", False),
    ("at limit\nv / omega", False),
    ("estimate\nconverged", False),
    ("verdict", False),
)


def _seconds(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f} s"


def _number(value: float | None, unit: str) -> str:
    return "-" if value is None else f"{value:.3g}{unit}"


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.3g} %"


def key_metric(phase: dict[str, Any], start_clearance: float | None = None) -> str:
    """What tells how a phase went, a line each: how far off its path and how far
    behind its reference (entry and detours left out), the detours, error from
    its target, constraint margin, turn-rate jitter. ``start_clearance``: the
    body's clearance at the phase's first sample, where known."""
    parts = []
    tracking = phase.get("tracking")
    judged = tracking is not None and (
        tracking.get("cross_track_error_max") is not None
        or tracking.get("along_track_lag_max") is not None
    )
    if tracking is not None and not judged:
        # every sample in the entry (or a detour): said, not shown as a bare '-'
        left = f"entry {_seconds(tracking.get('entry_time'))}"
        if tracking.get("detour_time"):
            left += f", detour {_seconds(tracking['detour_time'])}"
        parts.append(f"tracking not judged ({left})")
    elif tracking is not None:
        parts.append(f"cross-track max {_number(tracking.get('cross_track_error_max'), ' m')}")
        parts.append(f"lag max {_number(tracking.get('along_track_lag_max'), ' m')}")
        if tracking.get("detour_time"):
            offset = _number(tracking.get("detour_offset_max"), " m")
            parts.append(f"detour {_seconds(tracking['detour_time'])}, {offset} off")
    target = phase.get("target_error")
    if target is not None:
        parts.append(f"end error {_number(target.get('position'), ' m')}")
        if target.get("heading") is not None:
            parts.append(f"end heading error {_number(target.get('heading'), ' rad')}")
    constraint = phase.get("constraint") or {}
    least = constraint.get("clearance_min")  # in metres, of the body if it has one
    if least is not None:
        # Least where the phase began, as the last phase left the robot (case 2's
        # return, on the ellipse its orbit rode): said so, not read as its own doing.
        where = " at its start" if least == start_clearance else ""
        parts.append(f"clearance {_number(least, ' m')}{where}")
    elif constraint.get("max_violation") is not None:
        parts.append(f"max constraint {_number(constraint['max_violation'], '')}")
    jitter = (phase.get("inputs") or {}).get("turn_rate_jitter")
    if jitter is not None:
        # a constant turn rate leaves only rounding (1e-16) about its moving mean
        parts.append(f"omega jitter {_number(jitter if jitter > 1e-12 else 0.0, ' rad/s')}")
    return "\n".join(parts) or "-"


def _at_limit(phase: dict[str, Any]) -> str:
    # Fractions of the samples after the settle time with |v|, |omega| at their limits.
    inputs = phase.get("inputs") or {}
    if not phase.get("settled_samples"):
        return "-"
    return (
        f"{_percent(inputs.get('speed_at_limit'))} / {_percent(inputs.get('turn_rate_at_limit'))}"
    )


def _convergence(phase: dict[str, Any]) -> str:
    # Seconds after the phase start from which every estimation error stays
    # below its state's convergence tolerance.
    time = (phase.get("estimation") or {}).get("convergence_time")
    return "never" if time is None else f"{time:.2f} s"


def _verdicts(
    checks: list[dict[str, Any]], phases: list[dict[str, Any]], ends: list[list[str]] | None = None
) -> list[str]:
    """Each phase entry's verdict: first how it ended where not by its `until`
    (``ends``, :func:`_ends`: 'timed out', 'breached'); then 'NOT MET' and, a
    line each, every threshold missed with the phase's value
    (``speed_jump_max 2.33 (max 2)``), or 'ok' where it met them all and ended
    by its `until`; a phase without thresholds that ended by its `until` has
    none ('-'). One pass over the checks, not one per phase: a run of 15,000
    phases took minutes.

    The checks come in the entries' order, each entry's a block in which every
    check is named once: a check is its entry's until it names another phase
    or repeats a check of the block, which starts the next entry of its name
    (a phase resumed after a contingency has two entries of one name)."""
    own: list[list[dict[str, Any]]] = [[] for _ in phases]
    entry, seen = 0, set[str]()
    for check in checks:
        name = check.get("phase")
        if name is None:
            continue
        if entry >= len(phases) or phases[entry]["name"] != name or check["metric"] in seen:
            later = entry + 1 if check["metric"] in seen else entry
            found = next((i for i in range(later, len(phases)) if phases[i]["name"] == name), None)
            if found is None:  # not in the run's phases (a summary edited): by its name
                found = next((i for i, p in enumerate(phases) if p["name"] == name), None)
            if found is None:
                continue
            entry, seen = found, set()
        seen.add(check["metric"])
        own[entry].append(check)
    verdicts = []
    for row, mine in enumerate(own):
        ended = [] if ends is None else ends[row]
        missed = [c for c in mine if not c["met"]]
        verdict = ["NOT MET"] if missed else [] if ended else ["ok"] if mine else ["-"]
        verdicts.append("\n".join([*ended, *verdict, *(_missed(c) for c in missed)]))
    return verdicts


# A phase entry's end other than by its `until`, by its transition's condition.
_ENDED = {"timeout": "timed out", "breach": "breached"}
# A run's outcome that its last phase entry's end gave it.
_ENDED_RUN = {"timeout": "timed out", "breached": "breached"}


def _ends(summary: dict[str, Any], result: RunRecord | None = None) -> list[list[str]]:
    """How each phase entry ended where not by its `until`: 'timed out' or
    'breached' (a retry is an entry of its own, with its own row), whether
    the run ended there or went on (``on_timeout: next``, a retry, a
    contingency). From the run's transitions, each placed in the entry of its
    phase whose span holds its time; without the run, from the summary's
    outcome, for its last entry only."""
    phases = summary.get("phases") or []
    ends: list[list[str]] = [[] for _ in phases]
    spans = [(p.get("start"), p.get("end")) for p in phases]
    timed = all(isinstance(a, int | float) and isinstance(b, int | float) for a, b in spans)
    if result is None or not timed:
        word = _ENDED_RUN.get(str(summary.get("outcome")))
        if word is not None and phases:
            ends[-1].append(word)
        return ends
    row, slack = 0, 0.5 * result.dt
    for change in result.transitions:  # in time order, as the entries are
        word = _ENDED.get(change.condition)
        if word is None:
            continue
        while row < len(phases) and spans[row][1] < change.time - slack:
            row += 1
        for at in range(row, len(phases)):
            if spans[at][0] > change.time + slack:
                break
            if phases[at]["name"] == change.from_phase:
                ends[at].append(word)
                break
    return ends


def _missed(check: dict[str, Any]) -> str:
    side = "max" if check.get("max") is not None else "min"
    if check.get("value") is None:
        return f"{check['metric']}\nnone ({side} {check[side]:g})"
    value, bound = beside(check["value"], check[side], 3)
    return f"{check['metric']}\n{value} ({side} {bound})"


def _aim(final: dict[str, Any], phases: list[dict[str, Any]]) -> str:
    """What the final error is measured from."""
    target = final.get("target") or {}
    name = target.get("phase")
    if name is None:
        return ""
    kinds = {phase.get("name"): phase.get("kind") for phase in phases}
    if kinds.get(name) == "track":
        time = final.get("time")
        at = "" if time is None else f", at t = {time:.2f} s"
        return f" (from the last reference point of phase '{name}'{at})"
    return f" (from the target of phase '{name}')"


def unreached(result: RunRecord) -> list[str]:
    """For a run that timed out: what its phase was waiting for, and how far it was."""
    ended = [tr for tr in result.transitions if tr.to_phase is None and tr.condition == "timeout"]
    if not ended or result.samples == 0:
        return []
    name = ended[-1].from_phase
    info = next(p for p in result.phases if p.name == name)
    if info.near is None:
        return [f"not reached: the `until` condition of phase '{name}' (it timed out)"]
    gx, gy, tolerance = info.near
    distance = math.hypot(float(result.x[-1]) - gx, float(result.y[-1]) - gy)
    return [
        f"not reached: near ({gx:g}, {gy:g}) within {tolerance:g} m of phase '{name}': "
        f"{distance:.3g} m away when it timed out"
    ]


def _phase_table(
    summary: dict[str, Any],
    checks: list[dict[str, Any]],
    width: int,
    result: RunRecord | None = None,
) -> list[str]:
    rows, columns = _phase_rows(summary, checks, result), _COLUMNS
    table = _fitting_table(rows, width, columns)
    if table is None and width < WIDTH:  # a narrow terminal: two columns folded
        rows, columns = [_folded(row) for row in rows], _FOLDED_COLUMNS
        table = _fitting_table(rows, width, columns)
    return table or _wrapped_table(rows, width, columns)


# A terminal narrower than WIDTH's columns (80 is the common default): each phase's
# inputs at their limits and its estimate's convergence as lines of its key
# metric, not columns of their own, so that no cell is wrapped inside a word.
_FOLDED_COLUMNS: Columns = (*_COLUMNS[:4], _COLUMNS[-1])


def _folded(row: list[str]) -> list[str]:
    """A row of :data:`_COLUMNS` in :data:`_FOLDED_COLUMNS`."""
    *first, key, at_limit, converged, verdict = row
    return [
        *first,
        f"{key}\nv / omega at limit {at_limit}\nestimate converged {converged}",
        verdict,
    ]


def _first_sample(phase: dict[str, Any], result: RunRecord) -> int:
    """The index of the phase's first sample in the run's columns."""
    import numpy as np

    return int(np.searchsorted(result.t, phase["start"] - 0.5 * result.dt))


def _start_clearance(
    phase: dict[str, Any], result: RunRecord | None, infos: dict[str, PhaseRecord]
) -> float | None:
    """[m] the body's clearance from the phase's zones at its first sample
    (None without the run, or where the phase has no clearance)."""
    info = infos.get(phase["name"])
    if result is None or info is None or phase.get("start") is None:
        return None
    if (phase.get("constraint") or {}).get("clearance_min") is None:
        return None
    from wmr_mission.verdicts.clearance import clearance_min
    from wmr_mission.verdicts.zones import zones_of

    first = _first_sample(phase, result)
    at = slice(first, first + 1)
    footprint = ((result.mission or {}).get("robot") or {}).get("footprint")
    zones = zones_of(info.constraints, result.regions)
    return clearance_min(result.x[at], result.y[at], result.theta[at], zones, footprint)


def _backwards(phase: dict[str, Any], result: RunRecord | None) -> bool:
    """Whether a track phase was driven backwards, most of its travel at a
    negative speed (a short phase whose path starts behind the robot:
    docs/controllers.md): said in its row, where a forward robot is assumed.
    Its travel, not its samples: a robot that drove forwards and then stood,
    its speed -1e-10 from rounding, was said to have driven backwards."""
    if result is None or phase["kind"] != "track" or phase.get("start") is None:
        return False
    import numpy as np

    first = _first_sample(phase, result)
    samples = round((phase.get("duration") or 0.0) / result.dt)
    speed = result.v[first : first + samples]
    return bool(-float(np.sum(speed[speed < 0.0])) > float(np.sum(speed[speed > 0.0])))


def _phase_rows(
    summary: dict[str, Any], checks: list[dict[str, Any]], result: RunRecord | None = None
) -> list[list[str]]:
    """The phase table's cells, a row a phase, in :data:`_COLUMNS`' order. A
    run stopped by a signal: its last phase, cut short, is 'stopped', not judged."""
    phases = summary.get("phases") or []
    verdicts = _verdicts(checks, phases, _ends(summary, result))
    infos = {} if result is None else {info.name: info for info in result.phases}
    # The last row: a phase entered again (a retry, a goto) has rows before it.
    stopped = len(phases) - 1 if summary.get("outcome") == "interrupted" else None
    return [
        [
            str(phase["name"]),
            str(phase["kind"]) + ("\nbackwards" if _backwards(phase, result) else ""),
            _seconds(phase.get("duration")),
            key_metric(phase, _start_clearance(phase, result, infos)),
            _at_limit(phase),
            _convergence(phase),
            "stopped" if row == stopped else verdicts[row],
        ]
        for row, phase in enumerate(phases)
    ]


def _fitting_table(
    rows: list[list[str]], width: int, columns: Columns = _COLUMNS
) -> list[str] | None:
    """The table with every cell at its full width, laid out as rich lays it
    out (:func:`_wrapped_table`): a rule under the headers, two spaces
    between columns, a header on its column's last header line, a cell on
    its row's first lines; None when it needs more than ``width`` columns, a
    verdict more than VERDICT_WIDTH, or a cell holds other than printable
    ASCII (whose width on a terminal rich measures)."""
    headers = [header.split("\n") for header, _ in columns]
    cells = [[cell.split("\n") for cell in row] for row in rows]
    widths = [max(map(len, lines)) for lines in headers]
    for row in cells:
        for column, lines in enumerate(row):
            if not all(line.isascii() and line.isprintable() for line in lines):
                return None
            widths[column] = max(widths[column], *map(len, lines))
    if widths[-1] > VERDICT_WIDTH or sum(widths) + 2 * (len(widths) - 1) > width:
        return None
    height = max(map(len, headers))
    header_lines = [[""] * (height - len(lines)) + lines for lines in headers]
    rule = "\u2500" * (sum(widths) + 2 * (len(widths) - 1))  # rich's box.SIMPLE_HEAD
    table = [*_lines(header_lines, widths, columns), rule]
    for row in cells:
        table += _lines(row, widths, columns)
    return [line.rstrip() for line in table if line.strip()]


def _lines(row: list[list[str]], widths: list[int], columns: Columns) -> list[str]:
    """The text lines of one row of the table, its cells' lines side by side."""
    lines = []
    for at in range(max(map(len, row))):
        parts = []
        for (_, right), width, cell in zip(columns, widths, row, strict=True):
            text = cell[at] if at < len(cell) else ""
            parts.append(text.rjust(width) if right else text.ljust(width))
        lines.append("  ".join(parts))
    return lines


def _wrapped_table(rows: list[list[str]], width: int, columns: Columns = _COLUMNS) -> list[str]:
    """The table laid out by rich, a long cell wrapped inside its column."""
    from rich import box
    from rich.console import Console
    from rich.table import Table

    table = Table(
        box=box.SIMPLE_HEAD,
        show_edge=False,
        pad_edge=False,
        collapse_padding=True,
        header_style=None,
    )
    for header, right in columns:
        table.add_column(
            header,
            justify="right" if right else "left",
            overflow="fold",
            # a missed threshold's name on a line, its value and bound on the next
            max_width=VERDICT_WIDTH if header == "verdict" else None,
        )
    for row in rows:
        table.add_row(*row)
    # Plain text: no colours, no markup or emoji codes (":x:") read in names.
    console = Console(
        file=io.StringIO(),
        width=width,
        color_system=None,
        highlight=False,
        markup=False,
        emoji=False,
    )
    console.print(table)
    text = console.file.getvalue()  # type: ignore[attr-defined]  # the StringIO above
    return [line.rstrip() for line in text.splitlines() if line.strip()]


def format_table(
    summary: dict[str, Any],
    run_dir: str | os.PathLike[str],
    *,
    wall_seconds: float | None = None,
    result: RunRecord | None = None,
    width: int | None = None,
) -> str:
    """Phases with their key metrics and verdicts, the mission-wide expectations,
    the outcome and where the files are; the table within ``width`` columns
    (by default WIDTH, or the terminal's width where it is narrower).

    ``wall_seconds``: the computer's time for the run, shown beside the
    simulated time; ``result``: the run, to say which goal a timed-out phase
    missed. A failed run's message (what failed, and by how much) is not
    repeated here: ``run`` prints it once, on stderr; a mission-wide check it
    missed is listed NOT MET, since no phase's verdict says it.
    """
    if width is None:
        width = min(WIDTH, shutil.get_terminal_size((WIDTH, 24)).columns)
    checks = list(summary.get("expectations", []))
    lines = _phase_table(summary, checks, width, result)
    final = summary.get("final") or {}
    if final.get("position_error") is not None:
        text = f"final error: {_number(final['position_error'], ' m')}"
        if final.get("heading_error") is not None:
            text += f", {_number(final['heading_error'], ' rad')}"
        lines.append(text + _aim(final, summary.get("phases", [])))
    if result is not None:
        lines += unreached(result)
    converged = summary.get("estimation_convergence_time")
    lines.append(
        "estimation converged from: " + ("never" if converged is None else f"t = {converged:.2f} s")
    )
    outcome = summary.get("outcome")
    phases = summary.get("phases") or []
    stopped_phase = phases[-1]["name"] if outcome == "interrupted" and phases else None
    # What to try, where a known mechanism explains a miss (verdicts/advice.py).
    lines += [f"try: {check['advice']}" for check in checks if check.get("advice")]
    for check in checks:
        if check["met"] and check.get("phase") is not None:
            continue  # the verdict column says it
        if not check["met"] and outcome == "expect-failed" and check.get("phase") is not None:
            continue  # its phase's verdict says it; a mission-wide one has no phase row
        verdict = "met" if check["met"] else "NOT MET"
        if outcome == "interrupted" and check.get("phase") in (None, stopped_phase):
            verdict = f"{verdict.lower()} up to the stop"  # judged on the samples so far
        value = "null" if check["value"] is None else f"{check['value']:.4g}"
        where = "" if check.get("phase") is None else f"{check['phase']}: "
        # a bound from below (clearance_min, a temporal formula) is a min
        side, bound = ("<=", check["max"]) if "max" in check else (">=", check["min"])
        lines.append(f"expect {where}{check['metric']} {side} {bound:g}: {value} ({verdict})")
    line = f"outcome: {outcome} after {_seconds(summary.get('duration'))} of simulated time"
    if wall_seconds is not None:
        line += f" ({wall_seconds:.2f} s of wall time)"
    message = str(summary.get("message") or "")
    if outcome == "success" and message:
        line += f" - {message}"
    lines.append(line)
    lines.append(f"outputs: {os.fspath(run_dir)}")
    return "\n".join(lines) + "\n"
