"""What a run produces, as plain arrays: the recorder's output and the input of
``wmr_mission.output`` (run directory, metrics, plots)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

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
EXTRA_COLUMNS = ("x_ref", "y_ref", "constraint", "phase2_iterations")
# The measurement the estimate of the row has seen; NaN when there was none
# (sample 0, between measurement periods, lost) or the state is not measured.
MEASUREMENT_COLUMNS = ("x_meas", "y_meas", "theta_meas")


class Outcome(StrEnum):
    success = "success"
    timeout = "timeout"  # a phase timed out with on_timeout: fail
    diverged = "diverged"  # non-finite or runaway state or input
    expect_failed = "expect-failed"  # ran to the end, an `expect` threshold not met
    interrupted = "interrupted"  # stopped by SIGINT or SIGTERM: the samples up to the stop


@dataclass(frozen=True)
class Transition:
    """One phase change. ``to_phase`` is None when the mission ends."""

    time: float
    from_phase: str
    to_phase: str | None
    condition: str  # "elapsed", "reaches", "settled", "timeout", ...
    value: float  # the value of the condition when it fired
    lap: int | None = None  # the lap of ``to_phase`` when it is in a repeat


@dataclass(frozen=True)
class PhaseInfo:
    name: str
    kind: str  # "track" | "regulate" | "hold"
    # Pose the phase regulates to (regulate/hold), else None.
    target: tuple[float, float, float] | None = None
    # Names of the regions constrained in this phase and how ("inside"/"outside").
    constraints: tuple[tuple[str, str], ...] = ()


@dataclass
class RunResult:
    """Arrays are one row per sample k = 0..n-1; sample 0 is the initial state.

    ``x, y, theta`` are the plant's true state, ``*_est`` the estimator's
    filtered estimate, ``v, omega`` the input applied from t[k] to t[k+1]
    (the last row repeats the previous input). ``x_ref, y_ref`` is the path
    point the controller aims at (NaN outside track phases). ``constraint`` is
    the largest constraint-row value of the phase at the true state (> 0 means
    violated; NaN when the phase has no constraint). ``x_meas, y_meas,
    theta_meas`` (``measurement``, one row per sample, None: not recorded)
    is the measurement of the sample, which ``*_est`` has seen (NaN when
    there was none or the state is not measured). ``compute_ns`` is the
    wall time of estimator + controller for that sample (not written to the
    CSV: it is not reproducible). ``loop_ns`` is the wall time of the whole
    simulation loop (plant, sensors, estimator, controller, phase logic,
    recording), start-up excluded.
    """

    mission_name: str
    dt: float
    seed: int
    phases: list[PhaseInfo]
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
    loop_ns: int = 0
    measurement: FloatArray | None = None  # (n, 3) x_meas, y_meas, theta_meas

    def measurement_column(self, index: int) -> FloatArray:
        """Column ``index`` (0: x, 1: y, 2: theta) of the measurements; NaN if not recorded."""
        if self.measurement is None:
            return np.full(self.samples, np.nan)
        return self.measurement[:, index]

    @property
    def samples(self) -> int:
        return int(self.t.shape[0])
