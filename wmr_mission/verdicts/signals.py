"""The error signals the verdicts judge, sample by sample, for the figure that
explains a run (``verdicts.png``).

Each `expect` check of a run (``summary.json``'s ``expectations``) is a bound
on one of these signals over a phase (or the whole run):

- a **peak** check (``*_max``, jumps, the final error) bounds every judged
  sample: the samples above the bound are the failure, the first of them its time;
  ``clearance_min`` is one on the depth of the body (minus its clearance),
  its bound drawn at minus the clearance asked for;
- a **level** check (an RMS, the jitter, a share of time at a limit, a count,
  a time) bounds one number made of the phase's samples: it is drawn as that
  number beside its bound.

The signals are computed here by the functions the verdicts use
(wmr_mission.verdicts.tracking, inputs, zones), so that what is drawn is what was
judged. Nothing here draws.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import STATES, FloatArray
from wmr_mission.spec import catalog, models
from wmr_mission.spec.numbers import MissionNumbers, mission_numbers
from wmr_mission.verdicts import inputs as input_metrics
from wmr_mission.verdicts import temporal
from wmr_mission.verdicts.check import Check as Judged
from wmr_mission.verdicts.clearance import body_clearances
from wmr_mission.verdicts.metrics import (
    check_expectations,
    distance_to_path,
    estimation_errors,
    footprint_of,
    phase_expectations,
    phase_segments,
    summarize,
)
from wmr_mission.verdicts.tracking import track_samples
from wmr_mission.verdicts.zones import zones_of

if TYPE_CHECKING:
    from wmr_mission.record import RunRecord

Mask = NDArray[np.bool_]

# Panels top to bottom (a failing one is moved to the top), with their axis labels.
PANELS: dict[str, str] = {
    "cross_track": "cross-track [m]",
    "along_track": "along-track lag [m]\n(> 0 behind)",
    "zones": "depth into zone [m]\n(> 0 inside)",
    "constraint": "constraint value\n(> 0 violated)",
    "goal": "to target [m]",
    "estimation": "|true - estimate|\n[m, rad]",
    "jumps": "one-sample change\n[m/s, rad/s]",
    "jitter": "ω - moving mean\n[rad/s]",
    "saturation": "|input| / limit",
}


def panel_of(metric: str) -> str | None:
    """The panel a check is drawn on (catalog.Metric.panel; None: none)."""
    entry = catalog.CATALOG.get(metric.split(".", 1)[0])
    if entry is not None:
        return entry.panel
    try:  # a temporal formula's: its first signal's panel
        return temporal.panel_of(metric)
    except ValueError:  # not a formula either
        return None


def line_of(metric: str) -> str | None:
    """The signal's line a peak check bounds; None for a level check."""
    entry = catalog.CATALOG.get(metric.split(".", 1)[0])
    return None if entry is None else entry.line


@dataclass
class Check(Judged):
    """One `expect` check (wmr_mission.verdicts.check) placed on the run's
    samples: ``span`` the samples of its phase (the whole run for a
    mission-wide one); for a failed peak check, ``over`` the judged samples
    above its bound."""

    span: tuple[int, int] = (0, 0)
    over: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    # the line of its panel it bounds (None: a level check, drawn as words)
    line: str | None = None

    @property
    def peak(self) -> bool:
        return self.line is not None

    @property
    def level(self) -> float:
        """The bound where its line reads it: minus a lower bound (the clearance
        asked for, on the body's depth), an upper bound itself."""
        return -self.bound if self.lower else self.bound

    @property
    def first_over(self) -> int | None:
        return int(self.over[0]) if self.over.size else None

    def words(self) -> str:
        """``south#1: speed_jump_max = 2.33 m/s (max 2 m/s)``."""
        unit = catalog.unit_of(self.metric)
        unit = f" {unit}" if unit else ""
        value = "none" if self.value is None else f"{self.value:.3g}{unit}"
        where = f"{self.phase}: " if self.phase is not None else ""
        return f"{where}{self.metric} = {value} ({self.side} {self.bound:.3g}{unit})"


# The lines the judge bounds at some of their samples only (Signals.unjudged).
PARTLY_JUDGED = ("cross-track error", "along-track lag", "distance to the path")


@dataclass
class Signals:
    """A run's error signals, one value per sample (NaN where not measured), by
    panel and line name; ``judged[line]``: the samples its peak checks look at."""

    lines: dict[str, dict[str, FloatArray]]
    judged: dict[str, Mask]
    checks: list[Check]

    def unjudged(self, name: str) -> Mask | None:
        """The samples of line ``name`` drawn but bounded by no check: a track
        phase's entry, its rejoining after a detour and, for the cross-track
        error and the lag, its detours (the detour's own check bounds the
        cross-track error there), and the wait before a tracking error settles;
        None for a line bounded wherever it is drawn, or bounded by none."""
        drawn = [lines[name] for lines in self.lines.values() if name in lines]
        if name not in PARTLY_JUDGED or not drawn:
            return None
        looked = self.judged[name]
        if name == "cross-track error" and "detour" in self.judged:
            looked = looked | self.judged["detour"]
        return ~looked & np.isfinite(drawn[0])

    def failed(self) -> list[Check]:
        """The failed checks, the one failing first in time first."""
        failed = [c for c in self.checks if not c.met]
        timed = sorted((c for c in failed if c.first_over is not None), key=lambda c: c.over[0])
        return timed + [c for c in failed if c.first_over is None]


