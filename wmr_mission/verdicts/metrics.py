"""Metrics of a run (``summary.json``) and the mission's ``expect`` thresholds.

The estimation error of a state is true minus estimate (``x - x_est``), the
sign of the output error ``xi - xi_hat`` bounded by eq. (4); heading errors are
wrapped to [-pi, pi). Values that do not exist (no track phase, no constraint,
never converged) are ``None`` and become ``null`` in JSON; so does anything
non-finite, e.g. after a divergence.

Everything here is computed from the recorded arrays of a :class:`RunRecord`
after the run. A track phase is judged against its timed reference
(wmr_mission.verdicts.tracking), the inputs by their quality
(wmr_mission.verdicts.inputs), the zones by the true position
(wmr_mission.verdicts.zones); `tracking_error_*`, `*_at_limit` and the
estimation RMS leave out a phase's first ``settle_time`` seconds.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import STATES, FloatArray, cached_value
from wmr_mission.kernels import jit
from wmr_mission.spec import catalog, models
from wmr_mission.spec.catalog import Metric
from wmr_mission.spec.located import written_phases
from wmr_mission.spec.numbers import MissionNumbers, mission_numbers
from wmr_mission.verdicts import inputs as input_metrics
from wmr_mission.verdicts import temporal
from wmr_mission.verdicts.advice import advice
from wmr_mission.verdicts.check import Check, margin_fields
from wmr_mission.verdicts.clearance import clearance_min
from wmr_mission.verdicts.nearest import NearestPoints
from wmr_mission.verdicts.passes import (
    PARTIALS,
    estimation_error_pass,
    finite_squares_sum,
    largest_finite,
    last_unconverged,
    poses_finite,
    reference_distances,
    settled_count,
)
from wmr_mission.verdicts.path_distance import compiled_distances, first_in_cells
from wmr_mission.verdicts.regulation import regulated
from wmr_mission.verdicts.tracking import (
    Known,
    Placement,
    known_samples,
    placed_known,
    reference_known,
    track_samples,
)
from wmr_mission.verdicts.zones import Bounds, intrusion_max, zones_of

if TYPE_CHECKING:
    from wmr_mission.record import PhaseRecord, RunRecord

# The mission's `expect` settings when a summary is made without a mission.
DEFAULT_CONVERGENCE_TOLERANCE = dict.fromkeys(STATES, models.DEFAULT_CONVERGENCE_TOLERANCE)
# A constraint row above this counts as violated: a constraint held as an
# equality by the corrective action sits on 0 to rounding.
VIOLATION_TOLERANCE = 1e-6
# An input within this fraction of its limit counts as at the limit (the
# runner clips to the limit exactly; this only absorbs rounding).
AT_LIMIT_TOLERANCE = 1e-9
# Distance to the path: the segments within this many reference points of a
# sample's own, and those next to this many of the path's nearest points, are tried.
LOCAL_WINDOW = 8
_NEAREST_POINTS = 4
_DISTANCE_CHUNK = 4096  # positions per block: bounded memory on long runs

# An `auto` turn-rate jitter allows this share of the turn-rate limit besides
# what the heading noise explains.
JITTER_FLOOR = 0.01
# `expect` keys that set how metrics are measured, not thresholds.
_SETTINGS = ("settle_time", "convergence_tolerance")
# The run's metrics that only a real-time run has: not checked in a simulation.
_REALTIME = "realtime"
# The robot's sampling period and limits where a mission leaves them out.
_DEFAULT_DT = models.Robot.model_fields["dt"].default
_DEFAULT_V = models.Limits.model_fields["v"].default
_DEFAULT_OMEGA = models.Limits.model_fields["omega"].default


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


_EVERY = np.zeros(0, dtype=bool)


def _largest(
    values: FloatArray,
    chosen: NDArray[np.bool_] | slice = _EVERY,
    factor: float = 1.0,
    divisor: float = 1.0,
    magnitude: bool = False,
) -> float | None:
    """:func:`_max_or_none` of ``factor * values[chosen] / divisor`` (of
    ``|values|`` with ``magnitude``; every value where ``chosen`` is empty),
    for values that are never -0 or whose zero is read as +0: compiled, one
    pass with no copy (verdicts/passes.py), where the kernels are loaded."""
    if isinstance(chosen, slice):  # a view: the same values in the same order
        values, chosen = values[chosen], _EVERY
    if jit.judging_compiled():
        found = jit.compiled(largest_finite)(values, chosen, factor, divisor, magnitude)
        return None if math.isnan(found) else float(found)
    values = values if chosen.size == 0 else values[chosen]
    values = np.abs(values) if magnitude else values
    if factor != 1.0 or divisor != 1.0:
        values = factor * values / divisor
    return _max_or_none(values)


def _violation(values: FloatArray, starts: list[int] | None = None) -> float | None:
    """How far the largest constraint-row value is above 0 (0 when never) over
    the states a phase's own inputs produced; None when no constraint applied.
    ``starts``: the first sample of each phase's stretch (None: one phase's samples).

    A phase's first sample is the state it was entered in, which the phase
    before it (or the mission's initial state) produced: no input of the phase
    has acted on it yet (docs/paper-notes.md, eq. (33))."""
    counted = np.isfinite(values)  # a mask, not a copy of the column
    if starts is None:  # one phase's samples
        counted[:1] = False
    else:
        counted[starts] = False
    values = values[counted]
    return max(0.0, float(values.max())) if values.size else None


def _suffix(mask: NDArray[np.bool_], count: int | None = None) -> slice | NDArray[np.bool_]:
    """The samples ``mask`` picks: a slice where they are its last ones (the
    samples after a settle time, time never going back), whose columns are
    views, not copies of a long run's; else ``mask``. ``count``: how many it
    picks, if known."""
    count = int(np.count_nonzero(mask)) if count is None else count
    return slice(mask.size - count, mask.size) if mask[mask.size - count :].all() else mask


def _rms_or_none(values: FloatArray) -> float | None:
    if values.size == 0:
        return None
    mean = np.mean(values**2)
    if math.isfinite(mean):  # every value finite: the mean of them all
        return float(np.sqrt(mean))
    finite = np.isfinite(values)
    values = values if finite.all() else values[finite]  # a copy only where one is missing
    return float(np.sqrt(np.mean(values**2))) if values.size else None


def reference_distance(
    x: FloatArray, y: FloatArray, x_ref: FloatArray, y_ref: FloatArray
) -> FloatArray:
    """[m] Distance of each position from the reference point of the same
    sample (the time-indexed one: lag included), not from the path. IEEE
    operations alone (no library hypot): the same bits on every CPU
    (docs/reliability.md); one compiled pass where the judge's passes run compiled."""
    if jit.judging_compiled():
        found = np.empty(x.size)
        jit.compiled(reference_distances)((x, y), (x_ref, y_ref), found)
        return found
    dx, dy = x - x_ref, y - y_ref
    distance: FloatArray = np.sqrt(dx * dx + dy * dy)
    return distance


def reference_error(distance: FloatArray) -> float | None:
    """``reference_error_rms`` [m] of the distances to the reference point
    counted, the finite ones (an exact sum: no pairwise one); None without any.
    Compiled, one pass: the same float (verdicts/passes.py)."""
    if jit.judging_compiled():
        total, count = jit.compiled(finite_squares_sum)(distance, np.empty(PARTIALS))
        if count == 0:
            return None
        if not math.isnan(total):  # else math.fsum decides, as below
            return math.sqrt(total / count)
    distance = distance[np.isfinite(distance)]
    if distance.size == 0:
        return None
    return math.sqrt(math.fsum(distance * distance) / distance.size)


_WHOLE = slice(None)


def estimation_errors(result: RunRecord, window: slice = _WHOLE) -> dict[str, FloatArray]:
    """True minus estimated state per sample (of ``window``), heading wrapped;
    one compiled pass where the judge's passes run compiled (the same bits)."""
    r, w = result, window
    if jit.judging_compiled():
        true, estimate = (r.x, r.y, r.theta), (r.x_est, r.y_est, r.theta_est)
        if w != _WHOLE:  # the whole run's columns as they are
            true = (r.x[w], r.y[w], r.theta[w])
            estimate = (r.x_est[w], r.y_est[w], r.theta_est[w])
        x, y, theta = np.empty((3, true[0].size))  # one block: a row a state
        jit.compiled(estimation_error_pass)(true, estimate, (x, y, theta))
        return {"x": x, "y": y, "theta": theta}
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
    if jit.judging_compiled() and tuple(errors) == STATES:  # one compiled pass, from the end
        size = errors["x"].size
        bounds = (float(tolerance["x"]), float(tolerance["y"]), float(tolerance["theta"]))
        columns = (errors["x"], errors["y"], errors["theta"])
        last = jit.compiled(last_unconverged)(columns, bounds) if size else 0
        return None if size == 0 or last + 1 == size else last + 1
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
    crossed = _largest(error, factor=float(-np.sign(error[0])), divisor=scale)
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
    known = np.isfinite(x_ref) & np.isfinite(y_ref)
    finite = np.isfinite(x) & np.isfinite(y)
    # Copies only where something is missing: a long run's columns are large.
    every_finite = bool(finite.all())
    these = known_samples(known)  # a slice (views) where they run unbroken
    px, py = x_ref[these], y_ref[these]
    if px.size == 0 or not finite.any():
        return np.full(x.shape, np.nan)
    qx, qy = (x, y) if every_finite else (x[finite], y[finite])
    if px.size == 1:
        return _where_finite(finite, np.hypot(qx - px[0], qy - py[0]))
    # each sample's reference point: the last known at or before it (else the first)
    if isinstance(these, slice):  # counted from its start, held at the first and the last
        own = np.arange(-these.start, x.size - these.start)
        own[: these.start] = 0
        own[these.start + px.size :] = px.size - 1
    else:
        own = np.maximum(np.cumsum(known) - 1, 0)
    own = own if every_finite else own[finite]
    steps = np.diff(px)
    steps = np.hypot(steps, np.diff(py), out=steps)  # (a long run's columns: no more than needed)
    positive = steps > 0
    moving = steps if positive.all() else steps[positive]  # reordered by the median: not read after
    cell = float(np.median(moving, overwrite_input=True)) / 2 if moving.size else 1.0
    # One point per cell: the first the path passes in it (a stable sort by cell).
    first = first_in_cells(px, py, cell) if jit.judging_compiled() else None  # the same, compiled
    if first is None:
        column, row = np.floor(px / cell), np.floor(py / cell)
        order = np.lexsort((row, column))
        column, row = column[order], row[order]
        first = order[np.r_[True, (column[1:] != column[:-1]) | (row[1:] != row[:-1])]]
    if jit.distances_compiled():  # the same bits in one compiled pass (verdicts/path_distance.py)
        found = compiled_distances(px, py, qx, qy, own, first, cell, LOCAL_WINDOW, _NEAREST_POINTS)
        return found if every_finite else _where_finite(finite, found)
    grid = NearestPoints(px[first], py[first], cell, qx.size)
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
    return found if every_finite else _where_finite(finite, found)


def _where_finite(finite: NDArray[np.bool_], found: FloatArray) -> FloatArray:
    """``found`` at the ``finite`` samples, NaN at the others."""
    distance = np.full(finite.shape, np.nan)
    distance[finite] = found
    return distance


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
    least = limit * (1.0 - AT_LIMIT_TOLERANCE)
    if least > 0.0:  # |value| >= least on either side, no column of magnitudes made
        at = np.count_nonzero(values >= least) + np.count_nonzero(values <= -least)
    else:  # (a zero would count on both sides)
        at = np.count_nonzero(np.abs(values) >= least)
    return float(at) / float(values.size)


class Entry(NamedTuple):
    """One entry into a phase: its stretch of the run and what ended it."""

    phase: int  # the phase's number in the run's phases
    start: int  # its first sample
    end: int  # one past its last sample (start: none)
    # the condition of the transition that ended it ("elapsed", "timeout",
    # "interrupted", ...); None where the record says none did
    ended_by: str | None


def phase_segments(result: RunRecord) -> list[Entry]:
    """Each entry into a phase, in run order, as the run's transitions record
    them: its first phase's at sample 0, then each phase a transition entered
    (an update enters none), each ended by the transition after its start. A
    phase entered again (a retry, a goto, a resumption) has a stretch per
    entry, judged by how that entry ended, and a phase whose `until` already
    held when it was entered one without samples (start == end: the next
    phase's first sample is the same). An entry after the last sample
    recorded (a run stopped there) has none."""
    t = result.t
    n = t.shape[0]
    if n == 0:
        return []
    number = {info.name: i for i, info in enumerate(result.phases)}
    moves = [tr for tr in result.transitions if tr.condition != "update"]
    half = 0.5 * result.dt
    starts = [(0, 0)]
    for tr in moves:
        if tr.to_phase is not None:
            # the array's own method: numpy's function dispatches first (about 1 us)
            k = int(t.searchsorted(tr.time - half))
            if k < n:
                starts.append((number[str(tr.to_phase)], k))
    ends = [k for _, k in starts[1:]]
    ends.append(n)
    return [  # the j-th move ends the j-th entry: the first phase's, and so on
        Entry(i, k, end, moves[j].condition if j < len(moves) else None)
        for j, ((i, k), end) in enumerate(zip(starts, ends, strict=True))
    ]


def _phase_target(
    result: RunRecord, info: PhaseRecord, start: int, end: int
) -> tuple[tuple[float, float, float | None], int | None] | None:
    """The pose a phase aims at: its target, or for a track phase its last reference
    point and that point's sample (None: a target, for all time)."""
    if info.kind == "track":
        known = np.flatnonzero(
            np.isfinite(result.x_ref[start:end]) & np.isfinite(result.y_ref[start:end])
        )
        if known.size == 0:
            return None
        k = start + int(known[-1])
        return (float(result.x_ref[k]), float(result.y_ref[k]), None), k
    if info.target is None:
        return None
    return info.target, None


def _pose_error(
    result: RunRecord, k: int, target: tuple[float, float, float | None]
) -> tuple[float | None, float | None]:
    position = math.hypot(float(result.x[k]) - target[0], float(result.y[k]) - target[1])
    heading = None
    if target[2] is not None:
        # wrap_angle of one float: Python's % is numpy's (fmod, then the divisor's sign)
        error = float(result.theta[k]) - target[2]
        heading = _finite_or_none(abs((error + math.pi) % (2.0 * math.pi) - math.pi))
    return _finite_or_none(position), heading


def _final(result: RunRecord, stretches: list[tuple[PhaseRecord, int, int]]) -> dict[str, Any]:
    """Final error of the true pose from the aim of the last phase that has one.

    The aim is a regulate target, or a track phase's last reference point (no
    heading then; where the phase ends the run, the robot is measured at that
    point's sample, the run's last but one); phases are searched from the last
    one run backwards. A hold phase keeps the pose it started from, so it has
    no aim of its own: the error of a mission ending "park, then hold" is
    measured from the park's target.
    """
    final: dict[str, Any] = {
        "position_error": None,
        "heading_error": None,
        "target": None,
        "time": None,  # [s] of the sample measured: the last, or a track's last reference's
        "pose": None,
    }
    if result.samples == 0:
        return final
    last = result.samples - 1
    for info, start, end in reversed(stretches):  # each phase's record, first and end sample
        if info.kind == "hold":
            continue
        aim = _phase_target(result, info, start, end)
        if aim is None:
            continue
        target, sample = aim
        # A track phase that ends the run has no reference point at the run's last
        # sample (it follows the last command): the robot is measured at its last
        # reference point's own sample, not v dt past it.
        at = sample if sample is not None and end == result.samples else last
        final["position_error"], final["heading_error"] = _pose_error(result, at, target)
        final["target"] = {"phase": info.name, "x": target[0], "y": target[1], "theta": target[2]}
        final["time"] = _finite_or_none(result.t[at])
        break
    final["pose"] = {
        "x": _finite_or_none(result.x[last]),
        "y": _finite_or_none(result.y[last]),
        "theta": _finite_or_none(result.theta[last]),
    }
    return final


# The mission a run is judged by: checked (a Mission), or as a run directory
# holds it (its resolved form, ``Mission.model_dump(mode="json")``); None: the
# defaults.
MissionTerms = models.Mission | Mapping[str, Any] | None


def resolved(mission: MissionTerms) -> Mapping[str, Any] | None:
    """The mission's resolved form, what the judge reads (a checked mission's
    every default written out)."""
    if isinstance(mission, models.Mission):
        return mission.model_dump(mode="json")
    return mission


OffPath = Callable[[FloatArray, FloatArray, FloatArray, FloatArray], FloatArray]


class _Judged(NamedTuple):
    """What every phase of a run is judged by: the mission's numbers and the
    first sample from when [s] the estimate first came within its tolerance
    (None: never)."""

    numbers: MissionNumbers
    inputs_from: int | None  # the first sample at or after that time (None: never)
    goals: Mapping[str, tuple[float, float]]  # phase name as written -> position, heading tolerance
    errors: dict[str, FloatArray] | None  # the run's estimation errors, where its judge keeps them
    # the robot's footprint in the mission judged by (None: a point): a campaign's
    # runs carry no mission of their own, and were judged on the axle
    footprint: Mapping[str, Any] | None


class PhaseSamples:
    """A phase's stretch of the run, and the samples its quality metrics count
    (those after its settle time). What only some metrics read is computed on
    first use."""

    def __init__(
        self,
        result: RunRecord,
        info: PhaseRecord,
        entry: Entry,
        settle_time: float,
        off_path_of: OffPath,
        judged: _Judged,
    ) -> None:
        start, end = entry.start, entry.end
        self.result, self.info = result, info
        self.window = window = slice(start, end)
        t = result.t
        self.start_time = start_time = float(t[start])
        self.settle_time = settle_time
        self.v, self.omega = result.v[window], result.omega[window]
        t, least = t[window], settle_time - 1e-9 * result.dt
        # the samples after the settle time: their count, and whether they are the last
        # ones (one compiled pass where the judge's passes run compiled: the same)
        count, last = (
            jit.compiled(settled_count)(t, start_time, least)
            if jit.judging_compiled()
            else (0, False)
        )
        self.settled: slice | NDArray[np.bool_]
        if last:  # a slice: its columns are views
            self.settled_samples, self.settled = count, slice(t.size - count, t.size)
        else:
            settled = (t - self.start_time) >= least
            self.settled_samples = int(np.count_nonzero(settled))
            self.settled = _suffix(settled, self.settled_samples)
        self._off_path_of = off_path_of
        self.numbers = judged.numbers
        self.ended_by = entry.ended_by
        self.goals = judged.goals
        self._run_errors = judged.errors
        self._footprint = judged.footprint
        # the first sample of the phase whose inputs are judged (past the end: none)
        first = judged.inputs_from
        self.first_judged = end if first is None else first if first > start else start

    @cached_value
    def off_path(self) -> FloatArray:
        """Distance of each sample from the path (of a track phase)."""
        r, window = self.result, self.window
        return self._off_path_of(r.x[window], r.y[window], r.x_ref[window], r.y_ref[window])

    @cached_value
    def errors(self) -> dict[str, FloatArray]:
        if self._run_errors is not None:  # the same numbers: a phase's are the run's, sliced
            return {state: error[self.window] for state, error in self._run_errors.items()}
        return estimation_errors(self.result, self.window)

    @cached_value
    def zones(self) -> list[Any]:
        return zones_of(self.info.constraints, self.result.regions)

    @cached_value
    def placement(self) -> Placement | None:
        """The places on the path of the samples whose reference is known, for the
        tracking metrics and the formulas alike (track phases)."""
        if self.info.kind != "track":
            return None
        return self._placed[1]

    @cached_value
    def reference_known(self) -> Known:
        """Whether each sample's reference point is known, and those samples
        (:func:`reference_known`): for the places, the tracking metrics and
        the formulas, once."""
        if self.info.kind == "track":
            return self._placed[0]
        r, w = self.result, self.window
        return reference_known(r.x_ref[w], r.y_ref[w])

    @cached_value
    def _placed(self) -> tuple[Known, Placement | None]:
        """:attr:`reference_known` and :attr:`placement` of a track phase, found
        together (:func:`placed_known`)."""
        r, w = self.result, self.window
        return placed_known(r.x[w], r.y[w], r.x_ref[w], r.y_ref[w])

    @cached_value
    def tracked(self) -> tuple[dict[str, Any], NDArray[np.bool_] | None] | None:
        """Tracking against the timed reference, and per sample whether it is
        judged (None: nothing measured), of a track phase."""
        if self.info.kind != "track":
            return None
        r, w, placement = self.result, self.window, self.placement
        timed = self.ended_by in ("elapsed", "mission_time")
        if placement is None:
            px, py, rx, ry = r.x[w], r.y[w], r.x_ref[w], r.y_ref[w]
        else:  # the places' own columns: the phase's not sliced again
            px, py, rx, ry = placement.px, placement.py, placement.path[1], placement.path[2]
        found, samples = track_samples(
            r.t[w], px, py, rx, ry, self.numbers, self.zones, timed, r.constraint_margin,
            placement, known=self.reference_known,
        )  # fmt: skip
        return found, None if samples is None else samples.judged  # the errors not kept

    @cached_value
    def tracking(self) -> dict[str, Any] | None:
        """Tracking against the timed reference (track phases)."""
        return None if self.tracked is None else self.tracked[0]

    @cached_value
    def inputs(self) -> dict[str, Any]:
        """The input-quality metrics of the judged samples (None where none is)."""
        r, first, stop = self.result, self.first_judged, self.window.stop
        if first >= stop:
            return dict.fromkeys(_INPUT_METRICS)
        judged = slice(first, stop)
        counted = None  # a track phase's jitter: the samples its tracking is judged at
        if self.tracked is not None and self.tracked[1] is not None:
            counted = self.tracked[1][first - self.window.start :]
        cuts: list[int] = []  # where an update's reference took over
        if r.reference is not None:
            reference = r.reference[judged]
            cuts = (np.flatnonzero(reference[1:] != reference[:-1]) + 1).tolist()
        return input_metrics.input_quality(
            r.t[judged], r.v[judged], r.omega[judged], self.numbers, self._progress, counted, cuts
        )

    def _progress(self, a: int, b: int) -> float:
        """[m] the progress from judged sample a to b (:attr:`progress`)."""
        return self.progress(a, b)

    @cached_value
    def progress(self) -> input_metrics.Progress:
        """The progress from a judged sample to another: along the path (a
        track phase), towards the target in force at each sample (a regulate
        phase), none where no aim is known. Made when first asked: only a
        stretch at the speed limit asks, and most phases have none."""
        r, first, stop = self.result, self.first_judged, self.window.stop
        judged = slice(first, stop)
        x, y = r.x[judged], r.y[judged]
        if self.info.kind == "track":
            return input_metrics.progress_along(x, y, r.x_ref[judged], r.y_ref[judged])
        if self.info.target is not None:  # towards the target in force at each sample
            return _towards_targets(self.info, first, stop, x, y)
        return lambda a, b: 0.0  # no aim known: nothing is progress

    @cached_value
    def goal(self) -> tuple[float, float]:
        """Position and heading tolerance of the phase's goal (see :func:`_goals`)."""
        found = self.goals.get(_written_name(self.info.name))
        if found is not None:
            return found
        numbers = self.numbers
        return (
            numbers.tracking_tolerance,
            numbers.convergence_tolerance["theta"] + numbers.heading_noise,
        )

    @cached_value
    def stall_and_overshoot(self) -> tuple[float | None, float | None]:
        """The stall time and the overshoot of a regulate phase (else None),
        found together for each stretch of its samples over which one target
        was in force (the phase's own, then each an update gave: a phase is
        judged against the target in force at each sample, not its last): the
        stall time the sum over them, the overshoot the most, each from where
        its target took over (None where none has a value)."""
        if self.info.kind != "regulate":
            return None, None
        r, w = self.result, self.window
        finite = True if self.pose_finite else None  # else each stretch looked at
        stalls, overshoots = [], []
        for a, b, aim in self.info.targets_in_force(w.start, w.stop):
            found = regulated(
                r.x[a:b], r.y[a:b], r.theta[a:b], aim, self.goal, self.numbers, self.zones, finite
            )
            if found[0] is not None:
                stalls.append(found[0])
            if found[1] is not None:
                overshoots.append(found[1])
        return (sum(stalls) if stalls else None, max(overshoots) if overshoots else None)

    @cached_value
    def stall(self) -> float | None:
        """Time away from its goal without progress (regulate phases)."""
        return self.stall_and_overshoot[0]

    @cached_value
    def overshoot(self) -> float | None:
        """How far past its target the robot went (regulate phases)."""
        return self.stall_and_overshoot[1]

    @cached_value
    def regulation(self) -> dict[str, Any] | None:
        """A regulate phase's progress to its target, with what the `auto` bound reads."""
        if self.info.kind != "regulate":
            return None
        return {
            "stall_time": self.stall,
            "overshoot_max": self.overshoot,
            "goal_position": self.goal[0] if self.info.target is not None else None,
        }

    @cached_value
    def pose_finite(self) -> bool:
        """Whether every pose of the phase is finite (read by its zones and
        regulation metrics, once)."""
        r, w = self.result, self.window
        x, y, theta = r.x[w], r.y[w], r.theta[w]
        if jit.judging_compiled():  # the same in one compiled pass (verdicts/passes.py)
            return bool(jit.compiled(poses_finite)(x, y, theta))
        return bool(np.isfinite(x).all() and np.isfinite(y).all() and np.isfinite(theta).all())

    @cached_value
    def zone_bounds(self) -> list[Bounds | None]:
        """Each zone's :meth:`Zone.bounds` of the phase's positions: computed
        once for the intrusion and the clearance."""
        r, w = self.result, self.window
        return [zone.bounds(r.x[w], r.y[w]) for zone in self.zones]

    @cached_value
    def clearance(self) -> float | None:
        r, w = self.result, self.window
        if not self.zones or w.stop == w.start:
            return None
        return clearance_min(
            r.x[w], r.y[w], r.theta[w], self.zones, self._footprint, self.zone_bounds,
            self.pose_finite,
        )  # fmt: skip

    @cached_value
    def intrusion(self) -> float | None:
        r, w = self.result, self.window
        if not self.zones:
            return None
        return intrusion_max(r.x[w], r.y[w], self.zones, self.numbers, self.zone_bounds)


def _towards_targets(
    info: PhaseRecord, first: int, stop: int, x: FloatArray, y: FloatArray
) -> input_metrics.Progress:
    """:func:`input_metrics.progress_to` the target in force at each sample of
    ``first .. stop - 1`` (``x``, ``y``: their positions)."""
    aim_x, aim_y = np.empty(x.size), np.empty(x.size)
    for start, end, aim in info.targets_in_force(first, stop):
        aim_x[start - first : end - first] = aim[0]
        aim_y[start - first : end - first] = aim[1]
    return input_metrics.progress_to(x, y, (aim_x, aim_y))


_INPUT_METRICS = (
    "speed_jump_max",
    "turn_rate_jump_max",
    "speed_reversals",
    "turn_rate_reversals",
    "speed_fight_time",
    "turn_rate_fight_time",
    "turn_rate_jitter",
)


def _tracking_value(key: str) -> Callable[[PhaseSamples], Any]:
    return lambda p: None if p.tracking is None else p.tracking[key]


def _input_value(key: str) -> Callable[[PhaseSamples], Any]:
    return lambda p: p.inputs[key]


Measure = Callable[["PhaseSamples"], Any]
# How each metric of a phase in the catalog (wmr_mission.spec.catalog) is
# measured, by its name: a metric added to the catalog adds its computation here.
MEASURES: dict[str, Measure] = {
    "tracking_error_rms": lambda p: _rms_or_none(p.off_path[p.settled]),
    "tracking_error_max": lambda p: _largest(p.off_path, p.settled),
    **{
        key: _tracking_value(key)
        for key in (
            "cross_track_error_max",
            "along_track_lag_max",
            "detour_offset_max",
            "detour_time",
        )
    },
    "zone_intrusion_max": lambda p: p.intrusion,
    "clearance_min": lambda p: p.clearance,
    "stall_time": lambda p: p.stall,
    "overshoot_max": lambda p: p.overshoot,
    **{key: _input_value(key) for key in _INPUT_METRICS},
    "speed_at_limit": lambda p: at_limit_fraction(p.v[p.settled], p.result.limits[0]),
    "turn_rate_at_limit": lambda p: at_limit_fraction(p.omega[p.settled], p.result.limits[1]),
    "estimation_rms": lambda p: {s: _rms_or_none(e[p.settled]) for s, e in p.errors.items()},
}


def _measured(phase: PhaseSamples, metrics: list[Metric]) -> dict[str, dict[str, Any]]:
    """The values of a phase's ``metrics``, placed as in a phase's summary."""
    values: dict[str, dict[str, Any]] = {}
    for metric in metrics:
        section, key = metric.where
        values.setdefault(section, {})[key] = MEASURES[metric.name](phase)
    return values


def _checked_phase_summary(
    info: PhaseRecord, phase: PhaseSamples, thresholds: Mapping[str, Any]
) -> dict[str, Any]:
    """What :func:`check_expectations` reads of a phase's summary: the value of
    each threshold set that applies to the phase, as :func:`_phase_summary` has it."""
    summary = {
        "name": info.name,
        "kind": info.kind,
        "settled_samples": phase.settled_samples,
    }
    checked = [metric for metric in _applying(summary) if thresholds.get(metric.name) is not None]
    values: dict[str, Any] = _measured(phase, checked)
    if "tracking" in values:  # with what the `auto` thresholds read
        values["tracking"] = phase.tracking
    if "regulation" in values:
        values["regulation"] = phase.regulation
    return summary | values


def _phase_summary(
    result: RunRecord, info: PhaseRecord, phase: PhaseSamples, tolerance: Mapping[str, float]
) -> dict[str, Any]:
    """A phase's summary in ``summary.json``."""
    t = result.t
    window, settled, start_time = phase.window, phase.settled, phase.start_time
    # A phase lasts until the next one begins (or the run ends).
    end_sample = window.stop if window.stop < result.samples else result.samples - 1
    track = info.kind == "track"
    quality = _measured(
        phase,
        [
            m
            for m in catalog.phase_metrics()
            if m.where[0] != "tracking" and (track or m.where[0] != "tracking_error")
        ],
    )
    tracking = None
    if track:
        x, y = result.x[window], result.y[window]
        x_ref, y_ref = result.x_ref[window], result.y_ref[window]
        tracking = quality["tracking_error"] | {
            "rms_from_start": _rms_or_none(phase.off_path),
            "max_from_start": _largest(phase.off_path),
            # distance from the reference point of the same sample, lag
            # included (runs.csv's reference_error_rms over the track phases)
            "reference_error_rms": reference_error(
                reference_distance(x[settled], y[settled], x_ref[settled], y_ref[settled])
            ),
        }

    target_error = None
    if not track and info.target is not None:
        position, heading = _pose_error(result, end_sample, info.target)
        target_error = {"position": position, "heading": heading}

    constraint = result.constraint[window]
    converged = convergence_index(phase.errors, tolerance)
    iterations = result.phase2_iterations[window]
    summary: dict[str, Any] = {
        "name": info.name,
        "kind": info.kind,
        "start": start_time,
        "end": float(t[end_sample]),
        "duration": round(float(t[end_sample]) - start_time, 9),  # no 20.000000000000004
        "settle_time": phase.settle_time,
        "settled_samples": phase.settled_samples,
        "tracking_error": tracking,
        "tracking": phase.tracking,
        "target_error": target_error,
        "regulation": phase.regulation,
        "constraint": {
            "max_violation": _violation(constraint),
            # the largest row value itself: negative = the closest approach
            "max_value": _max_or_none(constraint),
            "time_in_violation": (
                float(np.count_nonzero(constraint > VIOLATION_TOLERANCE)) * result.dt
            ),
            "intrusion_max": quality["constraint"]["intrusion_max"],
            # [m] the body's least distance from the zones' forbidden side
            "clearance_min": phase.clearance,
        },
        "estimation": {
            "rms": quality["estimation"]["rms"],
            "max_abs_error": {s: _largest(e, magnitude=True) for s, e in phase.errors.items()},
            "overshoot": {s: overshoot(e, tolerance[s]) for s, e in phase.errors.items()},
            # seconds after the phase start
            "convergence_time": (
                None if converged is None else float(t[window.start + converged]) - start_time
            ),
        },
        "inputs": {
            # seconds after the phase start from which the input quality is judged
            "judged_from": (
                float(t[phase.first_judged]) - start_time
                if phase.first_judged < window.stop
                else None
            ),
            **quality["inputs"],
        },
        "max_abs_v": _largest(phase.v, magnitude=True),
        "max_abs_omega": _largest(phase.omega, magnitude=True),
        "phase2_iterations": {
            "total": int(iterations.sum()),
            "max": int(iterations.max()) if iterations.size else 0,
        },
    }
    for section, values in quality.items():  # a metric the catalog has beside these
        placed = summary.setdefault(section, {})
        if isinstance(placed, dict):
            for key, value in values.items():
                placed.setdefault(key, value)
    return summary


def compute_time_us(compute_ns: np.ndarray) -> dict[str, float | None]:
    """Estimator + controller wall time per sample [us]: mean, median, 99th percentile."""
    if compute_ns.size == 0:
        return {"mean": None, "median": None, "p99": None}
    us = np.divide(compute_ns, 1000.0)  # each as a float, divided: no copy before
    mean = float(np.mean(us))  # before `us` is reordered: the sum's order is its own
    # `us` selected in place, not copied: a long run's column (the same values picked)
    median = float(np.median(us, overwrite_input=True))
    return {
        "mean": mean,
        "median": median,
        "p99": float(np.percentile(us, 99, overwrite_input=True)),
    }


def _expect_of(mission: Mapping[str, Any] | None) -> Mapping[str, Any]:
    expect = (mission or {}).get("expect")
    # a resolved mission's dicts told apart without the abstract class's slower check
    return expect if type(expect) is dict or isinstance(expect, Mapping) else {}


def phase_expectations(mission: Mapping[str, Any] | None) -> dict[str, dict[str, Any]]:
    """Per phase name, the phase's `expect` thresholds in force: the mission's
    per-phase keys, overridden by each key the phase sets itself (its
    ``temporal`` formulas too).

    ``mission`` is the resolved mission (``Mission.model_dump(mode="json")``).
    """
    expect = _expect_of(mission)
    shared = {key: expect.get(key) for key in _phase_keys()}
    merged = {}
    for phase in _written_phases(mission):
        # the shared keys in their order, each the phase sets (not null) its own
        kept = merged[str(phase.get("name"))] = shared.copy()
        for key, value in (phase.get("expect") or {}).items():
            if value is not None and key in shared:
                kept[key] = value
    return merged


# (catalog size) -> the catalog's run metrics, read per row.
_RUN_METRICS: dict[int, tuple[Metric, ...]] = {}


def _run_metrics() -> tuple[Metric, ...]:
    """:func:`catalog.run_metrics`, once per catalog."""
    found = _RUN_METRICS.get(len(catalog.CATALOG))
    if found is None:
        found = _RUN_METRICS[len(catalog.CATALOG)] = tuple(catalog.run_metrics())
    return found


# (catalog size) -> the keys of a phase's `expect` in force: read per row, the
# same once the models are built.
_PHASE_KEYS: dict[int, tuple[str, ...]] = {}


def _phase_keys() -> tuple[str, ...]:
    """The keys :func:`phase_expectations` gives each phase, in its order."""
    found = _PHASE_KEYS.get(len(catalog.CATALOG))
    if found is None:
        found = ("settle_time", "temporal", *(m.name for m in catalog.phase_metrics()))
        _PHASE_KEYS[len(catalog.CATALOG)] = found
    return found


def _written_phases(mission: Mapping[str, Any] | None) -> list[Mapping[str, Any]]:
    """The mission's phases as written, those of each repeat group in its
    place, then its contingencies' (:func:`written_phases`)."""
    return [phase for _, phase in written_phases(mission)]


def _goals(
    mission: Mapping[str, Any] | None, numbers: MissionNumbers
) -> dict[str, tuple[float, float]]:
    """Per phase name as written, the position and heading tolerances of its goal:
    its `settled` condition widened by a noise std (the estimator averages noise, so
    a true pose beyond that is the controller's), else the tracking tolerance and
    the heading's convergence tolerance and noise."""
    goals = {}
    for phase in _written_phases(mission):
        settled = (phase.get("until") or {}).get("settled")
        if settled is not None and (type(settled) is dict or isinstance(settled, Mapping)):
            goals[str(phase.get("name"))] = (
                float(settled["position"]) + numbers.position_noise,
                float(settled["heading"]) + numbers.heading_noise,
            )
    return goals


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


def summarize(result: RunRecord, mission: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """All metrics of a run, in a fixed key order (the content of ``summary.json``).

    ``mission`` (the resolved mission) sets how metrics are measured: each
    phase's settle time and the convergence tolerance per state.
    """
    errors = estimation_errors(result)  # once: the run's and, sliced, its phases'
    phases = _phase_samples(result, mission, distance_to_path, errors)
    summary = run_metrics(result, mission, phases, errors)
    tolerance = _tolerance(mission)
    entries = [
        _phase_summary(result, info, p, tolerance) | _formulas(result, info, p, mission, expect)
        for info, p, expect in phases
    ]
    summary["clearance_phases"] = _clearance_phases(entries)
    summary["phases"] = entries
    summary["compute_us_per_sample"] = compute_time_us(result.compute_ns)
    summary["loop_us_per_sample"] = loop_time_us(result)
    return summary


def _clearance_phases(entries: Sequence[Mapping[str, Any]]) -> list[str] | None:
    """The phases (``phases[].name``, each once, in run order) the run's
    ``clearance_min`` is the least over: those with zones and samples. A zone
    is judged only where a phase keeps it: a phase without it may go through
    it, and the run's least does not see it. None where none has (no zones)."""
    names = [
        str(entry["name"])
        for entry in entries
        if (entry.get("constraint") or {}).get("clearance_min") is not None
    ]
    return list(dict.fromkeys(names)) or None


Phases = list[tuple["PhaseRecord", "PhaseSamples", Mapping[str, Any]]]


def _formulas(
    result: RunRecord,
    info: PhaseRecord,
    phase: PhaseSamples,
    mission: Mapping[str, Any] | None,
    expect: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """A phase's temporal formulas' robustness, ``{"temporal": {formula: rho}}``, if
    any; ``expect``: the phase's thresholds in force (:func:`phase_expectations`),
    if at hand."""
    return temporal.phase_values(
        result, info, phase.window, phase.settle_time, phase.numbers, mission,
        lambda: phase.placement, None if expect is None else tuple(expect.get("temporal") or ()),
        lambda: phase.reference_known, lambda: _entry_time(phase),
    )  # fmt: skip


def _entry_time(phase: PhaseSamples) -> float:
    """[s] The entry a track phase's tracking leaves out (0 where none is):
    a formula's `entry` is the same instant."""
    return float((phase.tracking or {}).get("entry_time") or 0.0)


def _phase_samples(
    result: RunRecord,
    mission: Mapping[str, Any] | None,
    off_path: OffPath,
    errors: dict[str, FloatArray] | None = None,
    per_phase: Mapping[str, Mapping[str, Any]] | None = None,
) -> Phases:
    """Each stretch of a phase in run order: its record, its samples (their
    tracking error measured by ``off_path``), and the `expect` thresholds in
    force for it. ``errors``: the run's estimation errors, if at hand (the
    phases' are then views of them); ``per_phase``: the mission's
    :func:`phase_expectations`, if at hand."""
    per_phase = phase_expectations(mission) if per_phase is None else per_phase
    numbers = mission_numbers(mission, result.dt, result.limits)
    kept = errors
    errors = estimation_errors(result) if errors is None else errors
    judged_from = input_metrics.first_judged(result.t, errors, numbers)
    # its first sample, the same for every phase: found once
    inputs_from = (
        None if judged_from is None else int(result.t.searchsorted(judged_from - 1e-9 * result.dt))
    )
    del errors  # not kept while the phases are measured unless the caller keeps them
    body = footprint_of(mission if mission is not None else result.mission)
    judged = _Judged(numbers, inputs_from, _goals(mission, numbers), kept, body)
    phases: Phases = []
    shared = _expect_of(mission)  # a phase not written in the mission's: the mission's own
    for entry in phase_segments(result):
        info = result.phases[entry.phase]
        expect = per_phase.get(_written_name(info.name), shared)
        phase = PhaseSamples(result, info, entry, _settle_time(expect), off_path, judged)
        phases.append((info, phase, expect))
    return phases


def run_columns(
    result: RunRecord, mission: Mapping[str, Any] | None, phases: Phases | None = None
) -> dict[str, float | None]:
    """Each metric of a phase that runs.csv has a column of (catalog.Metric.column),
    over the run: its worst over the phases of its kinds that have it
    (``clearance_min``: the body's least clearance; None where no phase has one).
    ``phases``: the run's (:func:`_phase_samples`), if at hand."""
    wanted = _of_kind("", False, column=True)
    found: dict[str, list[float]] = {m.name: [] for m in wanted}
    if phases is None:
        phases = _phase_samples(result, mission, distance_to_path)
    for info, phase, _ in phases:
        for metric in wanted:
            value = MEASURES[metric.name](phase) if info.kind in metric.kinds else None
            if value is not None:
                found[metric.name].append(value)
    return {m.name: m.worst(found[m.name]) for m in wanted}


def run_metrics(
    result: RunRecord,
    mission: Mapping[str, Any] | None = None,
    phases: Phases | None = None,
    errors: dict[str, FloatArray] | None = None,
) -> dict[str, Any]:
    """The mission-wide metrics of :func:`summarize` (its keys before ``phases``),
    without the per-phase ones; ``phases`` and ``errors`` (the run's estimation
    errors): the run's, if at hand."""
    tolerance = _tolerance(mission)
    errors = estimation_errors(result) if errors is None else errors
    if phases is None:
        phases = _phase_samples(result, mission, distance_to_path, errors)
    summary = _bounded_metrics(
        result, tolerance, errors, run_columns(result, mission, phases), phases
    )
    settled = _suffix(
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
    if any(phase.constraints for phase in result.phases):
        # [m] the zones' allowed side shrunk by the estimate's uncertainty
        summary["constraint_margin"] = result.constraint_margin
    # last in summary.json, whose key order is fixed
    for key in ("max_constraint_violation", *(m.name for m in catalog.phase_metrics() if m.column)):
        summary[key] = summary.pop(key)
    return summary


def _bounded_metrics(
    result: RunRecord,
    tolerance: Mapping[str, float],
    errors: dict[str, FloatArray],
    columns: Mapping[str, float | None],
    phases: Phases,
) -> dict[str, Any]:
    """The run's outcome, the mission-wide metrics an `expect` can bound (the
    catalog's run metrics) and the worst of the phases' that runs.csv has
    (:func:`run_columns`), as :func:`run_metrics` has them; ``phases``: the
    run's (:func:`_phase_samples`)."""
    converged = convergence_index(errors, tolerance)
    stretches = [(info, phase.window.start, phase.window.stop) for info, phase, _ in phases]
    duration = round(float(result.t[-1] - result.t[0]), 9) if result.samples else 0.0
    return {
        "outcome": result.outcome.value,
        "message": result.message,
        "mission": result.mission_name,
        "seed": result.seed,
        "samples": result.samples,
        "duration": duration,
        "final": _final(result, stretches),
        "estimation_convergence_time": None if converged is None else float(result.t[converged]),
        "max_constraint_violation": _violation(
            result.constraint, [start for _, start, _ in stretches]
        ),
        **columns,
        # A real-time run's pace and command latency (wmr_mission.backends); absent in
        # our simulator, whose summary keeps its bytes.
        **({} if result.realtime is None else {"realtime": copy.deepcopy(result.realtime)}),
    }


def footprint_of(mission: Mapping[str, Any] | None) -> Mapping[str, Any] | None:
    """The robot's footprint as written (None: a point)."""
    robot = (mission or {}).get("robot") or {}
    footprint = robot.get("footprint")
    return footprint if isinstance(footprint, Mapping) else None


def loop_time_us(result: RunRecord) -> float | None:
    """Wall time of the whole simulation loop per sample [us] (None when not timed)."""
    if result.loop_ns <= 0 or result.samples == 0:
        return None
    return result.loop_ns / 1000.0 / result.samples


def summary_value(summary: Mapping[str, Any], path: tuple[str, ...]) -> float | None:
    value: Any = summary
    for key in path:
        # a summary's dicts told apart without the abstract class's slower check
        if type(value) is not dict and not isinstance(value, Mapping):
            return None
        value = value.get(key)
    if type(value) is float:  # most values: no further type checks
        return value if math.isfinite(value) else None
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def _value_of(phase: Mapping[str, Any], where: tuple[str, ...]) -> float | None:
    """:func:`summary_value` of a phase's summary (a dict), a metric in a
    section of it read without the general walk: most checks read one."""
    if len(where) == 2:
        section = phase.get(where[0])
        if type(section) is dict:
            value = section.get(where[1])
            if type(value) is float or type(value) is int:  # not a bool
                return float(value) if math.isfinite(value) else None
            if value is None:
                return None
    return summary_value(phase, where)


def _applying(phase: Mapping[str, Any]) -> tuple[Metric, ...]:
    """The catalog's phase metrics that apply to ``phase`` (its summary), in
    the catalog's order: those of its kind (catalog.Metric.kinds); of those
    measured after the settle time, only where it has samples after it (one
    checked where measured is checked where it has a value)."""
    return _of_kind(str(phase.get("kind")), bool(phase.get("settled_samples")))


# (kind, settled samples or none, columns, catalog size) -> the metrics: a
# row's phases ask the same few questions of the catalog, which is complete
# once the models are built.
_APPLYING: dict[tuple[str, bool, bool, int], tuple[Metric, ...]] = {}


def _of_kind(kind: str, settled: bool, column: bool = False) -> tuple[Metric, ...]:
    """The catalog's phase metrics of phases of ``kind``, those measured after
    the settle time only if ``settled``, in its order; with ``column``, those
    runs.csv has a column of (catalog.Metric.column), of every kind."""
    key = (kind, settled, column, len(catalog.CATALOG))
    found = _APPLYING.get(key)
    if found is None:
        found = _APPLYING[key] = tuple(
            m
            for m in catalog.phase_metrics()
            if (m.column if column else kind in m.kinds and (m.where_measured or settled))
        )
    return found


def auto_threshold(metric: str, phase: Mapping[str, Any], numbers: MissionNumbers) -> float | None:
    """The bound an `auto` threshold stands for in ``phase`` (its summary), from
    the mission's numbers (docs/mission-format.md, "Verdicts", says why)."""
    if metric == "cross_track_error_max":
        return numbers.tracking_tolerance
    if metric == "along_track_lag_max":
        speed = (phase.get("tracking") or {}).get("reference_speed_max")
        if speed is None:
            return None
        # the time to accelerate to the reference's speed is the entry's
        # (MissionNumbers.recovery_time), not a lag kept for the whole phase
        return numbers.lag_allowance(float(speed))
    if metric == "detour_offset_max":
        # The filter keeps the tracked output off the zones grown by the margin
        # the controller keeps (the body's and the estimate's, in zone_reach) and
        # the look-ahead (constrained_tracking.keep_constraints); a robot that
        # tracks is within the tolerance of that. The aim's gap beyond it
        # (AIM_GAP, at most half the tolerance) is the controller's own and
        # comes out of the tolerance.
        reach = (phase.get("tracking") or {}).get("zone_reach") or 0.0
        return reach + numbers.look_ahead + numbers.tracking_tolerance
    if metric == "overshoot_max":
        return (phase.get("regulation") or {}).get("goal_position")
    if metric == "speed_jump_max":
        return numbers.v_limit
    if metric == "turn_rate_jump_max":
        return numbers.omega_limit
    if metric == "turn_rate_jitter":
        return JITTER_FLOOR * numbers.omega_limit + numbers.heading_noise / numbers.time_constant
    raise ValueError(f"{metric} has no auto threshold")


def _phase_checks(
    phase: Mapping[str, Any], thresholds: Mapping[str, Any], numbers: MissionNumbers
) -> list[Check]:
    checks = []
    name = str(phase.get("name"))
    for metric in _applying(phase):
        threshold = thresholds.get(metric.name)
        if threshold is None:
            continue
        if metric.expect == "per-state":  # a bound per state
            for state in STATES:
                if threshold.get(state) is not None:
                    value = _value_of(phase, (*metric.where, state))
                    checks.append(
                        Check(f"{metric.name}.{state}", name, float(threshold[state]), value)
                    )
            continue
        value = _value_of(phase, metric.where)
        if metric.where_measured and value is None:
            continue
        if metric.bound == "min":  # at least so much
            checks.append(Check(metric.name, name, float(threshold), value, lower=True))
            continue
        bound = (
            auto_threshold(metric.name, phase, numbers) if threshold == "auto" else threshold["max"]
        )
        if bound is not None:
            checks.append(Check(metric.name, name, float(bound), value))
    return checks


def check_expectations(
    summary: Mapping[str, Any], mission: Mapping[str, Any] | None
) -> list[Check]:
    """Each `expect` threshold in force with the run's value: the mission-wide
    ones (``phase`` null), then each phase's (``phase`` its name), in run order;
    an `auto` one with the bound it stands for in the phase (:func:`auto_threshold`).

    A missing (null) value never meets a threshold: a non-finite metric after
    a divergence fails. A phase-quality threshold is not checked where it does
    not apply (a phase no longer than its settle time; tracking off a track phase;
    a metric checked where measured, catalog.Metric.where_measured, where it has no value).
    """
    return _checks(summary, mission, phase_expectations(mission))


# (catalog size) -> the keys a mission's `expect` may have: read per row.
_KNOWN_KEYS: dict[int, frozenset[str]] = {}


def _known_keys() -> frozenset[str]:
    found = _KNOWN_KEYS.get(len(catalog.CATALOG))
    if found is None:
        found = _KNOWN_KEYS[len(catalog.CATALOG)] = frozenset(
            (*catalog.CATALOG, *_SETTINGS, "temporal")
        )
    return found


def _checks(
    summary: Mapping[str, Any],
    mission: Mapping[str, Any] | None,
    per_phase: Mapping[str, Mapping[str, Any]],
    at_hand: MissionNumbers | None = None,
) -> list[Check]:
    """:func:`check_expectations` with the mission's :func:`phase_expectations`
    at hand; ``at_hand``: the mission's numbers for some sampling period and
    limits, if any (used where they are the mission's)."""
    robot = (mission or {}).get("robot") or {}
    limits = robot.get("limits") or {}
    dt = float(robot.get("dt", _DEFAULT_DT))
    v_limit, omega_limit = (
        float(limits.get("v", _DEFAULT_V)),
        float(limits.get("omega", _DEFAULT_OMEGA)),
    )
    numbers = (
        at_hand
        if at_hand is not None
        and (at_hand.dt, at_hand.v_limit, at_hand.omega_limit) == (dt, v_limit, omega_limit)
        else mission_numbers(mission, dt, (v_limit, omega_limit))
    )
    expect = _expect_of(mission)
    known = _known_keys()
    if not known.issuperset(expect):  # the first key unknown named
        key = next(key for key in expect if key not in known)
        listed = ", ".join((*catalog.CATALOG, *_SETTINGS, "temporal"))
        raise ValueError(f"unknown expectation {key!r}; expected one of {listed}")
    checks = [
        Check(m.name, None, float(expect[m.name]["max"]), summary_value(summary, m.where))
        for m in _run_metrics()
        if expect.get(m.name) is not None and (m.where[0] != _REALTIME or _REALTIME in summary)
    ]
    controller = str(((mission or {}).get("controller") or {}).get("type", "paper"))
    for phase in summary.get("phases") or []:
        thresholds = per_phase.get(_written_name(str(phase.get("name"))), expect)
        found = _phase_checks(phase, thresholds, numbers)
        for check in found if phase.get("kind") == "track" else ():
            if not check.met:  # the tracking law's, for a miss
                check.advice = advice(check, phase, numbers, controller)
        checks.extend(found)
        checks.extend(temporal.formula_checks(phase))
    return checks


def unmet(checks: list[Check]) -> list[str]:
    """Each unmet check in words: ``orbit: turn_rate_at_limit = 0.974 (max 0.01)``."""
    return [check.words() for check in checks if not check.met]


def judge(result: RunRecord, mission: MissionTerms) -> dict[str, Any]:
    """The run's summary with every `expect` threshold checked.

    A run that ended as a success but misses a threshold is not one: its
    outcome becomes ``expect-failed`` (in ``result`` too), with the misses as
    its message. Thresholds are what a mission relaxes, not the outcome.
    ``mission``: the checked mission, or one as a run directory holds it
    (:func:`resolved`).
    """
    jit.judged(result.samples)
    mission = resolved(mission)
    summary = summarize(result, mission)
    checks = check_expectations(summary, mission)
    _judged(result, summary, checks)
    summary["expectations"] = [check.record() for check in checks]
    summary.update(margin_fields(checks, result.outcome.value))
    if mission is not None and mission is result.mission:  # summary.json reuses it
        result.judged = summary
    return summary


def judge_mission(result: RunRecord, mission: models.Mission) -> dict[str, Any]:
    """The run of the checked ``mission`` judged as :func:`judge` judges it, the
    mission as run (its defaults, the run's sensor seed) kept on the result
    for summary.json and the figures."""
    resolved = mission.model_dump(mode="json")
    resolved["sensors"]["seed"] = result.seed  # the mission as run
    result.mission = resolved
    return judge(result, resolved)


def judge_run_metrics(result: RunRecord, mission: MissionTerms) -> dict[str, Any]:
    """The keys of :func:`run_metrics` a campaign's row records (the outcome and
    the metrics an `expect` bounds mission-wide, the run's ``margin`` and
    ``margin_check``, and the checks it ``missed``), with the run judged as
    :func:`judge` judges it (the same outcome and message, in ``result`` too),
    at a fraction of the cost.

    A tracking-error threshold is checked first against the distance to each
    sample's own reference point: that point ends a segment
    :func:`distance_to_path` tries, so the distance to the path is never above
    it, and a phase within its threshold by it is within it. Only when that
    bound misses a threshold is the distance to the path computed.
    """
    jit.judged(result.samples)
    mission = resolved(mission)
    errors = estimation_errors(result)
    per_phase = phase_expectations(mission)
    phases = _phase_samples(result, mission, _off_path_bound, errors, per_phase)
    columns = run_columns(result, mission, phases)
    summary = _bounded_metrics(result, _tolerance(mission), errors, columns, phases)
    if not result.succeeded:  # judging changes only a success; no check decides a failure
        summary.update(margin_fields([], result.outcome.value))
        return summary
    del errors
    checked = [
        _checked_phase_summary(info, phase, expect)
        | _formulas(result, info, phase, mission, expect)
        for info, phase, expect in phases
    ]
    numbers = phases[0][1].numbers if phases else None  # the run's dt and limits
    del phases
    checks = _checks({**summary, "phases": checked}, mission, per_phase, numbers)
    missed = [check for check in checks if not check.met]
    margin = margin_fields(checks, result.outcome.value)
    # A bound above the distance to the path sets a tracking check's margin
    # below its own: exact where it misses, or where it sets the run's margin.
    if any(c.metric.startswith("tracking_error") for c in missed) or str(
        margin["margin_metric"]
    ).startswith("tracking_error"):
        checks = _checks(summarize(result, mission), mission, per_phase, numbers)
        missed = [check for check in checks if not check.met]
        margin = margin_fields(checks, result.outcome.value)
    _judged(result, summary, missed)  # (its outcome, judged still: the same margin)
    # the checks it missed (exact: a tracking check missed by its bound is
    # measured again), not every check: a met one may hold its bound's value
    summary["missed"] = [check.record() for check in missed]
    summary.update(margin)
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


def _judged(result: RunRecord, summary: dict[str, Any], checks: list[Check]) -> None:
    """A success that misses a threshold becomes ``expect-failed``, in
    ``result`` and ``summary``, with the misses as its message."""
    failures = unmet(checks)
    if result.succeeded and failures:
        result.miss_expectations(failures)
        summary["outcome"], summary["message"] = result.outcome.value, result.message
