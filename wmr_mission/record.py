"""What a run records, as plain arrays: the simulation's output, and what the
verdicts judge and ``wmr_mission.output`` writes and draws.

Below both: the record imports neither. ``wmr_mission.output.result.RunResult``
is this record with the ways to write it (``summary()``, ``write()``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any

import numpy as np

from wmr_mission.basics import FloatArray, IntArray

if TYPE_CHECKING:
    import pandas


# The first columns of trajectory.csv, in this order (DESIGN.md).
TRAJECTORY_COLUMNS = (
    "t",
    "x",
    "y",
    "theta",
    "x_est",
    "y_est",
    "theta_est",
    "v",
    "omega",
    "phase",
)
# Columns that follow them.
EXTRA_COLUMNS = (
    "x_ref",
    "y_ref",
    "constraint",
    "x_meas",
    "y_meas",
    "theta_meas",
    "phase2_iterations",
)
CSV_COLUMNS = TRAJECTORY_COLUMNS + EXTRA_COLUMNS
# The last column of a run whose mission has updates: the number of the
# reference in force (docs/run-directory.md); other runs keep their bytes.
REFERENCE_COLUMN = "reference"
INTEGER_COLUMNS = ("phase2_iterations", REFERENCE_COLUMN)


class Outcome(StrEnum):
    success = "success"
    timeout = "timeout"  # a phase timed out with on_timeout: fail
    diverged = "diverged"  # non-finite or runaway state or input
    expect_failed = "expect-failed"  # ran to the end, an `expect` threshold not met
    interrupted = "interrupted"  # stopped by SIGINT or SIGTERM: the samples up to the stop
    # the plant side stopped the run (a robot's measurements stopped, its
    # driver raised), or a plug-in's code raised, or its step returned the wrong shape
    failed = "failed"
    breached = "breached"  # the geofence breached, and its reaction failed the mission
    error = "error"  # a fault of our own inside the loop: a bug to report; samples kept


@dataclass(frozen=True)
class Transition:
    """One phase change. ``to_phase`` is None when the mission ends."""

    time: float
    from_phase: str
    to_phase: str | None
    condition: str  # "elapsed", "reaches", "settled", "timeout", ...
    value: float  # the value of the condition when it fired
    lap: int | None = None  # the lap of ``to_phase`` when it is in a repeat
    # The reaction that fired, as written ("retry: 2 (1 of 2)", "detour",
    # "then: resume"), and why, in words; None where the phases just ran in order.
    reaction: str | None = None
    why: str | None = None

    def fields(self) -> dict[str, Any]:
        """Its fields as the exports write them (a value that is not finite: None)."""
        return {
            "time": self.time,
            "from": self.from_phase,
            "to": self.to_phase,
            "condition": self.condition,
            "value": self.value if math.isfinite(self.value) else None,
            "lap": self.lap,
            "reaction": self.reaction,
            "why": self.why,
        }


Pose = tuple[float, float, float]


@dataclass(frozen=True)
class PhaseRecord:
    """What a run records of one of its phases (manifest.json keeps it)."""

    name: str
    kind: str  # "track" | "regulate" | "hold"
    # Pose the phase regulates to (regulate/hold), else None.
    target: tuple[float, float, float] | None = None
    # Names of the regions constrained in this phase and how ("inside"/"outside").
    constraints: tuple[tuple[str, str], ...] = ()
    # The phase's `until: near` goal: (x, y, tolerance), else None.
    near: tuple[float, float, float] | None = None
    # Points a track phase's path is written through (waypoints), for the figures.
    points: tuple[tuple[float, float], ...] = ()
    color: str | None = None  # from the mission's `plot.phase_colors`
    # A regulate phase whose `updates` changed its target: (sample, x, y, theta)
    # from which each target was in force, in sample order, its entries
    # included; empty: ``target`` throughout.
    targets: tuple[tuple[int, float, float, float], ...] = ()

    def targets_in_force(self, start: int, end: int) -> list[tuple[int, int, Pose]]:
        """(first sample, one past the last, target) of each stretch of samples
        ``start .. end - 1`` (a stretch of the run this phase ran) over which one
        target was in force; ``target`` over all of them without ``targets``;
        none over no sample."""
        if not self.targets:
            return [] if self.target is None or start >= end else [(start, end, self.target)]
        stretches: list[tuple[int, int, Pose]] = []
        for i, (first, x, y, theta) in enumerate(self.targets):
            stop = self.targets[i + 1][0] if i + 1 < len(self.targets) else end
            first, stop = max(first, start), min(stop, end)
            if first < stop:
                stretches.append((first, stop, (x, y, theta)))
        return stretches


@dataclass
class RunRecord:
    """Arrays are one row per sample k = 0..n-1; sample 0 is the initial state.

    ``x, y, theta`` are the plant's true state, ``*_est`` the estimator's
    filtered estimate, ``v, omega`` the input applied from t[k] to t[k+1]
    (the last row repeats the previous input). ``*_meas`` is the measurement
    the estimator received at t[k] (NaN at k = 0 and for unmeasured states).
    ``x_ref, y_ref`` is the path
    point the controller aims at (NaN outside track phases). ``constraint`` is
    the largest constraint-row value of the phase at the true state (> 0 means
    violated; NaN when the phase has no constraint). ``compute_ns`` is the
    wall time of estimator + controller for that sample (not written to the
    CSV: it is not reproducible). ``loop_ns`` is the wall time of the whole
    simulation loop (plant, sensors, estimator, controller, phase logic,
    recording), start-up excluded.
    """

    mission_name: str
    dt: float
    seed: int
    phases: list[PhaseRecord]
    t: FloatArray
    x: FloatArray
    y: FloatArray
    theta: FloatArray
    x_est: FloatArray
    y_est: FloatArray
    theta_est: FloatArray
    v: FloatArray
    omega: FloatArray
    phase: IntArray  # index into ``phases``
    x_ref: FloatArray
    y_ref: FloatArray
    constraint: FloatArray
    phase2_iterations: IntArray
    compute_ns: IntArray
    transitions: list[Transition]
    outcome: Outcome
    message: str  # one line: why the run ended as it did
    limits: tuple[float, float]  # |v| and |omega| limits
    # Output-error bounds of eq. (4) per state (lower, upper), NaN where unused.
    error_bounds: tuple[tuple[float, float], tuple[float, float], tuple[float, float]]
    regions: dict[str, Any] = field(default_factory=dict)  # name -> region spec (for plots)
    # [m] the margin the controller kept every zone with (Plant.constraint_margin)
    constraint_margin: float = 0.0
    x_meas: FloatArray = field(default_factory=lambda: np.zeros(0))
    y_meas: FloatArray = field(default_factory=lambda: np.zeros(0))
    theta_meas: FloatArray = field(default_factory=lambda: np.zeros(0))
    # The mission as run, with its defaults (``Mission.model_dump(mode="json")``):
    # its `expect` judges the run; None for a run of a compiled mission.
    mission: dict[str, Any] | None = None
    loop_ns: int = 0
    # How this run's loop ran: compiled by numba (True) or as plain Python
    # (False: a short run, a plug-in of plain Python objects, no numba); None
    # for a run not simulated in this process (manifest.json's `loop`).
    loop_compiled: bool | None = None
    # The number of the reference in force at each sample (0: the phase's own,
    # n: its update n took over), for a mission with updates; else None.
    reference: IntArray | None = None
    # A run on another plant (wmr_mission.backends): summary.json's `realtime`
    # (deadline misses, command latency, the zero command at the end) and
    # manifest.json's `backend` (its type, versions, settings). None in our simulator.
    realtime: dict[str, Any] | None = None
    backend: dict[str, Any] | None = None
    # A run read back from its directory: summary.json's `expectations`, the
    # checks as they were judged, read as data by the figures (None: judge it)
    expectations: list[dict[str, Any]] | None = None
    # summary.json's metrics and verdicts as ``verdicts.metrics.judge`` found them
    # by ``mission``: computed once per run, for the file, the table and the API.
    # Not copied by ``dataclasses.replace``.
    judged: dict[str, Any] | None = field(default=None, init=False, repr=False, compare=False)

    def __repr__(self) -> str:
        """A line, not the arrays: the mission, how it ended and its size."""
        duration = float(self.t[-1] - self.t[0]) if self.samples else 0.0
        return (
            f"RunResult(mission={self.mission_name!r}, outcome={self.outcome.value!r}, "
            f"samples={self.samples}, duration={duration:.6g} s, phases={len(self.phases)}, "
            f"seed={self.seed})"
        )

    def __post_init__(self) -> None:
        for name in ("x_meas", "y_meas", "theta_meas"):
            if getattr(self, name).shape[0] != self.t.shape[0]:  # not recorded: none known
                setattr(self, name, np.full(self.t.shape[0], np.nan))

    @property
    def succeeded(self) -> bool:
        return self.outcome is Outcome.success

    def miss_expectations(self, unmet: list[str]) -> None:
        """A success that misses `expect` thresholds is not one: ``expect-failed``,
        with the misses as its message."""
        if self.succeeded and unmet:
            self.outcome = Outcome.expect_failed
            self.message = "expectation not met: " + "; ".join(unmet)

    @property
    def samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def phase_names(self) -> list[str]:
        """The phases' names in mission order; ``phase`` indexes this list."""
        return [info.name for info in self.phases]

    def to_dataframe(self) -> pandas.DataFrame:
        """The samples as a pandas DataFrame, columns as in ``trajectory.csv``
        (``phase`` holds the phase names). Needs pandas."""
        try:
            import pandas
        except ImportError:
            raise ImportError(
                "RunResult.to_dataframe needs pandas: pip install 'wmr-mission[dataframe]'"
            ) from None
        columns: dict[str, Any] = {name: getattr(self, name) for name in csv_columns(self)}
        columns["phase"] = pandas.Categorical.from_codes(self.phase, categories=self.phase_names)
        return pandas.DataFrame(columns)


def csv_columns(record: RunRecord) -> tuple[str, ...]:
    """The columns of the run's ``trajectory.csv``: ``reference`` last where it has one."""
    return CSV_COLUMNS + ((REFERENCE_COLUMN,) if record.reference is not None else ())