def expectations(result: RunRecord) -> list[dict[str, Any]]:
    """The run's `expect` checks (``summary.json``'s ``expectations``)."""
    if result.judged is not None:
        return list(result.judged.get("expectations") or [])
    if result.expectations is not None:  # read back with its run directory
        return list(result.expectations)
    mission = result.mission
    if mission is None or not isinstance(mission.get("expect"), Mapping):
        return []
    return [check.record() for check in check_expectations(summarize(result, mission), mission)]


# The zones panel's line of the body: the axle's depth plus the body's reach,
# a round body's own depth (clearance_min is minus its least), at most a
# polygon body's (the temporal signal ``clearance`` is minus it).
BODY_DEPTH = "depth + the body's reach"


def run_signals(result: RunRecord) -> Signals:
    """The error signals of ``result`` and its checks placed on them."""
    n = result.samples
    numbers = mission_numbers(result.mission, result.dt, result.limits)
    checked = expectations(result)
    metrics = {str(c["metric"]).split(".", 1)[0] for c in checked}
    lines: dict[str, dict[str, FloatArray]] = {}
    judged: dict[str, Mask] = {}

    def line(panel: str, name: str) -> FloatArray:
        values = lines.setdefault(panel, {}).setdefault(name, np.full(n, np.nan))
        judged.setdefault(name, np.zeros(n, dtype=bool))
        return values

    segments = phase_segments(result)
    errors = estimation_errors(result)
    inputs_from = input_metrics.first_judged(result.t, errors, numbers)
    settle = _settle_times(result.mission)
    spans: dict[str, tuple[int, int]] = {}
    for index, start, end, ended_by in segments:
        info = result.phases[index]
        spans[info.name] = (start, end)
        w = slice(start, end)
        zones = zones_of(info.constraints, result.regions)
        placed = None
        if info.kind == "track":
            timed = ended_by in ("elapsed", "mission_time")
            _, placed = track_samples(
                result.t[w],
                result.x[w],
                result.y[w],
                result.x_ref[w],
                result.y_ref[w],
                numbers,
                zones,
                timed,
                result.constraint_margin,
            )
            if placed is not None:
                line("cross_track", "cross-track error")[w] = placed.cross
                line("along_track", "along-track lag")[w] = placed.lag
                # (a robot slowed where a zone blocks its way: its lag judged,
                # its offset by the detour's bound, verdicts/tracking.py)
                judged["cross-track error"][w] = placed.judged & ~placed.detour
                judged["along-track lag"][w] = placed.judged
                judged.setdefault("detour", np.zeros(n, dtype=bool))[w] = placed.detour
            if {"tracking_error_max", "tracking_error_rms"} & metrics:
                line("cross_track", "distance to the path")[w] = distance_to_path(
                    result.x[w], result.y[w], result.x_ref[w], result.y_ref[w]
                )
                time = result.t[w] - result.t[start]
                wait = settle.get(info.name.split("#", 1)[0], settle[""])
                judged["distance to the path"][w] = time >= wait - 1e-9 * result.dt
        if zones:
            depth = np.max([zone.depth(result.x[w], result.y[w]) for zone in zones], axis=0)
            line("zones", "depth into a zone")[w] = depth
            judged["depth into a zone"][w] = True
            if numbers.body > 0.0:  # what clearance_min reads: the body's, not the axle's
                line("zones", BODY_DEPTH)[w] = depth + numbers.body
                judged[BODY_DEPTH][w] = True
        if info.kind == "regulate":  # to the target in force at each sample
            for a, b, (tx, ty, _) in info.targets_in_force(start, end):
                to_target = line("goal", "distance to the target")
                to_target[a:b] = np.hypot(result.x[a:b] - tx, result.y[a:b] - ty)
        first = end if inputs_from is None else max(start, _sample(result, inputs_from))
        if first + 1 < end and {"speed_jump_max", "turn_rate_jump_max"} & metrics:
            for name, values in (("|Δv| [m/s]", result.v), ("|Δω| [rad/s]", result.omega)):
                jumps = line("jumps", name)
                jumps[first + 1 : end] = np.abs(np.diff(values[first:end]))
                judged[name][first + 1 : end] = True
        if first < end and "turn_rate_jitter" in metrics:
            jitter = line("jitter", "ω - moving mean")
            counted = None  # a track phase's: the samples its tracking is judged at
            if info.kind == "track" and placed is not None:
                counted = placed.judged[first - start :]
            jitter[first:end] = input_metrics.jitter_deviation(
                result.omega[first:end], numbers, counted
            )
    if np.isfinite(result.constraint).any():
        line("constraint", "constraint value")[:] = result.constraint
        judged["constraint value"][:] = True
    if "estimation" in _wanted_estimation(errors, numbers, metrics):
        for state in STATES:
            line("estimation", f"|{state}|")[:] = np.abs(errors[state])
    for label, values, limit in (
        ("|v| / limit", result.v, result.limits[0]),
        ("|ω| / limit", result.omega, result.limits[1]),
    ):
        if math.isfinite(limit) and limit > 0:
            line("saturation", label)[:] = np.abs(values) / limit
    checks = [_placed(c, spans, n, lines, judged) for c in checked]
    for check in checks:
        if check.metric == "clearance_min" and not check.met:
            _place_clearance(check, result)
    return Signals(lines, judged, checks)


