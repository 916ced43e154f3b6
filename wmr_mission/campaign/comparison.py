"""What a head-to-head campaign compares controllers (and estimators) by, per run.

Beside the metrics an ``expect`` bounds (wmr_mission.verdicts.metrics), each
row of ``runs.csv`` carries four figures of how the robot was driven, from
the run's samples:

* ``reference_error_rms`` [m]: RMS distance from the robot to the path's point
  of the same instant, over the samples of track phases after each one's
  settle time (``expect.settle_time``, 1 s unless written): summary.json's
  ``reference_error_rms`` of each track phase, over them all
  (:func:`reference_error`);
* ``run_turn_rate_jitter`` [rad/s]: the robust spread of the turn rate about
  its centred moving mean over the whole run from its first step, measured
  as summary.json's ``turn_rate_jitter`` is per phase from the sample its
  inputs are judged (wmr_mission.verdicts.inputs.jitter): not the same
  samples, so not the same name;
* ``input_saturation``: the fraction of samples with the speed or the turn
  rate at its limit;
* ``reference_capture_time`` [s]: from the start of the first track phase,
  the time after which the robot stays within ``SETTLED_WITHIN`` of the
  reference point for every later sample of a track phase (None: not by the
  end); not ``expect.settle_time``, the time a phase's metrics leave out.

They are cheap (no distance to the whole path), so every campaign row has them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Final

import numpy as np

from wmr_mission.output.result import RunResult
from wmr_mission.spec.models import DEFAULT_SETTLE_TIME
from wmr_mission.spec.numbers import mission_numbers
from wmr_mission.verdicts.inputs import jitter
from wmr_mission.verdicts.metrics import (
    AT_LIMIT_TOLERANCE,
    phase_segments,
    reference_distance,
    reference_error,
)

# Each with its unit (runs.csv's, the figures' axes).
COMPARISON_UNITS: Final = {
    "reference_error_rms": "m",
    "run_turn_rate_jitter": "rad/s",
    "input_saturation": "share of samples",
    "reference_capture_time": "s",
}
COMPARISON_METRICS: Final = tuple(COMPARISON_UNITS)
SETTLED_WITHIN: Final = 0.05  # [m] distance to the reference point counted as settled


def comparison_metrics(
    result: RunResult, mission: Mapping[str, Any] | None
) -> tuple[float | None, ...]:
    """The run's COMPARISON_METRICS, in that order."""
    expect = (mission or {}).get("expect") or {}
    settle = expect.get("settle_time")
    settle_time = DEFAULT_SETTLE_TIME if settle is None else float(settle)
    stepped = slice(0, max(0, result.samples - 1))  # the closing row takes no step
    v, omega = result.v[stepped], result.omega[stepped]
    saturated = None
    if v.size:
        near = 1.0 - AT_LIMIT_TOLERANCE  # an infinite limit is never reached
        limit_v, limit_omega = result.limits
        at_limit = (np.abs(v) >= limit_v * near) | (np.abs(omega) >= limit_omega * near)
        saturated = float(np.count_nonzero(at_limit)) / float(v.size)
    rms, settled_at = _reference_error(result, settle_time)
    turns = (
        jitter(omega, mission_numbers(mission, result.dt, result.limits)) if omega.size else None
    )
    return rms, turns, saturated, settled_at


def _reference_error(result: RunResult, settle_time: float) -> tuple[float | None, float | None]:
    """(RMS distance to the reference after each track phase's settle time,
    time to settle within SETTLED_WITHIN) over the track phases' samples."""
    # Each track phase's stretches by slices (a phase left and entered again
    # has several, its settle time from its first sample): masks or indices
    # per phase over the whole column cost several times as much.
    t = result.t
    tracked = np.zeros(result.samples, dtype=bool)
    settled = np.zeros(result.samples, dtype=bool)
    floor = settle_time - 1e-9 * result.dt
    for i, start, end, _ in phase_segments(result):  # each entry from its own start
        if result.phases[i].kind == "track" and start < end:
            tracked[start:end] = True
            settled[start:end] = t[start:end] - t[start] >= floor
    tracked &= np.isfinite(result.x_ref)
    if not tracked.any():
        return None, None
    error = reference_distance(result.x, result.y, result.x_ref, result.y_ref)
    rms = reference_error(error[tracked & settled])  # the judge's: its exact sum compiled
    outside = np.flatnonzero(tracked & (error > SETTLED_WITHIN))
    if outside.size == 0:
        return rms, 0.0
    later = tracked[outside[-1] + 1 :]
    if not later.any():
        return rms, None  # not settled by the end
    after = outside[-1] + 1 + int(later.argmax())  # the next tracked sample
    return rms, round(float(t[after] - t[int(tracked.argmax())]), 9)
