"""The short plain-text table printed at the end of ``wmr-mission run``."""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from wmr_mission.result import RunResult

_HEADERS = (
    "phase",
    "kind",
    "duration",
    "key metric",
    "at limit v/omega",
    "estimate converged after",
    "verdict",
)
# Right-aligned columns (numbers).
_RIGHT = (2,)


def _seconds(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f} s"


def _number(value: float | None, unit: str) -> str:
    return "-" if value is None else f"{value:.3g}{unit}"


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.3g} %"


def key_metric(phase: dict[str, Any]) -> str:
    """What tells how a phase went: distance from its path after the settle time,
    error from its target, constraint margin, turn-rate jitter."""
    parts = []
    tracking = phase.get("tracking_error")
    if tracking is not None:
        parts.append(
            f"off path rms {_number(tracking.get('rms'), ' m')} "
            f"max {_number(tracking.get('max'), ' m')}"
        )
    target = phase.get("target_error")
    if target is not None:
        text = f"end error {_number(target.get('position'), ' m')}"
        if target.get("heading") is not None:
            text += f" / {_number(target.get('heading'), ' rad')}"
        parts.append(text)
    constraint = phase.get("constraint") or {}
    if constraint.get("max_violation") is not None:
        parts.append(f"max constraint {_number(constraint['max_violation'], '')}")
    jitter = (phase.get("inputs") or {}).get("turn_rate_jitter")
    if jitter is not None:
        # a constant turn rate leaves only rounding (1e-16) about its moving mean
        parts.append(f"omega jitter {_number(jitter if jitter > 1e-12 else 0.0, ' rad/s')}")
    return ", ".join(parts) or "-"


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


def _verdict(phase: dict[str, Any], checks: list[dict[str, Any]]) -> str:
    """'ok', or the phase's thresholds that were not met."""
    mine = [c for c in checks if c.get("phase") == phase["name"]]
    failed = [str(c["metric"]) for c in mine if not c["met"]]
    if failed:
        return "NOT MET: " + ", ".join(failed)
    return "ok" if mine else "-"


def _aim(final: dict[str, Any], phases: list[dict[str, Any]]) -> str:
    """What the final error is measured from."""
    target = final.get("target") or {}
    name = target.get("phase")
    if name is None:
        return ""
    kinds = {phase.get("name"): phase.get("kind") for phase in phases}
    if kinds.get(name) == "track":
        return f" (from the last reference point of phase '{name}')"
    return f" (from the target of phase '{name}')"


def unreached(result: RunResult) -> list[str]:
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


def format_table(
    summary: dict[str, Any],
    run_dir: str | os.PathLike[str],
    *,
    wall_seconds: float | None = None,
    result: RunResult | None = None,
) -> str:
    """Phases with their key metrics and verdicts, the mission-wide expectations,
    the outcome and where the files are.

    ``wall_seconds``: the computer's time for the run, shown beside the
    simulated time; ``result``: the run, to say which goal a timed-out phase missed.
    """
    checks = list(summary.get("expectations", []))
    rows = [
        (
            str(phase["name"]),
            str(phase["kind"]),
            _seconds(phase.get("duration")),
            key_metric(phase),
            _at_limit(phase),
            _convergence(phase),
            _verdict(phase, checks),
        )
        for phase in summary.get("phases", [])
    ]
    widths = [max(len(row[i]) for row in [_HEADERS, *rows]) for i in range(len(_HEADERS))]
    lines = [
        "  ".join(
            cell.rjust(width) if i in _RIGHT else cell.ljust(width)
            for i, (cell, width) in enumerate(zip(row, widths, strict=True))
        ).rstrip()
        for row in [_HEADERS, tuple("-" * w for w in widths), *rows]
    ]
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
    for check in checks:
        if check.get("phase") is not None and check["met"]:
            continue  # the verdict column says it; an unmet one is spelt out below
        verdict = "met" if check["met"] else "NOT MET"
        value = "null" if check["value"] is None else f"{check['value']:.4g}"
        where = "" if check.get("phase") is None else f"{check['phase']}: "
        lines.append(f"expect {where}{check['metric']} <= {check['max']:g}: {value} ({verdict})")
    message = str(summary.get("message") or "")
    if message.startswith(str(summary.get("outcome"))):  # "diverged in phase ... at t = ..."
        outcome = f"outcome: {message}"
    else:
        outcome = (
            f"outcome: {summary.get('outcome')} after {_seconds(summary.get('duration'))} "
            "of simulated time"
        )
        if wall_seconds is not None:
            outcome += f" ({wall_seconds:.2f} s of wall time)"
        if message:
            outcome += f" - {message}"
    lines.append(outcome)
    lines.append(f"outputs: {os.fspath(run_dir)}")
    return "\n".join(lines) + "\n"
