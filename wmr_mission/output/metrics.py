"""Metrics of a run (``summary.json``) and the mission's ``expect`` thresholds.

The estimation error of a state is true minus estimate (``x - x_est``), the
sign of the output error ``xi - xi_hat`` bounded by eq. (4); heading errors are
wrapped to [-pi, pi). Values that do not exist (no track phase, no constraint,
never converged) are ``None`` and become ``null`` in JSON; so does anything
non-finite, e.g. after a divergence.

Everything here is computed from the recorded arrays of a :class:`RunResult`
after the run. The quality metrics of a phase (tracking error, inputs,
estimation RMS) leave out its first ``settle_time`` seconds: the entry
transient is the controller's job, not a fault.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import STATES, FloatArray
from wmr_mission.spec import models

if TYPE_CHECKING:
    from wmr_mission.output.result import PhaseRecord, RunResult

# The mission's `expect` settings when a summary is made without a mission.
DEFAULT_CONVERGENCE_TOLERANCE = dict.fromkeys(STATES, models.DEFAULT_CONVERGENCE_TOLERANCE)
# A constraint row above this counts as violated: a constraint held as an
# equality by the corrective action sits on 0 to rounding.
VIOLATION_TOLERANCE = 1e-6
# An input within this fraction of its limit counts as at the limit (the
# runner clips to the limit exactly; this only absorbs rounding).
AT_LIMIT_TOLERANCE = 1e-9
# Turn-rate jitter is measured about a centred moving mean of this many samples.
JITTER_WINDOW = 25
# Distance to the path: the segments within this many reference points of a
# sample's own, and those next to this many of the path's nearest points, are tried.
LOCAL_WINDOW = 8
_NEAREST_POINTS = 4
_DISTANCE_CHUNK = 4096  # positions per block: bounded memory on long runs
_CANDIDATES = 1 << 16  # candidate distances per block of the nearest-points search

# Mission-wide `expect` key -> where its value lives in the summary.
EXPECTATION_PATHS: dict[str, tuple[str, ...]] = {
    "final_position_error": ("final", "position_error"),
    "final_heading_error": ("final", "heading_error"),
    "max_constraint_violation": ("max_constraint_violation",),
    "estimation_convergence_time": ("estimation_convergence_time",),
    "duration": ("duration",),
    "deadline_misses": ("realtime", "deadline_misses"),
    "command_latency_p99": ("realtime", "latency_ms", "p99"),
}
# Thresholds on a real-time run's pace: not checked where the run was not one.
REALTIME_EXPECTATIONS = ("deadline_misses", "command_latency_p99")
# Per-phase `expect` key -> where its value lives in a phase's summary. A
# mission-wide value applies to every phase; a phase's own value overrides it.
PHASE_EXPECTATION_PATHS: dict[str, tuple[str, ...]] = {
    "tracking_error_rms": ("tracking_error", "rms"),
    "tracking_error_max": ("tracking_error", "max"),
    "speed_at_limit": ("inputs", "speed_at_limit"),
    "turn_rate_at_limit": ("inputs", "turn_rate_at_limit"),
    "turn_rate_jitter": ("inputs", "turn_rate_jitter"),
    "turn_rate_reversals": ("inputs", "turn_rate_reversals"),
    "estimation_rms": ("estimation", "rms"),  # per state
}
# `expect` keys that set how metrics are measured, not thresholds.
_SETTINGS = ("settle_time", "convergence_tolerance")


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


def estimation_errors(result: RunResult, window: slice = slice(None)) -> dict[str, FloatArray]:
    """True minus estimated state per sample (of ``window``), heading wrapped."""
    r, w = result, window
    return {
        "x": r.x[w] - r.x_est[w],
        "y": r.y[w] - r.y_est[w],
        "theta": wrap_angle(r.theta[w] - r.theta_est[w]),
    }


def convergence_index(
    errors: dict[str, FloatArray], tolerance: Mapping[str, float] | None = None
) -> int | None:
    """First sample from which every |error| stays below its state's tolerance
    to the end, else None."""
    tolerance = DEFAULT_CONVERGENCE_TOLERANCE if tolerance is None else tolerance
    converged = np.ones(len(next(iter(errors.values()))), dtype=bool)
    for state, error in errors.items():  # state by state: no copy of all three
        # NaN compares False: a non-finite error is never converged.
        converged &= np.abs(error) < tolerance[state]
    if converged.size == 0:
        return None
    unconverged = np.flatnonzero(~converged)
    if unconverged.size == 0:
        return 0
    last = int(unconverged[-1])
    return last + 1 if last + 1 < converged.size else None


def overshoot(error: FloatArray, floor: float = 0.0) -> float:
    """Step-response overshoot of an error decaying from ``error[0]``.

    max over k of ``-sign(e0) * e[k] / max(|e0|, floor)``: how far the error
    swings past zero, as a fraction of its initial value, or of ``floor`` (the
    state's convergence tolerance) when it starts smaller, so that a swing
    from a vanishing initial error is not blown up. 0 when the error never
    crosses zero, or when it starts at zero.
    """
    if error.size == 0 or not math.isfinite(float(error[0])) or error[0] == 0.0:
        return 0.0
    scale = max(abs(float(error[0])), floor)
    crossed = _max_or_none(-np.sign(error[0]) * error / scale)
    return max(0.0, crossed) if crossed is not None else 0.0


def distance_to_path(
    x: FloatArray, y: FloatArray, x_ref: FloatArray, y_ref: FloatArray
) -> FloatArray:
    """Distance of each position ``(x[k], y[k])`` from the path: the polyline
    through the finite reference points in order (the path passed so far).
    NaN where the position is not finite.

    The segments tried are those within LOCAL_WINDOW points of the sample's own
    reference point (where a robot that tracks is), and those next to the
    points of the whole path nearest to it (where a robot that fell behind or
    cut across is). For the second, the path's points are thinned to one per
    cell of a grid half as fine as its sampling, else a path run round many
    times is searched lap by lap. So the distance is never below the true one,
    is exact when the nearest point lies within the window, and is at most
    about one sampling step above it otherwise.
    """
    distance = np.full(x.shape, np.nan)
    known = np.isfinite(x_ref) & np.isfinite(y_ref)
    finite = np.isfinite(x) & np.isfinite(y)
    # Copies only where something is missing: a long run's columns are large.
    px, py = (x_ref, y_ref) if known.all() else (x_ref[known], y_ref[known])
    if px.size == 0 or not finite.any():
        return distance
    qx, qy = (x, y) if finite.all() else (x[finite], y[finite])
    if px.size == 1:
        distance[finite] = np.hypot(qx - px[0], qy - py[0])
        return distance
    own = np.maximum(np.cumsum(known) - 1, 0)[finite]  # each sample's reference point
    steps = np.hypot(np.diff(px), np.diff(py))
    cell = float(np.median(steps[steps > 0])) / 2 if np.any(steps > 0) else 1.0
    # One point per cell: the first the path passes in it (a stable sort by cell).
    column, row = np.floor(px / cell), np.floor(py / cell)
    order = np.lexsort((row, column))
    column, row = column[order], row[order]
    first = order[np.r_[True, (column[1:] != column[:-1]) | (row[1:] != row[:-1])]]
    grid = _PointGrid(px[first], py[first], cell)
    found = np.empty(qx.size)
    last = px.size - 2  # segment i runs from point i to point i + 1
    for start in range(0, qx.size, _DISTANCE_CHUNK):  # bounded memory on long runs
        part = slice(start, start + _DISTANCE_CHUNK)
        local = own[part, None] + np.arange(-LOCAL_WINDOW, LOCAL_WINDOW)
        near = _distance_to_segments(px, py, np.clip(local, 0, last), qx[part], qy[part])
        # The nearest points are looked for about as far as the path is near.
        nearest = first[grid.nearest(qx[part], qy[part], _NEAREST_POINTS, near)]
        segments = np.clip(np.concatenate((nearest - 1, nearest), axis=1), 0, last)
        found[part] = np.minimum(near, _distance_to_segments(px, py, segments, qx[part], qy[part]))
    distance[finite] = found
    return distance


class _PointGrid:
    """The k points nearest a position, exactly, by numpy alone.

    The points are bucketed in square cells of side ``cell``, then 2, 4, ...
    times that. At each size, the points of the 3 x 3 cells round a position's
    cell are its candidates: the k nearest of them are the k nearest of all
    when the k-th is no farther than the edge of those 9 cells (or when they
    hold every point). A position not settled at one size is tried at the
    next, up to the size where 2 x 2 cells hold the whole path; those left
    (far off the path) are measured against every point.
    """

    def __init__(self, px: FloatArray, py: FloatArray, cell: float) -> None:
        self.px, self.py = px, py
        self.origin = (float(px.min()), float(py.min()))
        self.cell = cell
        self._levels: dict[float, Any] = {}  # cell size -> buckets, made once

    def nearest(
        self, qx: FloatArray, qy: FloatArray, k: int, reach: FloatArray
    ) -> NDArray[np.intp]:
        """Indices (len(qx), min(k, points)) of the points nearest each position;
        ``reach`` guesses how far they are (it only sets where the search starts)."""
        k = min(k, self.px.size)
        found = np.zeros((qx.size, k), dtype=np.intp)
        # The first size whose cells' reach (at least one side) covers the guess.
        doublings = np.log2(np.maximum(reach + 2 * self.cell, self.cell) / self.cell)
        level = np.ceil(np.nan_to_num(doublings, nan=0.0, posinf=64.0)).astype(np.int64)
        unsettled = np.ones(qx.size, dtype=bool)
        size = self.cell
        while unsettled.any():
            if size not in self._levels:
                self._levels[size] = self._buckets(size)
            buckets = self._levels[size]
            if buckets is None:  # 2 x 2 cells hold the whole path
                pending = np.flatnonzero(unsettled)
                found[pending] = self._every_point(qx[pending], qy[pending], k)
                break
            pending = np.flatnonzero(unsettled & (level <= 0))
            level -= 1
            settled = np.zeros(pending.size, dtype=bool)
            rows = max(1, _CANDIDATES // (9 * buckets[3]))
            for start in range(0, pending.size, rows):
                part = pending[start : start + rows]
                chosen, ok = self._search(buckets, size, qx[part], qy[part], k)
                found[part[ok]] = chosen[ok]
                settled[start : start + rows] = ok
            unsettled[pending[settled]] = False
            size *= 2
        return found

    def _buckets(
        self, size: float
    ) -> tuple[NDArray[np.int64], NDArray[np.intp], NDArray[np.int64], int, int, int] | None:
        """Sorted cell keys of the points and where each cell's points start in
        ``order``, the order, the most points in a cell, the grid's columns and rows."""
        column = np.floor((self.px - self.origin[0]) / size).astype(np.int64)
        row = np.floor((self.py - self.origin[1]) / size).astype(np.int64)
        columns, rows = int(column.max()) + 1, int(row.max()) + 1
        if columns <= 2 and rows <= 2:
            return None
        keys = column * rows + row
        order = np.argsort(keys, kind="stable")
        cells, starts, counts = np.unique(keys[order], return_index=True, return_counts=True)
        return cells, order, np.column_stack((starts, counts)), int(counts.max()), columns, rows

    def _search(
        self,
        buckets: tuple[NDArray[np.int64], NDArray[np.intp], NDArray[np.int64], int, int, int],
        size: float,
        qx: FloatArray,
        qy: FloatArray,
        k: int,
    ) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        """The k nearest candidates of each position in its 3 x 3 cells, and
        whether they are its k nearest of all."""
        cells, order, spans, most, columns, rows = buckets
        # Cell of each position, clipped: a position far outside is never settled here.
        u = (qx - self.origin[0]) / size
        v = (qy - self.origin[1]) / size
        column = np.clip(np.floor(u), -2, columns + 1).astype(np.int64)
        row = np.clip(np.floor(v), -2, rows + 1).astype(np.int64)
        shift = np.arange(-1, 2)
        near_column = (column[:, None] + shift)[:, :, None]  # (n, 3, 1)
        near_row = (row[:, None] + shift)[:, None, :]  # (n, 1, 3)
        inside = (near_column >= 0) & (near_column < columns) & (near_row >= 0) & (near_row < rows)
        keys = (near_column * rows + near_row).reshape(qx.size, 9)
        at = np.minimum(np.searchsorted(cells, keys), cells.size - 1)
        held = inside.reshape(qx.size, 9) & (cells[at] == keys)
        slot = np.arange(most)
        taken = held[:, :, None] & (slot < spans[at, 1][:, :, None])  # (n, 9, most)
        where = np.minimum(spans[at, 0][:, :, None] + slot, order.size - 1)
        candidate = order[where].reshape(qx.size, -1)
        taken = taken.reshape(qx.size, -1)
        squared = np.where(
            taken,
            (self.px[candidate] - qx[:, None]) ** 2 + (self.py[candidate] - qy[:, None]) ** 2,
            np.inf,
        )
        best = np.argpartition(squared, k - 1, axis=1)[:, :k]
        chosen = np.take_along_axis(candidate, best, axis=1)
        kth = np.take_along_axis(squared, best, axis=1).max(axis=1)
        # Distance to the edge of the 3 x 3 cells: every point outside is farther.
        edge = (
            np.minimum.reduce((u - (column - 1), column + 2 - u, v - (row - 1), row + 2 - v)) * size
        )
        whole = (column <= 1) & (column >= columns - 2) & (row <= 1) & (row >= rows - 2)
        ok = np.isfinite(kth) & ((kth <= np.maximum(edge, 0.0) ** 2) | whole)
        return chosen, ok

    def _every_point(self, qx: FloatArray, qy: FloatArray, k: int) -> NDArray[np.intp]:
        found = np.empty((qx.size, k), dtype=np.intp)
        rows = max(1, _CANDIDATES // self.px.size)
        for start in range(0, qx.size, rows):
            part = slice(start, start + rows)
            squared = (self.px - qx[part, None]) ** 2 + (self.py - qy[part, None]) ** 2
            found[part] = np.argpartition(squared, k - 1, axis=1)[:, :k]
        return found


def _distance_to_segments(
    px: FloatArray, py: FloatArray, segments: NDArray[np.intp], qx: FloatArray, qy: FloatArray
) -> FloatArray:
    """Distance of each point (qx[i], qy[i]) from the nearest of its segments (row i)."""
    ax, ay = px[segments], py[segments]
    sx, sy = px[segments + 1] - ax, py[segments + 1] - ay
    length2 = sx**2 + sy**2
    qx, qy = qx[:, None], qy[:, None]
    along = ((qx - ax) * sx + (qy - ay) * sy) / np.where(length2 > 0, length2, 1.0)
    along = np.clip(along, 0.0, 1.0)
    found: FloatArray = np.hypot(qx - ax - along * sx, qy - ay - along * sy).min(axis=1)
    return found


def at_limit_fraction(values: FloatArray, limit: float) -> float | None:
    """Fraction of the samples with |value| at ``limit``; None without samples."""
    if values.size == 0:
        return None
    if not math.isfinite(limit):
        return 0.0
    return float(np.count_nonzero(np.abs(values) >= limit * (1.0 - AT_LIMIT_TOLERANCE))) / float(
        values.size
    )


def jitter(values: FloatArray, counted: np.ndarray) -> float | None:
    """RMS of ``values`` about their centred moving mean of JITTER_WINDOW samples,
    over the ``counted`` samples whose whole window lies in ``values``."""
    half = JITTER_WINDOW // 2
    if values.size < JITTER_WINDOW:
        return None
    # Summed in order, not by np.convolve: its products are BLAS's, whose
    # kernels, chosen by the CPU, round differently (docs/reliability.md).
    windows = values.size - JITTER_WINDOW + 1
    total = np.zeros(windows)
    for offset in range(JITTER_WINDOW):
        total += values[offset : offset + windows]
    mean = total / JITTER_WINDOW
    deviation = values[half : values.size - half] - mean
    return _rms_or_none(deviation[counted[half : values.size - half]])


def sign_reversals(values: FloatArray) -> int:
    """How often the sign of ``values`` flips (zeros and non-finite values skipped)."""
    signs = np.sign(values[np.isfinite(values) & (values != 0.0)])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def phase_segments(phase: np.ndarray) -> list[tuple[int, int, int]]:
    """(phase index, first sample, one past the last sample) of each stretch, in run order."""
    if phase.size == 0:
        return []
    starts = [0, *(np.flatnonzero(phase[1:] != phase[:-1]) + 1).tolist()]
    ends = [*starts[1:], phase.size]
    return list(zip(phase[starts].tolist(), starts, ends, strict=True))


def _phase_target(
    result: RunResult, info: PhaseRecord, start: int, end: int
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


OffPath = Callable[[FloatArray, FloatArray, FloatArray, FloatArray], FloatArray]


class _PhaseSamples:
    """A phase's stretch of the run, and the samples its quality metrics count
    (those after its settle time). What only some metrics read is computed on
    first use."""

    def __init__(
        self, result: RunResult, start: int, end: int, settle_time: float, off_path_of: OffPath
    ) -> None:
        self.result = result
        self.window = slice(start, end)
        self.start_time = float(result.t[start])
        self.settle_time = settle_time
        self.settled = (result.t[self.window] - self.start_time) >= settle_time - 1e-9 * result.dt
        self.v, self.omega = result.v[self.window], result.omega[self.window]
        self._off_path_of = off_path_of

    @cached_property
    def off_path(self) -> FloatArray:
        """Distance of each sample from the path (of a track phase)."""
        r, window = self.result, self.window
        return self._off_path_of(r.x[window], r.y[window], r.x_ref[window], r.y_ref[window])

    @cached_property
    def errors(self) -> dict[str, FloatArray]:
        return estimation_errors(self.result, self.window)


# How each per-phase `expect` metric (PHASE_EXPECTATION_PATHS) is measured.
_PHASE_METRICS: dict[str, Callable[[_PhaseSamples], Any]] = {
    "tracking_error_rms": lambda p: _rms_or_none(p.off_path[p.settled]),
    "tracking_error_max": lambda p: _max_or_none(p.off_path[p.settled]),
    "speed_at_limit": lambda p: at_limit_fraction(p.v[p.settled], p.result.limits[0]),
    "turn_rate_at_limit": lambda p: at_limit_fraction(p.omega[p.settled], p.result.limits[1]),
    "turn_rate_jitter": lambda p: jitter(p.omega, p.settled),
    "turn_rate_reversals": lambda p: sign_reversals(p.omega[p.settled]),
    "estimation_rms": lambda p: {s: _rms_or_none(e[p.settled]) for s, e in p.errors.items()},
}


def _measured(phase: _PhaseSamples, metrics: list[str]) -> dict[str, dict[str, Any]]:
    """The values of per-phase ``metrics``, placed as in a phase's summary."""
    values: dict[str, dict[str, Any]] = {}
    for metric in metrics:
        section, key = PHASE_EXPECTATION_PATHS[metric]
        values.setdefault(section, {})[key] = _PHASE_METRICS[metric](phase)
    return values


def _checked_phase_summary(
    info: PhaseRecord, phase: _PhaseSamples, thresholds: Mapping[str, Any]
) -> dict[str, Any]:
    """What :func:`check_expectations` reads of a phase's summary: the value of
    each threshold set that applies to the phase, as :func:`_phase_summary` has it."""
    summary = {
        "name": info.name,
        "kind": info.kind,
        "settled_samples": int(np.count_nonzero(phase.settled)),
    }
    checked = [
        metric
        for metric in PHASE_EXPECTATION_PATHS
        if thresholds.get(metric) is not None and _applies(summary, metric)
    ]
    return summary | _measured(phase, checked)


def _phase_summary(
    result: RunResult, info: PhaseRecord, phase: _PhaseSamples, tolerance: Mapping[str, float]
) -> dict[str, Any]:
    """A phase's summary in ``summary.json``."""
    t = result.t
    window, settled, start_time = phase.window, phase.settled, phase.start_time
    # A phase lasts until the next one begins (or the run ends).
    end_sample = window.stop if window.stop < result.samples else result.samples - 1
    track = info.kind == "track"
    quality = _measured(
        phase, [m for m in PHASE_EXPECTATION_PATHS if track or not m.startswith("tracking_error")]
    )
    tracking = None
    if track:
        x, y = result.x[window], result.y[window]
        x_ref, y_ref = result.x_ref[window], result.y_ref[window]
        tracking = quality["tracking_error"] | {
            "rms_from_start": _rms_or_none(phase.off_path),
            "max_from_start": _max_or_none(phase.off_path),
            # distance from the reference point of the same sample: lag included
            "reference_rms": _rms_or_none(np.hypot(x - x_ref, y - y_ref)[settled]),
        }

    target_error = None
    if not track and info.target is not None:
        position, heading = _pose_error(result, end_sample, info.target)
        target_error = {"position": position, "heading": heading}

    constraint = result.constraint[window]
    converged = convergence_index(phase.errors, tolerance)
    iterations = result.phase2_iterations[window]
    return {
        "name": info.name,
        "kind": info.kind,
        "start": start_time,
        "end": float(t[end_sample]),
        "duration": round(float(t[end_sample]) - start_time, 9),  # no 20.000000000000004
        "settle_time": phase.settle_time,
        "settled_samples": int(np.count_nonzero(settled)),
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
            "rms": quality["estimation"]["rms"],
            "max_abs_error": {s: _max_or_none(np.abs(e)) for s, e in phase.errors.items()},
            "overshoot": {s: overshoot(e, tolerance[s]) for s, e in phase.errors.items()},
            # seconds after the phase start
            "convergence_time": (
                None if converged is None else float(t[window.start + converged]) - start_time
            ),
        },
        "inputs": quality["inputs"],
        "max_abs_v": _max_or_none(np.abs(phase.v)),
        "max_abs_omega": _max_or_none(np.abs(phase.omega)),
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


def _expect_of(mission: Mapping[str, Any] | None) -> Mapping[str, Any]:
    expect = (mission or {}).get("expect")
    return expect if isinstance(expect, Mapping) else {}


def phase_expectations(mission: Mapping[str, Any] | None) -> dict[str, dict[str, Any]]:
    """Per phase name, the phase's `expect` thresholds in force: the mission's
    per-phase keys, overridden by each key the phase sets itself.

    ``mission`` is the resolved mission (``Mission.model_dump(mode="json")``).
    """
    expect = _expect_of(mission)
    shared = {key: expect.get(key) for key in ("settle_time", *PHASE_EXPECTATION_PATHS)}
    merged = {}
    for phase in _written_phases(mission):
        own = phase.get("expect") or {}
        merged[str(phase.get("name"))] = {
            key: own[key] if own.get(key) is not None else value for key, value in shared.items()
        }
    return merged


def _written_phases(mission: Mapping[str, Any] | None) -> list[Mapping[str, Any]]:
    """The mission's phases as written, those of each repeat group in its place."""
    phases: list[Mapping[str, Any]] = []
    for step in (mission or {}).get("phases") or []:
        repeat = step.get("repeat")
        phases.extend((repeat.get("phases") or []) if isinstance(repeat, Mapping) else [step])
    return phases


def _written_name(name: str) -> str:
    """A phase's name as written: a repeated phase runs as ``name#lap``."""
    return name.split("#", 1)[0]


def _tolerance(mission: Mapping[str, Any] | None) -> dict[str, float]:
    """Convergence tolerance per state: the mission's, else the default."""
    return {
        **DEFAULT_CONVERGENCE_TOLERANCE,
        **(_expect_of(mission).get("convergence_tolerance") or {}),
    }


def _settle_time(phase_expect: Mapping[str, Any] | None) -> float:
    value = (phase_expect or {}).get("settle_time")
    return models.DEFAULT_SETTLE_TIME if value is None else float(value)


def summarize(result: RunResult, mission: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """All metrics of a run, in a fixed key order (the content of ``summary.json``).

    ``mission`` (the resolved mission) sets how metrics are measured: each
    phase's settle time and the convergence tolerance per state.
    """
    summary = run_metrics(result, mission)
    summary["phases"] = _phase_summaries(result, mission, distance_to_path)
    summary["compute_us_per_sample"] = compute_time_us(result.compute_ns)
    summary["loop_us_per_sample"] = loop_time_us(result)
    return summary


def _phase_summaries(
    result: RunResult,
    mission: Mapping[str, Any] | None,
    off_path: OffPath,
    checked_only: bool = False,
) -> list[dict[str, Any]]:
    """Each phase's summary (see :func:`_phase_summary`), its tracking error
    measured by ``off_path``; ``checked_only``: only what its `expect`
    thresholds read (:func:`_checked_phase_summary`), for a verdict at a
    fraction of the cost."""
    tolerance = _tolerance(mission)
    per_phase = phase_expectations(mission)
    summaries = []
    for index, start, end in phase_segments(result.phase):
        info = result.phases[index]
        expect = per_phase.get(_written_name(info.name), _expect_of(mission))
        phase = _PhaseSamples(result, start, end, _settle_time(expect), off_path)
        if checked_only:
            summaries.append(_checked_phase_summary(info, phase, expect))
        else:
            summaries.append(_phase_summary(result, info, phase, tolerance))
    return summaries


def run_metrics(result: RunResult, mission: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The mission-wide metrics of :func:`summarize` (its keys before ``phases``),
    without the per-phase ones."""
    tolerance = _tolerance(mission)
    errors = estimation_errors(result)
    summary = _bounded_metrics(result, tolerance, errors)
    settled = (
        result.t - (result.t[0] if result.samples else 0.0)
        >= _settle_time(_expect_of(mission)) - 1e-9 * result.dt
    )
    summary |= {
        "convergence_tolerance": tolerance,
        "estimation_overshoot": {
            state: overshoot(error, tolerance[state]) for state, error in errors.items()
        },
        # after the mission's settle time from its start
        "estimation_rms": {state: _rms_or_none(error[settled]) for state, error in errors.items()},
    }
    # last in summary.json, whose key order is fixed
    summary["max_constraint_violation"] = summary.pop("max_constraint_violation")
    return summary


def _bounded_metrics(
    result: RunResult, tolerance: Mapping[str, float], errors: dict[str, FloatArray]
) -> dict[str, Any]:
    """The run's outcome and the mission-wide metrics an `expect` can bound
    (EXPECTATION_PATHS), as :func:`run_metrics` has them."""
    converged = convergence_index(errors, tolerance)
    duration = round(float(result.t[-1] - result.t[0]), 9) if result.samples else 0.0
    return {
        "outcome": result.outcome.value,
        "message": result.message,
        "mission": result.mission_name,
        "seed": result.seed,
        "samples": result.samples,
        "duration": duration,
        "final": _final(result, phase_segments(result.phase)),
        "estimation_convergence_time": None if converged is None else float(result.t[converged]),
        "max_constraint_violation": _violation(result.constraint),
        # A real-time run's pace and command latency (wmr_mission.backends); absent in
        # our simulator, whose summary keeps its bytes.
        **({} if result.realtime is None else {"realtime": copy.deepcopy(result.realtime)}),
    }


def loop_time_us(result: RunResult) -> float | None:
    """Wall time of the whole simulation loop per sample [us] (None when not timed)."""
    if result.loop_ns <= 0 or result.samples == 0:
        return None
    return result.loop_ns / 1000.0 / result.samples


def summary_value(summary: Mapping[str, Any], path: tuple[str, ...]) -> float | None:
    value: Any = summary
    for key in path:
        if not isinstance(value, Mapping):
            return None
        value = value.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def _check(metric: str, phase: str | None, limit: float, value: float | None) -> dict[str, Any]:
    return {
        "metric": metric,
        "phase": phase,
        "max": limit,
        "value": value,
        "met": value is not None and value <= limit,
    }


def _applies(phase: Mapping[str, Any], metric: str) -> bool:
    """A phase-quality threshold needs samples after the settle time; the
    tracking ones need a track phase."""
    if not phase.get("settled_samples"):
        return False
    return not metric.startswith("tracking_error") or phase.get("kind") == "track"


def _phase_checks(phase: Mapping[str, Any], thresholds: Mapping[str, Any]) -> list[dict[str, Any]]:
    checks = []
    name = str(phase.get("name"))
    for metric, path in PHASE_EXPECTATION_PATHS.items():
        threshold = thresholds.get(metric)
        if threshold is None or not _applies(phase, metric):
            continue
        if metric == "estimation_rms":  # a bound per state
            for state in STATES:
                if threshold.get(state) is not None:
                    value = summary_value(phase, (*path, state))
                    checks.append(_check(f"{metric}.{state}", name, threshold[state], value))
            continue
        checks.append(_check(metric, name, float(threshold["max"]), summary_value(phase, path)))
    return checks


def check_expectations(
    summary: Mapping[str, Any], mission: Mapping[str, Any] | None
) -> list[dict[str, Any]]:
    """Each `expect` threshold in force with the run's value: the mission-wide
    ones (``phase`` null), then each phase's (``phase`` its name), in run order.

    A missing (null) value never meets a threshold: a non-finite metric after
    a divergence fails. A phase-quality threshold is not checked where it does
    not apply (a phase no longer than its settle time; tracking off a track phase).
    """
    expect = _expect_of(mission)
    known = (*EXPECTATION_PATHS, *PHASE_EXPECTATION_PATHS, *_SETTINGS)
    for metric in expect:
        if metric not in known:
            raise ValueError(f"unknown expectation {metric!r}; expected one of {', '.join(known)}")
    checks = [
        _check(metric, None, float(expect[metric]["max"]), summary_value(summary, path))
        for metric, path in EXPECTATION_PATHS.items()
        if expect.get(metric) is not None
        and (metric not in REALTIME_EXPECTATIONS or "realtime" in summary)
    ]
    per_phase = phase_expectations(mission)
    for phase in summary.get("phases") or []:
        thresholds = per_phase.get(_written_name(str(phase.get("name"))), expect)
        checks.extend(_phase_checks(phase, thresholds))
    return checks


def unmet(checks: list[dict[str, Any]]) -> list[str]:
    """Each unmet check in words: ``orbit: turn_rate_at_limit = 0.974 (max 0.01)``."""
    lines = []
    for item in checks:
        if item["met"]:
            continue
        value = "none" if item["value"] is None else f"{item['value']:.6g}"
        where = f"{item['phase']}: " if item["phase"] is not None else ""
        lines.append(f"{where}{item['metric']} = {value} (max {item['max']:.6g})")
    return lines


def judge(result: RunResult, mission: Mapping[str, Any] | None) -> dict[str, Any]:
    """The run's summary with every `expect` threshold checked.

    A run that ended as a success but misses a threshold is not one: its
    outcome becomes ``expect-failed`` (in ``result`` too), with the misses as
    its message. Thresholds are what a mission relaxes, not the outcome.
    """
    summary = summarize(result, mission)
    checks = check_expectations(summary, mission)
    _judged(result, summary, checks)
    summary["expectations"] = checks
    if mission is not None and mission is result.mission:  # summary.json reuses it
        result.judged = summary
    return summary


def judge_run_metrics(result: RunResult, mission: Mapping[str, Any] | None) -> dict[str, Any]:
    """The keys of :func:`run_metrics` a campaign's row records (the outcome and
    the metrics an `expect` bounds mission-wide), with the run judged as
    :func:`judge` judges it (the same outcome and message, in ``result`` too),
    at a fraction of the cost.

    A tracking-error threshold is checked first against the distance to each
    sample's own reference point: that point ends a segment
    :func:`distance_to_path` tries, so the distance to the path is never above
    it, and a phase within its threshold by it is within it. Only when that
    bound misses a threshold is the distance to the path computed.
    """
    summary = _bounded_metrics(result, _tolerance(mission), estimation_errors(result))
    if not result.succeeded:  # judging changes only a success
        return summary
    phases = _phase_summaries(result, mission, _off_path_bound, checked_only=True)
    checks = check_expectations({**summary, "phases": phases}, mission)
    if any(not c["met"] and c["metric"].startswith("tracking_error") for c in checks):
        checks = check_expectations(summarize(result, mission), mission)
    _judged(result, summary, checks)
    return summary


def _off_path_bound(
    x: FloatArray, y: FloatArray, x_ref: FloatArray, y_ref: FloatArray
) -> FloatArray:
    """At least :func:`distance_to_path` at every sample: the distance to the
    sample's own reference point, a relative 1e-9 and 1e-12 m above it for
    rounding (or the distance to the path itself where a reference point is
    missing, or the squares overflow)."""
    dx, dy = x - x_ref, y - y_ref
    own: FloatArray = np.sqrt(dx * dx + dy * dy) * (1.0 + 1e-9) + 1e-12  # hypot at half the cost
    return own if np.isfinite(own).all() else distance_to_path(x, y, x_ref, y_ref)


def _judged(result: RunResult, summary: dict[str, Any], checks: list[dict[str, Any]]) -> None:
    """A success that misses a threshold becomes ``expect-failed``, in
    ``result`` and ``summary``, with the misses as its message."""
    failures = unmet(checks)
    if result.succeeded and failures:
        result.miss_expectations(failures)
        summary["outcome"], summary["message"] = result.outcome.value, result.message