def _place_clearance(check: Check, result: RunRecord) -> None:
    """A failed ``clearance_min`` check's samples below its bound, each pose's
    clearance measured as the check measures the least (exact for a polygon
    body too, which the drawn line bounds from above)."""
    start, end = check.span
    w = slice(start, end)
    x, y, theta = result.x[w], result.y[w], result.theta[w]
    zones = zones_of(result.phases[int(result.phase[start])].constraints, result.regions)
    finite = np.isfinite(x) & np.isfinite(y) & np.isfinite(theta)
    if not zones or not finite.any():
        return
    kept = np.flatnonzero(finite)
    footprint = footprint_of(result.mission)
    clearance = body_clearances(x[kept], y[kept], theta[kept], zones, footprint)
    check.over = (kept[clearance < check.bound] + start).astype(np.intp)


def mark_first_violations(summary: dict[str, Any], result: RunRecord) -> None:
    """Each failed check of ``summary`` (``result``'s, as judged) gains its
    ``first_violation``: the first judged sample beyond its bound, ``time`` and
    ``sample``, as verdicts.png marks it; null for a level check (an RMS, a
    count, a time: no sample is beyond it). The signals are computed once,
    where a check failed."""
    failed = [r for r in summary.get("expectations") or [] if not r.get("met")]
    if not failed or all("first_violation" in record for record in failed):
        return
    first = {(c.metric, c.phase): c.first_over for c in run_signals(result).checks}
    for record in failed:
        sample = first.get((record["metric"], record["phase"]))
        record["first_violation"] = (
            None if sample is None else {"time": float(result.t[sample]), "sample": sample}
        )


def _wanted_estimation(
    errors: dict[str, FloatArray], numbers: MissionNumbers, metrics: set[str]
) -> set[str]:
    """The estimation panel is drawn when it is checked or its error is not nil
    (a noise-free run's estimate equals the truth: nothing to show)."""
    if metrics & {"estimation_rms", "estimation_convergence_time"}:
        return {"estimation"}
    largest = max(
        float(np.nanmax(np.abs(e))) if np.isfinite(e).any() else 0.0 for e in errors.values()
    )
    return {"estimation"} if largest > 1e-9 else set()


def _sample(result: RunRecord, time: float) -> int:
    return int(np.searchsorted(result.t, time - 1e-9 * result.dt))


def _settle_times(mission: Mapping[str, Any] | None) -> dict[str, float]:
    """Each phase's settle time by its name as written; ``""``: the mission's."""
    expect = (mission or {}).get("expect") or {}
    shared = expect.get("settle_time")
    times = {"": models.DEFAULT_SETTLE_TIME if shared is None else float(shared)}
    for name, own in phase_expectations(mission).items():
        value = own.get("settle_time")
        times[name] = times[""] if value is None else float(value)
    return times


def _placed(
    check: Mapping[str, Any],
    spans: Mapping[str, tuple[int, int]],
    n: int,
    lines: Mapping[str, Mapping[str, FloatArray]],
    judged: Mapping[str, Mask],
) -> Check:
    placed = Check.read(check)  # summary.json's record, read as data
    metric, phase = placed.metric, placed.phase
    placed.span = span = spans.get(phase, (0, n)) if phase is not None else (0, n)
    name = line_of(metric)
    panel = panel_of(metric)
    if metric == "clearance_min":  # the body's depth where it has one, else the axle's
        name = BODY_DEPTH if BODY_DEPTH in lines.get("zones", {}) else "depth into a zone"
    placed.line = name
    if placed.met or name is None or panel is None or metric == "clearance_min":
        return placed  # a clearance's samples below it: _place_clearance
    values = lines.get(panel, {}).get(name)
    if values is None:
        return placed
    start, end = span
    if metric == "final_position_error":  # the last sample alone
        start = max(end - 1, 0)
    # a lag is signed (ahead or behind); a depth or constraint value < 0 is allowed
    window = np.abs(values[start:end]) if metric == "along_track_lag_max" else values[start:end]
    mask = judged.get(name)
    looked = np.ones(end - start, dtype=bool) if mask is None else mask[start:end]
    if metric == "detour_offset_max":
        looked = judged.get("detour", np.zeros(n, dtype=bool))[start:end]
    if metric == "final_position_error":
        looked = np.ones(end - start, dtype=bool)
    with np.errstate(invalid="ignore"):
        placed.over = np.flatnonzero(looked & (window > placed.bound)).astype(np.intp) + start
    return placed
