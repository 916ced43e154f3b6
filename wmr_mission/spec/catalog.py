"""The catalog of metrics: one entry per metric a run is measured by.

Each entry says what the metric is (its name, unit and words), what it
applies to (a phase of some kinds, or the whole run), which way it is bounded
(``max``: at most; ``min``: at least), what its `expect` key takes and its
default, what an ``auto`` bound stands for, where its value lives in
``summary.json``, whether ``runs.csv`` has a column of it, and the panel of
``verdicts.png`` it is drawn on. The mission's `expect` models
(wmr_mission.spec.models), the judge (wmr_mission.verdicts.metrics), the
signals figure (wmr_mission.verdicts.signals), a campaign's rows and figures
and ``view`` all read it; none keeps a list of metric names of its own.

How a metric is computed lives beside the judge, by name
(wmr_mission.verdicts.metrics.MEASURES for a phase's): adding a metric is one
entry here and its computation there (tests/test_catalog.py adds one). A
metric is registered before the mission models are built (the models read
the catalog as they are made): at import, as the built-in ones are.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, Final, Literal, NamedTuple

__all__ = [
    "CATALOG",
    "Metric",
    "add",
    "columns",
    "metric",
    "phase_metrics",
    "run_metrics",
    "unit_of",
]

Scope = Literal["phase", "run"]
Bound = Literal["max", "min"]
# What an `expect` key of the metric takes: an upper bound {max: X}; that or
# `auto`; a number (a lower bound, `clearance_min: 0.1`); a bound per state.
Kind = Literal["threshold", "auto", "number", "per-state"]
TRACK: Final = frozenset({"track"})
REGULATE: Final = frozenset({"regulate"})
EVERY: Final = frozenset({"track", "regulate", "hold"})


class Metric(NamedTuple):
    """One metric of a run (see the module's words)."""

    name: str
    unit: str  # "m", "rad/s" ...; "" for a count or a share
    description: str  # the `expect` key's, in the schema and docs/mission-format.md
    scope: Scope  # a phase's, or the whole run's
    where: tuple[str, ...]  # its place in summary.json (in a phase's entry, or the run's)
    expect: Kind = "threshold"
    bound: Bound = "max"
    # the phase kinds it applies to (a run-wide one: every)
    kinds: frozenset[str] = EVERY
    # only the samples after the phase's settle time count: not judged without any
    settled: bool = False
    # the mission's `expect` value unless written ({"max": X}, "auto", a number, None)
    default: Any = None
    # the default in words, after the description in the mission's `expect`
    default_words: str = ""
    # verdicts.png: its panel, and for a peak check (every judged sample bounded)
    # the signal's line it bounds; None: a level check (one number of the phase)
    panel: str | None = None
    line: str | None = None
    # runs.csv and campaign.json have its value over the run (a phase's: its
    # worst over the phases, at the top of summary.json under its name)
    column: bool = False
    # in summary.json only where a phase has it (a track phase's, a zone's, ...):
    # checked where measured; a missing value is not a miss
    where_measured: bool = False

    @property
    def run_path(self) -> tuple[str, ...]:
        """Its value over the run in summary.json: a run metric's place, a phase
        metric's worst at the top under its name (``column``)."""
        return self.where if self.scope == "run" else (self.name,)

    def unit_of(self, state: str | None = None) -> str:
        """Its unit; of one state's bound for a per-state metric."""
        if self.expect == "per-state" and state is not None:
            return "rad" if state == "theta" else "m"
        return self.unit

    def worst(self, values: list[float]) -> float | None:
        """Its value over the run from its phases': the largest (an upper bound),
        the least (a lower bound); None without any."""
        if not values:
            return None
        return max(values) if self.bound == "max" else min(values)


CATALOG: dict[str, Metric] = {}
# Set once the mission models are built from the catalog: a metric added later
# would be judged but never accepted by `expect`.
_BUILT: list[bool] = []


def add(entry: Metric) -> Metric:
    """Register ``entry``: before the mission models are built (at import)."""
    if _BUILT:
        raise ValueError(
            f"metric {entry.name!r} comes after the mission models were built from the "
            "catalog: add it before wmr_mission.spec.models is imported"
        )
    if entry.name in CATALOG:
        raise ValueError(f"a metric named {entry.name!r} is registered already")
    CATALOG[entry.name] = entry
    return entry


def built() -> None:
    """The mission models are built from the catalog: no metric may follow."""
    _BUILT.append(True)


def metric(name: str) -> Metric:
    """The entry of ``name``; of ``estimation_rms.x``, ``estimation_rms``'s."""
    return CATALOG[name.split(".", 1)[0]]


def unit_of(check: str) -> str:
    """The unit of a check's value (``estimation_rms.x``: of its state), or ``""``:
    a count, a share, or a metric the catalog does not hold (a summary.json
    written by a build with another metric)."""
    base, _, state = check.partition(".")
    entry = CATALOG.get(base)
    return "" if entry is None else entry.unit_of(state or None)


def phase_metrics() -> Iterator[Metric]:
    """A phase's metrics an `expect` bounds, in the catalog's order."""
    return (m for m in CATALOG.values() if m.scope == "phase")


def run_metrics() -> Iterator[Metric]:
    """The run's metrics an `expect` bounds, in the catalog's order."""
    return (m for m in CATALOG.values() if m.scope == "run")


def columns() -> tuple[Metric, ...]:
    """The metrics runs.csv has a column of, in the catalog's order: the run's,
    then a phase's worst over the run."""
    return (*(m for m in run_metrics() if m.column), *(m for m in phase_metrics() if m.column))


_ZERO_TIME = "{max: 0} unless set."

# --- a phase's metrics --------------------------------------------------------
for _entry in (
    Metric(
        "tracking_error_rms",
        "m",
        "[m] RMS distance of the true position from the path after settle_time.",
        "phase",
        ("tracking_error", "rms"),
        kinds=TRACK,
        settled=True,
        panel="cross_track",
    ),
    Metric(
        "tracking_error_max",
        "m",
        "[m] largest distance of the true position from the path after settle_time.",
        "phase",
        ("tracking_error", "max"),
        kinds=TRACK,
        settled=True,
        panel="cross_track",
        line="distance to the path",
    ),
    Metric(
        "cross_track_error_max",
        "m",
        "[m] largest distance of the true position from its place on the path (track "
        "phases; the entry and detours a zone forces left out).",
        "phase",
        ("tracking", "cross_track_error_max"),
        expect="auto",
        kinds=TRACK,
        default="auto",
        default_words="auto: 0.1 m + the position noise std.",
        panel="cross_track",
        line="cross-track error",
        where_measured=True,
    ),
    Metric(
        "along_track_lag_max",
        "m",
        "[m] largest arc length between the robot's place on the path and its reference "
        "point, behind or ahead (track phases; the entry and detours left out).",
        "phase",
        ("tracking", "along_track_lag_max"),
        expect="auto",
        kinds=TRACK,
        default="auto",
        default_words=(
            "auto: 0.1 m + the position noise std + 3 time constants at the reference's top speed."
        ),
        panel="along_track",
        line="along-track lag",
        where_measured=True,
    ),
    Metric(
        "detour_offset_max",
        "m",
        "[m] largest distance from the path during a detour a zone forces.",
        "phase",
        ("tracking", "detour_offset_max"),
        expect="auto",
        kinds=TRACK,
        default="auto",
        default_words=(
            "auto: how far the phase's zones reach into the path (a box's or polygon's: the "
            "shorter way out across it) + the body's reach (robot.footprint) + the estimate's "
            "margin (constraint_margin less the body's) + the look-ahead + 0.1 m + the "
            "position noise std."
        ),
        panel="cross_track",
        line="cross-track error",
        where_measured=True,
    ),
    Metric(
        "detour_time",
        "s",
        "[s] time spent on detours a zone forces.",
        "phase",
        ("tracking", "detour_time"),
        kinds=TRACK,
        panel="cross_track",
        where_measured=True,
    ),
    Metric(
        "zone_intrusion_max",
        "m",
        "[m] deepest the true position went beyond a zone's edge (into a stay_outside "
        "region, out of a stay_inside one).",
        "phase",
        ("constraint", "intrusion_max"),
        default={"max": 0.005},
        default_words="{max: 0.005} unless set.",
        panel="zones",
        line="depth into a zone",
        where_measured=True,
    ),
    Metric(
        "clearance_min",
        "m",
        "[m] at least: the least distance of the robot's body (robot.footprint; a point "
        "without one) from a zone's forbidden side, negative where it went beyond; written "
        "as a number, clearance_min: 0.1 (at least 0.1 m).",
        "phase",
        ("constraint", "clearance_min"),
        expect="number",
        bound="min",
        default_words="Unless set: 0 with a robot.footprint (its body may not touch a zone), "
        "else null.",
        panel="zones",  # the body's: the panel draws its depth beside the axle's
        column=True,
        where_measured=True,
    ),
    Metric(
        "stall_time",
        "s",
        "[s] time a regulate phase spends away from its goal without taking 10 % of its "
        "error out over the next 20 time constants (or half a turn and 10 time constants).",
        "phase",
        ("regulation", "stall_time"),
        kinds=REGULATE,
        default={"max": 0.0},
        default_words=_ZERO_TIME,
        panel="goal",
        where_measured=True,
    ),
    Metric(
        "overshoot_max",
        "m",
        "[m] how far a regulate phase's robot went past its target, along the way from "
        "where the phase started to the target (not judged for a phase that starts within "
        "its goal).",
        "phase",
        ("regulation", "overshoot_max"),
        expect="auto",
        kinds=REGULATE,
        default="auto",
        default_words=(
            "auto: the phase's settled position tolerance + the position noise std (without "
            "`settled`, 0.1 m + the position noise std)."
        ),
        panel="goal",
        where_measured=True,
    ),
    Metric(
        "speed_jump_max",
        "m/s",
        "[m/s] largest change of v from one sample to the next.",
        "phase",
        ("inputs", "speed_jump_max"),
        expect="auto",
        default="auto",
        default_words="auto: limits.v, half the range.",
        panel="jumps",
        line="|Δv| [m/s]",
        where_measured=True,
    ),
    Metric(
        "turn_rate_jump_max",
        "rad/s",
        "[rad/s] largest change of omega from one sample to the next.",
        "phase",
        ("inputs", "turn_rate_jump_max"),
        expect="auto",
        default="auto",
        default_words="auto: limits.omega, half the range.",
        panel="jumps",
        line="|Δω| [rad/s]",
        where_measured=True,
    ),
    Metric(
        "speed_reversals",
        "",
        "Most sign reversals of v within any 10 time constants (a count; values within "
        "5 % of limits.v of zero not counted).",
        "phase",
        ("inputs", "speed_reversals"),
        default={"max": 3},
        default_words="{max: 3} unless set.",
        panel="saturation",
        where_measured=True,
    ),
    Metric(
        "turn_rate_reversals",
        "",
        "Most sign reversals of omega within any 10 time constants (a count; values within "
        "5 % of limits.omega plus 3 heading-noise std per time constant of zero not counted).",
        "phase",
        ("inputs", "turn_rate_reversals"),
        default={"max": 3},
        default_words="{max: 3} unless set.",
        panel="saturation",
        where_measured=True,
    ),
    Metric(
        "speed_fight_time",
        "s",
        "[s] time v spends at its limit in stretches of a time constant or more that "
        "reverse or turn less than half their distance into progress.",
        "phase",
        ("inputs", "speed_fight_time"),
        default={"max": 0.0},
        default_words=_ZERO_TIME,
        panel="saturation",
        where_measured=True,
    ),
    Metric(
        "turn_rate_fight_time",
        "s",
        "[s] time omega spends at its limit in stretches of a time constant or more that "
        "reverse or turn more than half a turn.",
        "phase",
        ("inputs", "turn_rate_fight_time"),
        default={"max": 0.0},
        default_words=_ZERO_TIME,
        panel="saturation",
        where_measured=True,
    ),
    Metric(
        "turn_rate_jitter",
        "rad/s",
        "[rad/s] 1.4826 times the median absolute deviation of omega from its centred "
        "moving mean over two time constants.",
        "phase",
        ("inputs", "turn_rate_jitter"),
        expect="auto",
        default="auto",
        default_words="auto: 1 % of limits.omega + the heading noise std per time constant.",
        panel="jitter",
        where_measured=True,
    ),
    Metric(
        "speed_at_limit",
        "",
        "Fraction of the samples after settle_time with |v| at limits.v.",
        "phase",
        ("inputs", "speed_at_limit"),
        settled=True,
        panel="saturation",
    ),
    Metric(
        "turn_rate_at_limit",
        "",
        "Fraction of the samples after settle_time with |omega| at limits.omega.",
        "phase",
        ("inputs", "turn_rate_at_limit"),
        settled=True,
        panel="saturation",
    ),
    Metric(
        "estimation_rms",
        "",  # per state: m or rad (Metric.unit_of)
        "RMS estimation error (true - estimate) per state after settle_time.",
        "phase",
        ("estimation", "rms"),
        expect="per-state",
        settled=True,
        panel="estimation",
    ),
    # --- the whole run's ------------------------------------------------------
    Metric(
        "final_position_error",
        "m",
        "[m] distance of the final true position from the target of the last regulate "
        "phase run, or from the last reference point if a track phase came after it "
        "(measured at that point's own sample where the track phase ends the run, whose "
        "last sample has no reference point; hold phases keep their entry pose and are "
        "skipped).",
        "run",
        ("final", "position_error"),
        panel="goal",
        line="distance to the target",
        column=True,
    ),
    Metric(
        "final_heading_error",
        "rad",
        "[rad] wrapped final heading error to that regulate target.",
        "run",
        ("final", "heading_error"),
        panel="goal",
        column=True,
    ),
    Metric(
        "max_constraint_violation",
        "constraint value",  # a constraint row's, in the region's own terms
        "Largest constraint-row value (> 0 = violated) over the states each phase's "
        "inputs produced: from a phase's second sample.",
        "run",
        ("max_constraint_violation",),
        panel="constraint",
        line="constraint value",
        column=True,
    ),
    Metric(
        "estimation_convergence_time",
        "s",
        "[s] first time after which every state's |estimation error| stays below its "
        "convergence_tolerance.",
        "run",
        ("estimation_convergence_time",),
        panel="estimation",
        column=True,
    ),
    Metric("duration", "s", "[s] mission time.", "run", ("duration",), panel="goal", column=True),
    Metric(
        "deadline_misses",
        "samples",
        "Samples whose step ended after their deadline, in a real-time run (backend ros2); "
        "not checked in a simulation.",
        "run",
        ("realtime", "deadline_misses"),
        panel="goal",
        column=True,
    ),
    Metric(
        "command_latency_p99",
        "ms",
        "[ms] 99th percentile of the time from reading a measurement to publishing the "
        "command computed from it, in a real-time run; not checked in a simulation.",
        "run",
        ("realtime", "latency_ms", "p99"),
        panel="goal",
        column=True,
    ),
):
    add(_entry)
