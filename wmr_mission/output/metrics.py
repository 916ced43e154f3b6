"""Metrics of a run (``summary.json``) and the mission's ``expect`` thresholds.

The estimation error of a state is true minus estimate (``x - x_est``), the
sign of the output error ``xi - xi_hat`` bounded by eq. (4); heading errors are
wrapped to [-pi, pi). Values that do not exist (no track phase, no constraint,
never converged) are ``None`` and become ``null`` in JSON; so does anything
non-finite, e.g. after a divergence.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wmr_mission.result import FloatArray, PhaseInfo, RunResult

STATES = ("x", "y", "theta")
# |estimation error| below which a state counts as converged; the same number
# as the paper's "short transient" acceptance and `expect.estimation_convergence_time`.
CONVERGENCE_TOLERANCE = 0.05
# Tracking-error RMS is also reported without the entry transient of a phase.
TRACKING_SETTLE_TIME = 1.0  # [s]
# A constraint row above this counts as violated: a constraint held as an
# equality by the corrective action sits on 0 to rounding.
VIOLATION_TOLERANCE = 1e-6

# `expect` key -> where its value lives in the summary.
_EXPECTATION_PATHS: dict[str, tuple[str, ...]] = {
    "final_position_error": ("final", "position_error"),
    "final_heading_error": ("final", "heading_error"),
    "max_constraint_violation": ("max_constraint_violation",),
    "estimation_convergence_time": ("estimation_convergence_time",),
    "duration": ("duration",),
}


def wrap_angle(angle: FloatArray) -> FloatArray:
    """Angles wrapped to [-pi, pi)."""
    wrapped: FloatArray = (angle + np.pi) % (2.0 * np.pi) - np.pi
    return wrapped


def _finite_or_none(value: float | np.floating[Any]) -> float | None:
    number = float(value)
    return number if math.isfinite(number) else None


def _max_or_none(values: FloatArray) -> float | None:
    """Largest finite value, or None when there is none."""
    finite = values[np.isfinite(values)]
    return float(finite.max()) if finite.size else None


def _violation(values: FloatArray) -> float | None:
    """How far the largest constraint-row value is above 0 (0 when never);
    None when no constraint applied."""
    largest = _max_or_none(values)
    return None if largest is None else max(0.0, largest)


def _rms_or_none(values: FloatArray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(finite**2))) if finite.size else None


def estimation_errors(result: RunResult) -> dict[str, FloatArray]:
    """True minus estimated state per sample, heading wrapped."""
    return {
        "x": result.x - result.x_est,
        "y": result.y - result.y_est,
        "theta": wrap_angle(result.theta - result.theta_est),
    }


def convergence_index(errors: dict[str, FloatArray]) -> int | None:
    """First sample from which every |error| stays below the tolerance to the end, else None."""
    stacked = np.abs(np.vstack(list(errors.values())))
    # NaN compares False: a non-finite error is never converged.
    converged = np.all(stacked < CONVERGENCE_TOLERANCE, axis=0)
    if converged.size == 0:
        return None
    unconverged = np.flatnonzero(~converged)
    if unconverged.size == 0:
        return 0
    last = int(unconverged[-1])
    return last + 1 if last + 1 < converged.size else None


def overshoot(error: FloatArray) -> float:
    """Step-response overshoot of an error decaying from ``error[0]``, as a fraction of it.

    max over k of ``-sign(e0) * e[k] / |e0|``; 0 when the error never crosses
    zero, or when it starts at zero.
    """
    if error.size == 0 or not math.isfinite(float(error[0])) or error[0] == 0.0:
        return 0.0
    crossed = _max_or_none(-np.sign(error[0]) * error / abs(float(error[0])))
    return max(0.0, crossed) if crossed is not None else 0.0


def phase_segments(phase: np.ndarray) -> list[tuple[int, int, int]]:
    """(phase index, first sample, one past the last sample) of each stretch, in run order."""
    if phase.size == 0:
        return []
    starts = np.concatenate(([0], np.flatnonzero(np.diff(phase) != 0) + 1))
    ends = np.concatenate((starts[1:], [phase.size]))
    return [(int(phase[s]), int(s), int(e)) for s, e in zip(starts, ends, strict=True)]


def _phase_target(
    result: RunResult, info: PhaseInfo, start: int, end: int
) -> tuple[float, float, float | None] | None:
    """The pose a phase aims at: its target, or for a track phase its last reference point."""
    if info.kind == "track":
        known = np.flatnonzero(
            np.isfinite(result.x_ref[start:end]) & np.isfinite(result.y_ref[start:end])
        )
        if known.size == 0:
            return None
        k = start + int(known[-1])
        return float(result.x_ref[k]), float(result.y_ref[k]), None
    if info.target is None:
        return None
    return info.target


def _pose_error(
    result: RunResult, k: int, target: tuple[float, float, float | None]
) -> tuple[float | None, float | None]:
    position = math.hypot(float(result.x[k]) - target[0], float(result.y[k]) - target[1])
    heading = None
    if target[2] is not None:
        heading = abs(float(wrap_angle(np.array([float(result.theta[k]) - target[2]]))[0]))
        heading = _finite_or_none(heading)
    return _finite_or_none(position), heading


def _final(result: RunResult, segments: list[tuple[int, int, int]]) -> dict[str, Any]:
    """Final error of the true pose from the aim of the last phase that has one.

    The aim is a regulate target, or a track phase's last reference point (no
    heading then); phases are searched from the last one run backwards. A hold
    phase keeps the pose it started from, so it has no aim of its own: the
    error of a mission ending "park, then hold" is measured from the park's
    target.
    """
    final: dict[str, Any] = {
        "position_error": None,
        "heading_error": None,
        "target": None,
        "pose": None,
    }
    if result.samples == 0:
        return final
    last = result.samples - 1
    for index, start, end in reversed(segments):
        info = result.phases[index]
        if info.kind == "hold":
            continue
        target = _phase_target(result, info, start, end)
        if target is None:
            continue
        final["position_error"], final["heading_error"] = _pose_error(result, last, target)
        final["target"] = {"phase": info.name, "x": target[0], "y": target[1], "theta": target[2]}
        break
    final["pose"] = {
        "x": _finite_or_none(result.x[last]),
        "y": _finite_or_none(result.y[last]),
        "theta": _finite_or_none(result.theta[last]),
    }
    return final


def _phase_summary(
    result: RunResult,
    errors: dict[str, FloatArray],
    index: int,
    start: int,
    end: int,
) -> dict[str, Any]:
    info = result.phases[index]
    t = result.t
    # A phase lasts until the next one begins (or the run ends).
    end_sample = end if end < result.samples else result.samples - 1
    window = slice(start, end)
    start_time = float(t[start])

    tracking = None
    if info.kind == "track":
        distance = np.hypot(
            result.x[window] - result.x_ref[window], result.y[window] - result.y_ref[window]
        )
        settled = (t[window] - start_time) >= TRACKING_SETTLE_TIME - 1e-9 * result.dt
        tracking = {
            "rms": _rms_or_none(distance),
            "max": _max_or_none(distance),
            "rms_after_1s": _rms_or_none(distance[settled]),
        }

    target_error = None
    if info.kind != "track" and info.target is not None:
        position, heading = _pose_error(result, end_sample, info.target)
        target_error = {"position": position, "heading": heading}

    constraint = result.constraint[window]
    phase_errors = {state: error[window] for state, error in errors.items()}
    converged = convergence_index(phase_errors)
    iterations = result.phase2_iterations[window]
    return {
        "name": info.name,
        "kind": info.kind,
        "start": start_time,
        "end": float(t[end_sample]),
        "duration": round(float(t[end_sample]) - start_time, 9),  # no 20.000000000000004
        "tracking_error": tracking,
        "target_error": target_error,
        "constraint": {
            "max_violation": _violation(constraint),
            # the largest row value itself: negative = the closest approach
            "max_value": _max_or_none(constraint),
            "time_in_violation": (
                float(np.count_nonzero(constraint > VIOLATION_TOLERANCE)) * result.dt
            ),
        },
        "estimation": {
            "max_abs_error": {s: _max_or_none(np.abs(e)) for s, e in phase_errors.items()},
            "overshoot": {s: overshoot(e) for s, e in phase_errors.items()},
            # seconds after the phase start
            "convergence_time": (
                None if converged is None else float(t[start + converged]) - start_time
            ),
        },
        "max_abs_v": _max_or_none(np.abs(result.v[window])),
        "max_abs_omega": _max_or_none(np.abs(result.omega[window])),
        "phase2_iterations": {
            "total": int(iterations.sum()),
            "max": int(iterations.max()) if iterations.size else 0,
        },
    }


def compute_time_us(compute_ns: np.ndarray) -> dict[str, float | None]:
    """Estimator + controller wall time per sample [us]: mean, median, 99th percentile."""
    if compute_ns.size == 0:
        return {"mean": None, "median": None, "p99": None}
    us = compute_ns.astype(np.float64) / 1000.0
    return {
        "mean": float(np.mean(us)),
        "median": float(np.median(us)),
        "p99": float(np.percentile(us, 99)),
    }


def summarize(result: RunResult) -> dict[str, Any]:
    """All metrics of a run, in a fixed key order (the content of ``summary.json``)."""
    segments = phase_segments(result.phase)
    errors = estimation_errors(result)
    converged = convergence_index(errors)
    duration = round(float(result.t[-1] - result.t[0]), 9) if result.samples else 0.0
    return {
        "outcome": result.outcome.value,
        "message": result.message,
        "mission": result.mission_name,
        "seed": result.seed,
        "samples": result.samples,
        "duration": duration,
        "final": _final(result, segments),
        "estimation_convergence_time": None if converged is None else float(result.t[converged]),
        "estimation_overshoot": {state: overshoot(error) for state, error in errors.items()},
        "max_constraint_violation": _violation(result.constraint),
        "phases": [
            _phase_summary(result, errors, index, start, end) for index, start, end in segments
        ],
        "compute_us_per_sample": compute_time_us(result.compute_ns),
        "loop_us_per_sample": loop_time_us(result),
    }


def loop_time_us(result: RunResult) -> float | None:
    """Wall time of the whole simulation loop per sample [us] (None when not timed)."""
    if result.loop_ns <= 0 or result.samples == 0:
        return None
    return result.loop_ns / 1000.0 / result.samples


def _summary_value(summary: dict[str, Any], path: tuple[str, ...]) -> float | None:
    value: Any = summary
    for key in path:
        if not isinstance(value, dict):
            return None
        value = value.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def check_expectations(summary: dict[str, Any], expect: dict[str, Any]) -> list[dict[str, Any]]:
    """Each set ``expect`` threshold with the run's value; a missing (null) value never meets one.

    ``expect`` is ``Expect.model_dump()``: metric -> None or ``{"max": float}``.
    """
    checks = []
    for metric, threshold in expect.items():
        if threshold is None:
            continue
        if metric not in _EXPECTATION_PATHS:
            raise ValueError(
                f"unknown expectation {metric!r}; expected one of {', '.join(_EXPECTATION_PATHS)}"
            )
        limit = float(threshold["max"])
        value = _summary_value(summary, _EXPECTATION_PATHS[metric])
        checks.append(
            {
                "metric": metric,
                "max": limit,
                "value": value,
                "met": value is not None and value <= limit,
            }
        )
    return checks
