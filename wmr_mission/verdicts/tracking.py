"""A track phase judged against its timed reference.

Each sample's *place on the path* is the point of the polyline through the
phase's reference points nearest the robot; where the path passes about as
near elsewhere (a lap run again, a path back over itself), the one nearest the
sample's own reference point along the path. From it:

- the **cross-track error**: the robot's distance from its place [m];
- the **along-track lag**: the arc length from its place to the sample's own
  reference point [m], > 0 behind the reference, < 0 ahead of it. A robot
  stalled on its path is on it (no cross-track error) and ever further behind.

Two stretches of a phase are not judged as tracking:

- the **entry**: the least time the limits need to take out the gap to the
  reference the phase starts with (:meth:`MissionNumbers.recovery_time`), or
  less: it ends once the robot has kept up with its reference point for
  SETTLING time constants (:func:`_kept_up`); a phase that runs for a set
  time (``until: elapsed`` or ``mission_time``) and ends before the entry
  does is judged at its last sample: it was too short for the limits to join
  its path, and tracking it was all it was for;
- a **detour a zone forces**: where a zone lies across the straight way from
  the robot to its reference point, or the path runs into a zone within the
  time a smooth detour needs to start (half a turn at the turn-rate limit and
  five time constants), while the robot keeps moving at half the reference's
  speed or more; and then the time to take out what the detour left. A robot
  that stops where a zone blocks its way is stalled, not detouring: it is
  judged by its lag (it falls behind), and how far off the path it is there
  by the detour's bound, not as tracking (a robot that slowed below half the
  reference's speed for a moment mid-detour read its offset, 0.825 m, as a
  cross-track error; tests/test_detour_bound.py).

A zone "lies across the way" when it is within the look-ahead and the tracking
tolerance of it: the tracked point runs that far ahead of the axle, and a
robot that tracks is that far off its path. How far off the path a detour
takes the robot is its own metric (``detour_offset_max``), over the whole
detour, its samples in the entry included while the robot tracks its path
(:func:`_counted_in_entry`), as is how long it lasts (``detour_time``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray
from wmr_mission.controllers.paper import TURNABLE_SHARE
from wmr_mission.geometry.regions import box_corners
from wmr_mission.kernels import jit
from wmr_mission.spec.numbers import SETTLING, MissionNumbers
from wmr_mission.verdicts.nearest import NearestPoints
from wmr_mission.verdicts.passes import kept_up
from wmr_mission.verdicts.placing import path_lengths, place_samples
from wmr_mission.verdicts.zones import Zone, reach_across

# [m] places on the path this much farther than the nearest are not "about as near".
NEAR_EQUAL = 0.01
# Segments on each side of the estimated place that are searched.
_SEARCH = 2
# Newton steps along the path from the first estimate of the place.
_STEPS = 4
# Points of the way from the robot to its reference point tried against the zones.
_WAY_POINTS = np.linspace(0.0, 1.0, 9)[1:]
# A detour keeps at least this share of the reference's speed (a mean over
# MOVING_WINDOW time constants): less is a stall.
MOVING = 0.5
MOVING_WINDOW = 10.0
# [m across per m along] the gentlest ramp a detour may leave its path on:
# it may start as far before a zone as this ramp takes to clear it.
GENTLE_SLOPE = 0.5
_CHUNK = 4096  # positions per block of the search: bounded memory on long runs
_CANDIDATES = 1 << 15  # below this many position-segment pairs, every segment is tried
_NO_HELD = np.zeros(0, dtype=np.intp)  # a path that never stands still: each segment its own
_NO_PLACES = np.zeros(0)  # none placed yet, or no columns asked for (Placement)

# A path as searched: the arc length at each point, the points, and each segment's
# step and length (segment i from point i to point i + 1).
_Path = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]


def path_steps(rx: FloatArray, ry: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each segment's step (x, y) and length: segment i from point i to point i + 1."""
    sx, sy = np.diff(rx), np.diff(ry)
    return sx, sy, np.sqrt(sx * sx + sy * sy)  # as hypot, at a fraction of its cost


def place_on_path(
    px: FloatArray,
    py: FloatArray,
    rx: FloatArray,
    ry: FloatArray,
    near: float,
    first: int = 0,
    steps: tuple[FloatArray, FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Cross-track error and along-track lag [m] of each position (px, py) against
    the reference points (rx, ry) of the same samples (all finite); NaN before
    sample ``first``, where they are not wanted (:meth:`Placement.on_path`).
    ``steps``: :func:`path_steps` of the reference points, if at hand."""
    return Placement(px, py, rx, ry, steps).on_path(near, first)


class Placement:
    """Each position's place on the path through the reference points of the
    same samples (all finite), found once and shared by whatever reads it: a
    track phase's metrics and its temporal formulas.

    The place is looked for where the robot's error, seen from its own reference
    point along the path's direction there, puts it: on that segment if the
    foot of the perpendicular is on it (the nearest within a few micrometres on
    a path sampled finely), else among the segments round it, and then along
    the path, a Newton step at a time, while it lies beyond them. That search
    is each position's own, so the samples are placed once, as first asked for
    (:meth:`on_path`). Where the robot is farther than ``near`` from the place
    found, the path's nearest points anywhere are tried too, and win when
    nearer by NEAR_EQUAL."""

    def __init__(
        self,
        px: FloatArray,
        py: FloatArray,
        rx: FloatArray,
        ry: FloatArray,
        steps: tuple[FloatArray, FloatArray, FloatArray] | None = None,
    ) -> None:
        self.px, self.py = px, py
        n = rx.size
        arc, moving = None, -1  # the segments that move (-1: not counted)
        # whether every position and every reference point is finite, and the
        # longest segment (None: not known yet)
        self._finite: bool | None = None
        self._known: bool | None = None
        self._longest: float | None = None
        if steps is None and jit.judging_compiled():  # the same bits in one compiled pass
            arc, steps = np.empty(n), (np.empty(n - 1), np.empty(n - 1), np.empty(n - 1))
            moving, self._longest, self._finite, self._known = jit.compiled(path_lengths)(
                (px, py), (rx, ry), steps, arc
            )
        self.steps = path_steps(rx, ry) if steps is None else steps
        sx, sy, length = self.steps
        if moving < 0:
            moving = int(np.count_nonzero(length > 0))
        self.standing = moving == 0  # a reference that stands still: a point
        self._held: NDArray[np.intp] | None = None
        # the places found from sample self._from on (made when first asked for)
        self._cross, self._place = _NO_PLACES, _NO_PLACES
        self._from = n
        if self.standing:  # no arc length along a point
            self.path: _Path = (np.zeros(1), rx, ry, sx, sy, length)
            return
        if arc is None:
            arc = np.concatenate(([0.0], np.cumsum(length)))
        self.path = (arc, rx, ry, sx, sy, length)
        # Where the path stands still, the direction it last had (or first has).
        if moving < n - 1:
            held = np.maximum.accumulate(np.where(length > 0, np.arange(n - 1), -1))
            held[held < 0] = int(np.argmax(length > 0))
            self._held = held

    @property
    def longest(self) -> float:
        """[m] The longest segment of the path (numpy's ``max``), of two points or more."""
        if self._longest is None:
            self._longest = float(self.steps[2].max())
        return self._longest

    @property
    def finite(self) -> bool:
        """Whether every position is finite."""
        if self._finite is None:
            self._finite = bool(np.isfinite(self.px).all() and np.isfinite(self.py).all())
        return self._finite

    @property
    def known(self) -> bool:
        """Whether every reference point is finite."""
        if self._known is None:
            rx, ry = self.path[1], self.path[2]
            self._known = bool(np.isfinite(rx).all() and np.isfinite(ry).all())
        return self._known

    def on_path(self, near: float, first: int = 0) -> tuple[FloatArray, FloatArray]:
        """Cross-track error and along-track lag [m] of each position; NaN
        before sample ``first``."""
        return self.judged_on_path(near, first, self.px.size)[:2]

    def judged_on_path(
        self, near: float, first: int, judged: int
    ) -> tuple[FloatArray, FloatArray, float | None, float | None]:
        """:meth:`on_path`, and the largest cross-track error and |lag| of the
        samples from ``judged`` on (numpy's ``max``: NaN if any is; None
        where there is none), found in the same pass where it is compiled."""
        px, py = self.px, self.py
        arc, rx, ry = self.path[:3]
        if self.standing:
            cross = np.hypot(px - rx[0], py - ry[0])
            cross[:first] = np.nan
            return _most(cross, np.where(np.isnan(cross), np.nan, 0.0), judged)
        if self._cross is _NO_PLACES:  # none read before self._from
            self._cross, self._place = np.empty(px.size), np.empty(px.size)
        begin, end = (first, self._from) if first < self._from else (first, first)
        self._from = min(first, self._from)
        if jit.judging_compiled():  # the same bits in one compiled pass (verdicts/placing.py)
            cross, lag = np.empty(px.size), np.empty(px.size)
            far_ones, most_cross, most_lag = self._place_samples(
                begin, end, (first, judged, near), (cross, lag)
            )
            if far_ones == 0:  # every place within ``near``: the nearest, none searched for
                if judged >= px.size:
                    return cross, lag, None, None
                return cross, lag, most_cross, most_lag
            far = np.flatnonzero(cross > near)
        else:
            self._place_samples(begin, end)
            cross = self._cross.copy()
            cross[:first] = np.nan
            lag = np.subtract(arc, self._place)  # the places not copied first: a long run's column
            lag[:first] = np.nan
            far = np.flatnonzero(cross > near)
        if far.size:
            distance, at = _nearest_anywhere(far, cross[far], self.path, px, py)
            better = distance < cross[far] - NEAR_EQUAL
            cross[far[better]] = distance[better]
            lag[far[better]] = arc[far[better]] - at[better]
        return _most(cross, lag, judged)

    def direction_at(
        self, samples: NDArray[np.intp], lag: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """The path's unit direction at the places ``lag`` behind the reference
        points of ``samples`` (as :meth:`on_path` gives them)."""
        arc, n = self.path[0], self.path[1].size
        if self.standing:
            return np.zeros(samples.size), np.zeros(samples.size)
        place = arc[samples] - lag
        segment = np.clip(np.searchsorted(arc, place, side="right") - 1, 0, n - 2)
        return self._direction(segment)

    def _direction(self, segment: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
        _, _, _, sx, sy, length = self.path
        along = segment if self._held is None else self._held[segment]
        return sx[along] / length[along], sy[along] / length[along]

    def _place_samples(
        self,
        begin: int,
        end: int,
        columns: tuple[int, int, float] = (0, 0, 0.0),
        found: tuple[FloatArray, FloatArray] = (_NO_PLACES, _NO_PLACES),
    ) -> tuple[int, float, float]:
        """The places of samples ``begin .. end - 1`` by the local search; where
        compiled, then :meth:`judged_on_path`'s columns into ``found`` (unless
        empty) from ``columns`` (first, judged, near), as ``place_samples``
        gives them: how many are far, and the largest."""
        px, py = self.px, self.py
        if jit.judging_compiled():  # the same numbers in one compiled pass (verdicts/placing.py)
            held = _NO_HELD if self._held is None else self._held
            return jit.compiled(place_samples)(
                px, py, self.path, held, (begin, end), _SEARCH, _STEPS,
                (self._cross, self._place), columns, found,
            )  # fmt: skip
        arc, rx, ry, sx, sy, length = self.path
        n = rx.size
        cross, place = self._cross, self._place
        for start in range(begin, end, _CHUNK):  # bounded memory on long runs
            stop = min(start + _CHUNK, end)
            own = np.minimum(np.arange(start, stop), n - 2)  # the last point: the last segment
            qx, qy, part = px[start:stop], py[start:stop], slice(start, stop)
            ux, uy = self._direction(own)
            guess = arc[part] - ((rx[part] - qx) * ux + (ry[part] - qy) * uy)
            # Most often the guess's own segment holds the foot of the perpendicular.
            # (np.minimum and np.maximum: np.clip costs several times more on small arrays)
            segment = np.maximum(
                np.minimum(np.searchsorted(arc, guess, side="right") - 1, n - 2), 0
            )
            ax, ay, ex, ey = rx[segment], ry[segment], sx[segment], sy[segment]
            step = length[segment]
            along = ((qx - ax) * ex + (qy - ay) * ey) / np.where(step > 0, step * step, 1.0)
            inside = (along > 0.0) & (along < 1.0)
            dx, dy = qx - ax - along * ex, qy - ay - along * ey
            cross[part] = np.where(inside, np.sqrt(dx * dx + dy * dy), np.nan)
            place[part] = arc[segment] + along * step
            pending = np.flatnonzero(~inside) + start
            guess = guess[pending - start]
            for attempt in range(_STEPS):
                if pending.size == 0:
                    break
                distance, at, segment, beyond = _search(pending, guess, self.path, px, py)
                if attempt == _STEPS - 1:
                    beyond[:] = False
                cross[pending[~beyond]] = distance[~beyond]
                place[pending[~beyond]] = at[~beyond]
                # Beyond the segments searched: a Newton step along the path from there.
                rows, seg, at = pending[beyond], segment[beyond], at[beyond]
                ux, uy = self._direction(seg)
                footx = rx[seg] + (at - arc[seg]) * ux
                footy = ry[seg] + (at - arc[seg]) * uy
                guess = at + (px[rows] - footx) * ux + (py[rows] - footy) * uy
                pending = rows
        return -1, math.nan, math.nan  # no columns made


def _most(
    cross: FloatArray, lag: FloatArray, judged: int
) -> tuple[FloatArray, FloatArray, float | None, float | None]:
    """The columns, and the largest cross-track error and |lag| from sample ``judged`` on."""
    if judged >= cross.size:
        return cross, lag, None, None
    return cross, lag, float(cross[judged:].max()), float(np.abs(lag[judged:]).max())


def _search(
    rows: NDArray[np.intp], guess: FloatArray, path: _Path, px: FloatArray, py: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.intp], NDArray[np.bool_]]:
    """For positions ``rows``, the nearest point of the segments round the arc
    length ``guess``: distance, arc length, segment, and whether it lies at the
    outer end of the segments searched (so that the place may be beyond)."""
    arc = path[0]
    last = arc.size - 2
    centre = np.searchsorted(arc, guess, side="right") - 1
    segments = np.maximum(np.minimum(centre[:, None] + np.arange(-_SEARCH, _SEARCH + 1), last), 0)
    distance, at, chosen, along = _nearest_of(segments, path, px, py, rows)
    beyond = ((chosen == segments[:, 0]) & (along <= 0.0) & (chosen > 0)) | (
        (chosen == segments[:, -1]) & (along >= 1.0) & (chosen < last)
    )
    return distance, at, chosen, beyond


def _nearest_of(
    segments: NDArray[np.intp], path: _Path, px: FloatArray, py: FloatArray, rows: NDArray[np.intp]
) -> tuple[FloatArray, FloatArray, NDArray[np.intp], FloatArray]:
    """Of each row's segments (i from point i to i + 1), the nearest point to
    position ``rows[row]``: its distance, arc length, segment and fraction along it."""
    arc, rx, ry, sx, sy, length = path
    qx, qy = px[rows][:, None], py[rows][:, None]
    ax, ay, ex, ey = rx[segments], ry[segments], sx[segments], sy[segments]
    squared = length[segments] ** 2
    along = ((qx - ax) * ex + (qy - ay) * ey) / np.where(squared > 0, squared, 1.0)
    along = np.maximum(np.minimum(along, 1.0), 0.0)
    dx, dy = qx - ax - along * ex, qy - ay - along * ey
    distance = np.sqrt(dx * dx + dy * dy)
    best = np.argmin(distance, axis=1)
    pick = np.arange(rows.size)
    chosen = segments[pick, best]
    fraction = along[pick, best]
    return distance[pick, best], arc[chosen] + fraction * length[chosen], chosen, fraction


def _nearest_anywhere(
    rows: NDArray[np.intp], reach: FloatArray, path: _Path, px: FloatArray, py: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The nearest point of the whole path to positions ``rows``: of every segment
    for a few positions, else of the segments next to the path's points nearest
    them (one point kept per cell of a grid half as fine as the path's sampling,
    so a path run round many times is not searched lap by lap; the first pass
    through a cell is the one kept)."""
    arc, rx, ry, _, _, length = path
    last = arc.size - 2
    if rows.size * (last + 1) <= _CANDIDATES:  # few enough to try every segment
        every = np.broadcast_to(np.arange(last + 1), (rows.size, last + 1))
        distance, at, _, _ = _nearest_of(every, path, px, py, rows)
        return distance, at
    steps = length[length > 0]
    cell = float(np.median(steps)) / 2
    column, row = np.floor(rx / cell), np.floor(ry / cell)
    order = np.lexsort((row, column))
    column, row = column[order], row[order]
    first = order[np.r_[True, (column[1:] != column[:-1]) | (row[1:] != row[:-1])]]
    grid = NearestPoints(rx[first], ry[first], cell, rows.size)
    distance, at = np.empty(rows.size), np.empty(rows.size)
    for start in range(0, rows.size, _CHUNK):
        part = slice(start, start + _CHUNK)
        points = first[grid.nearest(px[rows[part]], py[rows[part]], 4, reach[part])]
        segments = np.clip(np.concatenate((points - 1, points), axis=1), 0, last)
        d, a, _, _ = _nearest_of(segments, path, px, py, rows[part])
        distance[part], at[part] = d, a
    return distance, at


def _mean_over(values: FloatArray, samples: int) -> FloatArray:
    """Mean over a centred window of ``samples`` (fewer at the ends)."""
    samples = max(1, min(samples, values.size))
    total = np.concatenate(([0.0], np.cumsum(values)))
    half = samples // 2
    k = np.arange(values.size)
    lo, hi = np.maximum(k - half, 0), np.minimum(k - half + samples, values.size)
    mean: FloatArray = (total[hi] - total[lo]) / (hi - lo)
    return mean


def _any_within(flags: NDArray[np.bool_], samples: int) -> NDArray[np.bool_]:
    """Whether any of each sample and the ``samples`` after it is flagged."""
    count = np.concatenate(([0], np.cumsum(flags, dtype=np.int64)))
    k = np.arange(flags.size)
    found: NDArray[np.bool_] = count[np.minimum(k + samples + 1, flags.size)] - count[k] > 0
    return found


def _ramps(near: NDArray[np.bool_], travelled: FloatArray, across: FloatArray) -> NDArray[np.bool_]:
    """The samples on a ramp of GENTLE_SLOPE that goes ``across`` [m] by a
    ``near`` sample (less where it is not as deep) before it or after it:
    each stretch of near samples with as much path before and after it as
    the ramps it needs; ``travelled``: the distance along from the first
    sample, never falling."""
    ramps = np.zeros(near.size, dtype=bool)
    edges = np.flatnonzero(np.diff(near, prepend=False, append=False))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        along = travelled[start:stop]
        ramp = np.maximum(across[start:stop], 0.0) / GENTLE_SLOPE
        first = np.searchsorted(travelled, float(np.min(along - ramp)), side="left")
        last = np.searchsorted(travelled, float(np.max(along + ramp)), side="right")
        ramps[first:last] = True
    return ramps


def _speed(x: FloatArray, y: FloatArray, dt: float) -> FloatArray:
    """[m/s] from each sample to the next (the last repeats the one before)."""
    if x.size < 2:
        return np.zeros(x.size)
    dx, dy = np.diff(x), np.diff(y)
    step = np.sqrt(dx * dx + dy * dy) / dt
    return np.concatenate((step, step[-1:]))


class TrackSamples(NamedTuple):
    """A track phase's samples as its verdict sees them, one value per sample of
    the phase (NaN and False where the reference is unknown): the cross-track
    error and along-track lag [m] (NaN where not measured), whether the sample
    is judged (not in the entry nor in a detour or its rejoining), and whether
    the detour's bound judges its offset (in a detour a zone forces, or
    slowed where a zone blocks the robot's way: its cross-track error not
    judged, its lag judged); each put back among the phase's samples
    when read (a long run's columns made only where asked for)."""

    known: slice | NDArray[np.bool_] | None  # the samples with a known reference (None: all)
    size: int  # the phase's samples
    measured: tuple[FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.bool_]]  # of ``known``

    @property
    def cross(self) -> FloatArray:
        return self._all(0, np.nan)

    @property
    def lag(self) -> FloatArray:
        return self._all(1, np.nan)

    @property
    def judged(self) -> NDArray[np.bool_]:
        return self._all(2, False)

    @property
    def detour(self) -> NDArray[np.bool_]:
        return self._all(3, False)

    def _all(self, which: int, missing: float) -> NDArray[Any]:
        values: NDArray[Any] = self.measured[which]
        if self.known is None:
            return values
        found = np.full(self.size, missing, dtype=values.dtype)
        found[self.known] = values
        return found


def track_quality(
    t: FloatArray,
    px: FloatArray,
    py: FloatArray,
    rx: FloatArray,
    ry: FloatArray,
    numbers: MissionNumbers,
    zones: Sequence[Zone],
    timed: bool = False,
    margin: float | None = None,
    placement: Placement | None = None,
) -> dict[str, Any]:
    """The tracking metrics of a track phase's samples (``tracking`` in a phase's
    summary): ``cross_track_error_max`` and ``along_track_lag_max`` (the largest
    |lag|) over the samples judged, ``entry_time`` [s], ``detour_time`` [s] and
    ``detour_offset_max`` [m], with what the defaults of their thresholds read:
    the reference's top speed [m/s] and how far the zones, grown by ``margin``,
    reach into the path [m]. ``timed``: the phase ran for a set time (it ended
    on ``elapsed`` or ``mission_time``), so tracking was all it was for.
    ``margin``: [m] how far the controller keeps off a zone, the body's reach
    and the estimate's uncertainty (the run's ``constraint_margin``); None:
    the body's reach alone. ``placement``: as :func:`track_samples` takes it."""
    return track_samples(
        t, px, py, rx, ry, numbers, zones, timed, margin, placement, with_samples=False
    )[0]  # fmt: skip


def track_samples(
    t: FloatArray,
    px: FloatArray,
    py: FloatArray,
    rx: FloatArray,
    ry: FloatArray,
    numbers: MissionNumbers,
    zones: Sequence[Zone],
    timed: bool = False,
    margin: float | None = None,
    placement: Placement | None = None,
    *,
    with_samples: bool = True,
    known: Known | None = None,
) -> tuple[dict[str, Any], TrackSamples | None]:
    """:func:`track_quality`'s metrics and the samples they come from (None when
    nothing was measured, or not ``with_samples``: a long run's four columns
    not put together for nothing). ``placement``: the places on the path of
    the samples whose reference is known, if at hand (shared with the phase's
    formulas; its positions and reference points are read, not px .. ry);
    ``known``: the samples' :func:`reference_known`, if at hand."""
    these = (reference_known(rx, ry) if known is None else known)[1]
    size = t.size
    metrics: dict[str, Any] = {
        "cross_track_error_max": None,
        "along_track_lag_max": None,
        "entry_time": None,
        "detour_time": 0.0,
        "detour_offset_max": None,
        "reference_speed_max": None,
        "zone_reach": None,
    }
    if these is not None:
        t = t[these]
    if placement is not None:  # the same samples, kept once: a long run's columns are large
        px, py, rx, ry = placement.px, placement.py, placement.path[1], placement.path[2]
    elif these is not None:
        px, py, rx, ry = px[these], py[these], rx[these], ry[these]
    # (a placement's positions are finite)
    if t.size == 0 or (placement is None and not (np.isfinite(px).all() and np.isfinite(py).all())):
        return metrics, None  # no reference, or the run diverged
    dt = numbers.dt
    if placement is None:
        placement = Placement(px, py, rx, ry)
    length = placement.steps[2]
    # [m/s] the reference's first and top speed, of its steps' lengths (no array
    # of speeds: the largest length over dt is the largest of the lengths over dt,
    # as a division by one number keeps their order)
    first_speed, top_speed = 0.0, 0.0
    if t.size > 1:
        first_speed, top_speed = float(length[0]) / dt, placement.longest / dt
    entry = numbers.recovery_time(math.hypot(px[0] - rx[0], py[0] - ry[0]), first_speed)
    # The entry ends sooner once the robot has kept up with its reference point.
    judged, in_entry = _entry_judged(t, entry - 1e-9 * dt, (px, py), (rx, ry), numbers)
    # The entry is a prefix, not judged; a phase that runs for a set time and ends
    # in it (too short for the limits to join the path) is judged at its end.
    after_entry = min(in_entry, t.size - 1)
    ends_in_entry = not judged[-1]
    ended_in_entry = ends_in_entry and timed
    if ends_in_entry and not timed and not zones:  # nothing to measure
        metrics |= {"entry_time": entry, "reference_speed_max": top_speed}
        return metrics, None
    detour = stalled = np.zeros(t.size, dtype=bool)
    if zones:
        kept = numbers.body if margin is None else margin
        reference_speed = _reference_speed(length, dt)
        # the reference's distance along its path (none for one standing still)
        arc = placement.path[0] if not placement.standing else np.zeros(rx.size)
        going = [_goes_round(zone, rx, ry, numbers, kept) for zone in zones]
        # a keep-out zone only the path continued meets: the law may start its
        # ramp round it before the phase's end, no steeper than the ramp
        # (:func:`_ramp_allows`)
        only_ahead = [not g and _size_across(z) > 0.0 for z, g in zip(zones, going, strict=True)]
        ahead = _continued(
            (rx, ry, arc),
            reference_speed,
            [z for z, g, o in zip(zones, going, only_ahead, strict=True) if g or o],
            numbers,
            kept,
        )
        # a zone's reach along the path continued only where the law goes
        # round it, or may ramp towards it: a keep-in region's depth past its
        # edge widened its bound
        reaches = [
            reach_across(zone, *(ahead[:2] if g or o else (rx, ry)))
            for zone, g, o in zip(zones, going, only_ahead, strict=True)
        ]
        detour, stalled, rejoining, ramped = _detours(
            px,
            py,
            ahead[:3],
            ahead[3],
            numbers,
            list(zip(zones, reaches, strict=True)),
            kept,
            (only_ahead, placement),
        )
        judged &= ~(detour | rejoining)
        # a zone only the path continued meets counts where the ramp into it
        # excused a sample, else it widened the bound of another zone's detour
        counted = [r for r, o, u in zip(reaches, only_ahead, ramped, strict=True) if u or not o]
        metrics["zone_reach"] = max(
            0.0, max((float(np.max(r)) for r in counted), default=-math.inf) + kept
        )
    if ended_in_entry:  # (an in-place or of numpy's scalar costs a microsecond)
        judged[-1] = True
    most_cross: float | None
    most_lag: float | None
    if not zones:  # the entry alone is excused, a prefix: the samples after it
        first = after_entry if ended_in_entry or not ends_in_entry else t.size
        cross, lag, most_cross, most_lag = placement.judged_on_path(
            numbers.tracking_tolerance, after_entry, first
        )
    else:
        if detour[:after_entry].any():  # a detour in the entry: from the joining on
            cross, lag = _counted_in_entry(placement, numbers, after_entry, reference_speed)
        else:
            cross, lag = placement.on_path(numbers.tracking_tolerance, after_entry)
        # a robot slowed where a zone blocks its way is judged by its lag (it
        # falls behind) and its offset by the detour's bound, not as tracking
        judged_cross, judged_lag = cross[judged & ~stalled], lag[judged]
        most_cross = float(judged_cross.max()) if judged_cross.size else None
        most_lag = float(np.abs(judged_lag).max()) if judged_lag.size else None
    if zones:
        offset = cross[(detour | stalled) & ~np.isnan(cross)]
        metrics["detour_time"] = float(np.count_nonzero(detour)) * dt
        metrics["detour_offset_max"] = float(offset.max()) if offset.size else None
    # the entry left out: its bound, or to where the robot kept up, where sooner
    # (a time between samples written as `duration` is: 0.49, not 0.4899999999999993)
    left_out = entry
    if after_entry == in_entry and t[in_entry] - t[0] < entry - 1e-9 * dt:
        left_out = round(float(t[in_entry] - t[0]), 9)
    metrics |= {  # (no zone: no detour)
        "cross_track_error_max": most_cross,
        "along_track_lag_max": most_lag,
        "entry_time": left_out,
        "reference_speed_max": top_speed,
    }
    if not with_samples:
        return metrics, None
    # (the samples whose offset the detour's bound judges: its own, and those
    # the robot was slowed at where a zone blocks its way)
    return metrics, TrackSamples(these, size, (cross, lag, judged, detour | stalled))


# The most reference points a phase's path is continued by (:func:`_continued`).
_CONTINUED_AT_MOST = 100_000


def _continued(
    reference: tuple[FloatArray, FloatArray, FloatArray],
    reference_speed: FloatArray,
    zones: Sequence[Zone],
    numbers: MissionNumbers,
    kept: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The phase's reference (its points, their distance along the path) and
    its speed, continued past the phase's last sample straight on at its last
    step, as far as a detour round ``zones`` (those the law goes round,
    :func:`_goes_round`, and the keep-out zones only the path so continued
    meets, :func:`_ramp_allows`) may start before a zone (its ramp, and the
    lead of half a turn and settling): the law aims along
    the path beyond the phase's end, and a phase that ends on the ramp into a
    detour, or in it, was judged as tracking there, against how far the zones
    reach into its own stretch alone (a rock 0.5 m across the path judged by
    the 0.12 m of it before the phase's end: a detour 0.515 m off failed its
    bound of 0.274; a lap ending on the ramp: cross-track 0.35 m where 0.115
    is allowed). A reference that rests at the phase's end is not continued."""
    rx, ry, arc = reference
    step = math.hypot(rx[-1] - rx[-2], ry[-1] - ry[-2]) if rx.size > 1 else 0.0
    across = max((_size_across(zone) for zone in zones), default=0.0)
    if step == 0.0 or across == 0.0:
        return rx, ry, arc, reference_speed
    clearance = numbers.look_ahead + numbers.tracking_tolerance + kept
    lead = math.pi / numbers.omega_limit + SETTLING * numbers.time_constant
    distance = across + (across + clearance) / GENTLE_SLOPE + lead * step / numbers.dt
    count = min(math.ceil(distance / step), _CONTINUED_AT_MOST)
    k = np.arange(1, count + 1, dtype=np.float64)
    ux, uy = (rx[-1] - rx[-2]) / step, (ry[-1] - ry[-2]) / step
    return (
        np.concatenate((rx, rx[-1] + k * step * ux)),
        np.concatenate((ry, ry[-1] + k * step * uy)),
        np.concatenate((arc, arc[-1] + k * step)),
        np.concatenate((reference_speed, np.full(count, reference_speed[-1]))),
    )


def _goes_round(
    zone: Zone, rx: FloatArray, ry: FloatArray, numbers: MissionNumbers, kept: float
) -> bool:
    """Whether the law goes round ``zone`` past the phase's end (the path
    continued, :func:`_continued`): a zone with a way round that the phase's
    own path meets (the runner finds the ways round the zones a phase's path
    meets, and the law goes round those alone); not one only its straight
    continuation would meet: a robot that left its path there was judged
    as detouring round a zone it never went near. The ramp into a keep-out
    zone only the continuation meets excuses no more than it lets the robot
    be off its path (:func:`_ramp_allows`): a phase that ends as the robot
    starts round such a zone (a lap ending 0.5 m before a crate) was judged
    as tracking there, its swerve's start a cross-track error of 0.117 m."""
    if zone.keep_inside or zone.region["type"] == "half-plane" or rx.size < 2:
        return False
    clearance = numbers.look_ahead + numbers.tracking_tolerance + kept
    return bool(np.any(zone.depth(rx, ry, within=clearance) > -clearance))


def _size_across(zone: Zone) -> float:
    """[m] the most a keep-out zone can reach into a path that crosses it: its
    largest extent (0 for a zone kept inside or a half-plane: no way round)."""
    region = zone.region
    kind = region["type"]
    if zone.keep_inside or kind == "half-plane":
        return 0.0
    if kind == "circle":
        return 2.0 * float(region["radius"])
    if kind == "ellipse":
        return 2.0 * float(max(region["semi_axes"]))
    corners = box_corners(region) if kind == "box" else np.asarray(region["vertices"], float)
    return float(np.hypot(*np.ptp(corners, axis=0)))


def _reference_speed(length: FloatArray, dt: float) -> FloatArray:
    """[m/s] from each reference point to the next (the last repeats the one
    before), of the lengths of the path's steps."""
    return np.concatenate((length, length[-1:])) / dt if length.size else np.zeros(1)


def _counted_in_entry(
    placement: Placement,
    numbers: MissionNumbers,
    after_entry: int,
    reference_speed: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Cross-track error and lag [m] of a phase whose entry holds a detour, NaN
    where its entry's samples are the entry's alone: a detour's whole width
    counts, while the gap the phase starts with is the entry's to take out.

    The entry's samples count while the robot tracks its path with its reference
    point straight ahead: from a sample where it is within the tracking tolerance
    of its path, moving across it at no more than the tolerance over the settling
    time (``keeping_up_speed``) and along it at MOVING of the reference's speed
    or more (its velocity from the sample before), until the path bends between
    its place and its reference point. A robot behind its reference heads for it
    and cuts such a bend, the entry's doing, by at most how far the path strays
    from the straight way there (:func:`_chase_bend`): until it is back on its
    path, a sample counts where the robot is farther off than the largest such
    bend since it last tracked, and the tolerance. A robot that starts on its
    path at rest counts once under way; one that starts turned away, or is still
    swinging round, does not."""
    cross, lag = placement.on_path(numbers.tracking_tolerance)
    dt, tolerance = numbers.dt, numbers.tracking_tolerance
    px, py = placement.px[:after_entry], placement.py[:after_entry]
    vx, vy = np.diff(px, prepend=px[:1]) / dt, np.diff(py, prepend=py[:1]) / dt
    ux, uy = placement.direction_at(np.arange(after_entry), lag[:after_entry])
    on_it = (
        (cross[:after_entry] <= tolerance)
        & (np.abs(vx * uy - vy * ux) <= numbers.keeping_up_speed)
        & (vx * ux + vy * uy >= MOVING * reference_speed[:after_entry])
    )
    counts = np.zeros(after_entry, dtype=bool)
    tracking, cut = False, math.inf  # before it first tracks, all is the entry's
    for k in range(int(np.argmax(on_it)) if on_it.any() else after_entry, after_entry):
        bend = _chase_bend(placement, k, float(lag[k]))
        if bend > tolerance:
            tracking, cut = False, max(cut, bend)
        elif on_it[k]:
            tracking, cut = True, 0.0
        counts[k] = tracking or cross[k] > cut + tolerance
    cross[:after_entry][~counts], lag[:after_entry][~counts] = np.nan, np.nan
    return cross, lag


def _chase_bend(placement: Placement, k: int, lag: float) -> float:
    """[m] how far the path between sample ``k``'s place on it and its reference
    point (``lag`` apart along it) strays from the straight way between the two:
    how far off the path a robot that heads for its reference point goes without
    a zone."""
    arc, rx, ry = placement.path[:3]
    if placement.standing or abs(lag) <= 0.0:
        return 0.0
    near, far = sorted((float(arc[k]) - lag, float(arc[k])))
    inner = slice(int(np.searchsorted(arc, near, "right")), int(np.searchsorted(arc, far, "left")))
    ax, ay = float(np.interp(arc[k] - lag, arc, rx)), float(np.interp(arc[k] - lag, arc, ry))
    ux, uy = float(rx[k]) - ax, float(ry[k]) - ay
    chord = math.hypot(ux, uy)
    if chord == 0.0 or inner.start >= inner.stop:
        return 0.0
    return float(np.max(np.abs((rx[inner] - ax) * uy - (ry[inner] - ay) * ux)) / chord)


# Per sample, whether its reference point is known, and those samples as
# :func:`known_samples` picks them (None: every one).
Known = tuple[NDArray[np.bool_], slice | NDArray[np.bool_] | None]


def reference_known(rx: FloatArray, ry: FloatArray) -> Known:
    """Whether each reference point is known (finite), and the samples that are
    (:func:`known_samples`; None where every one is): read by a track phase's
    places, tracking metrics and formulas alike, once."""
    known = np.isfinite(rx) & np.isfinite(ry)
    return known, None if known.all() else known_samples(known)


def placed_known(
    px: FloatArray, py: FloatArray, rx: FloatArray, ry: FloatArray, known: Known | None = None
) -> tuple[Known, Placement | None]:
    """The samples' :func:`reference_known` (``known``, if at hand), and the
    places on the path of those whose reference is known (None where none is,
    or where a position is not finite)."""
    if known is None and rx.size and jit.judging_compiled():
        # Most often every reference point is known: the places' one compiled
        # pass finds it, where numpy's isfinite would look at them first.
        placement = Placement(px, py, rx, ry)
        if placement.known:
            mask = np.empty(rx.size, dtype=bool)
            mask.fill(True)  # (np.ones: twice the cost on a phase's column)
            return (mask, None), placement if placement.finite else None
    known = reference_known(rx, ry) if known is None else known
    if known[1] is not None:
        px, py, rx, ry = px[known[1]], py[known[1]], rx[known[1]], ry[known[1]]
    if rx.size == 0:
        return known, None
    placement = Placement(px, py, rx, ry)
    return known, placement if placement.finite else None


def known_samples(known: NDArray[np.bool_]) -> slice | NDArray[np.bool_]:
    """The samples whose reference is ``known``: a slice where they run
    unbroken (as a phase's do but its last sample), whose columns are views,
    not copies of a long run's."""
    count = int(np.count_nonzero(known))
    first = int(np.argmax(known)) if count else 0  # the first known
    if count and known[first : first + count].all():
        return slice(first, first + count)
    return known


def _detours(
    px: FloatArray,
    py: FloatArray,
    reference: tuple[FloatArray, FloatArray, FloatArray],
    reference_speed: FloatArray,
    numbers: MissionNumbers,
    zones: Sequence[tuple[Zone, FloatArray]],
    kept: float = 0.0,
    ahead_only: tuple[Sequence[bool], Placement] | None = None,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_], list[bool]]:
    """The samples of a detour a zone forces, those the robot was slowed at
    where a zone blocks its way (below MOVING of the reference's speed: it
    falls behind), and those after a detour that the robot needs to rejoin
    its reference; each zone with how far it reaches into the
    path at each reference point (:func:`reach_across`); ``reference``: its
    points and their distance along the path. The zones grown by the body's reach too:
    the robot leaves its path that much sooner, and a polygon body's detour
    (reach 0.36 m), begun 1.4 m before its zone, was judged as tracking for
    its first 0.7 m (cross-track 0.286 m where 0.1 is allowed).

    ``ahead_only``: per zone, whether only the path continued past the
    phase's end meets it, and the samples' places on the path: the ramp into
    such a zone excuses a sample only where the robot is no farther off its
    path than the ramp lets the aim be there (:func:`_ramp_allows`). Last:
    per zone, whether such a ramp excused a sample."""
    rx, ry, travelled = reference
    n = px.size  # the reference may go on past the positions (:func:`_continued`)
    clearance = numbers.look_ahead + numbers.tracking_tolerance + kept
    only = [False] * len(zones) if ahead_only is None else list(ahead_only[0])
    ramped = [False] * len(zones)
    blocked = np.zeros(rx.size, dtype=bool)
    for fraction in _WAY_POINTS:
        qx, qy = px + fraction * (rx[:n] - px), py + fraction * (ry[:n] - py)
        for zone, _ in zones:
            blocked[:n] |= zone.depth(qx, qy, within=clearance) > -clearance
    on_the_path = np.zeros(rx.size, dtype=bool)
    lead = (math.pi / numbers.omega_limit + SETTLING * numbers.time_constant) / numbers.dt
    cross: FloatArray | None = None
    # the samples on a ramp into such a zone farther off than it allows: off
    # the path, not rejoining it after a detour
    refused = np.zeros(n, dtype=bool)
    for index, (zone, reach) in enumerate(zones):
        near = zone.depth(rx, ry, within=clearance) > -clearance
        if reach.size == n:
            # not gone round past the phase's end (_goes_round): where the
            # phase's own path meets it, if it does
            near[n:] = False
        if only[index] and ahead_only is not None:
            near[:n] = False  # (none: the phase's own path does not meet it)
            ramp = (_ramps(near, travelled, reach + clearance) | _any_within(near, round(lead)))[:n]
            if not ramp.any():
                continue
            if cross is None:  # the places of the samples at the phase's end alone
                cross = ahead_only[1].on_path(numbers.tracking_tolerance, int(np.argmax(ramp)))[0]
            allows = _ramp_allows(zone, reference, numbers, kept, n, float(reference_speed[n - 1]))
            excused = ramp & (cross <= allows)
            ramped[index] = bool(excused.any())
            blocked[:n] |= excused
            refused[ramp & ~excused] = True
            continue
        if zone.keep_inside or zone.region["type"] == "half-plane":
            on_the_path |= near
            continue  # no way round: it is kept along its edge
        on_the_path |= near
        # A gentle detour round a keep-out zone leaves its path, and comes back
        # to it, on a ramp of GENTLE_SLOPE: as far before and after the zone as
        # that takes to clear it. A slow robot's half turn covers less ground (a lawn mower at 0.15
        # m/s round a tank was judged as tracking on both ramps: 0.328 m off,
        # where 0.11 is allowed; tests/test_detour_ramp.py).
        blocked |= _ramps(near, travelled, reach + clearance)
    # A smooth detour starts before the path meets the zone: half a turn and settling ahead.
    blocked |= _any_within(on_the_path, round(lead))
    blocked = blocked[:n]
    window = max(1, round(MOVING_WINDOW * numbers.time_constant / numbers.dt))
    speed = _speed(px, py, numbers.dt)
    moving = _mean_over(speed, window) >= MOVING * _mean_over(reference_speed[:n], window)
    detour = blocked & moving
    stalled = blocked & ~moving
    rejoining = np.zeros(n, dtype=bool)
    # A stretch the robot detoured in is rejoined after it; one it did not (a
    # robot far behind its reference in its entry, a zone between the two)
    # took it off nothing: a gap of 4.4 m there excused the rest of a phase
    # that ended 4.08 m from its reference (tests/test_detour_in_entry.py).
    edges = np.flatnonzero(np.diff(blocked, prepend=False, append=False))
    for start, k in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        if k >= n or refused[k] or not detour[start:k].any():
            continue
        gap = math.hypot(px[k] - rx[k], py[k] - ry[k])
        needed = numbers.recovery_time(gap, float(reference_speed[k]))
        end = min(int(k) + math.ceil(needed / numbers.dt - 1e-9), px.size)
        back = _kept_up(px, py, rx[:n], ry[:n], numbers, int(k), end)
        rejoining[k : end if back is None else back] = True
    return detour, stalled, rejoining, ramped


def _ramp_allows(
    zone: Zone,
    reference: tuple[FloatArray, FloatArray, FloatArray],
    numbers: MissionNumbers,
    kept: float,
    n: int,
    speed: float,
) -> FloatArray:
    """[m] How far off its path a robot may be at each of the phase's ``n``
    samples on the ramp into ``zone``, a keep-out zone only the path
    continued past the phase's end meets (:func:`_continued`: straight on
    from its last point, ``reference``: the points and their distance along
    the path continued): the aim, the look-ahead and a time constant's
    travel past the reference point, is moved across the path to the side
    away from the zone's centre no further than the zone, grown by twice the
    look-ahead and the margin (the filter's bound and the aim's gap beyond
    it, at most the look-ahead), reaches out of the wedge of the ramp's
    slope (constrained_tracking ``RAMP_SLOPE``) about the path's line, or
    under a turn-rate acceleration limit the climb that eases it; the robot
    tracks the aim within the tracking tolerance; no more. A robot 0.5 m
    off its path 0.7 m before a rock's edge is off its path: the ramp lets
    the aim be 0.16 m across there."""
    rx, ry, travelled = reference
    ux, uy = rx[n] - rx[n - 1], ry[n] - ry[n - 1]
    step = math.hypot(ux, uy)
    ux, uy = ux / step, uy / step
    ex, ey, end = float(rx[n - 1]), float(ry[n - 1]), float(travelled[n - 1])
    grown = 2.0 * numbers.look_ahead + kept
    cx, cy = _zone_centre(zone)
    # the side away from the zone's centre; through it, the left of travel
    side = -1.0 if (cx - ex) * -uy + (cy - ey) * ux > 0.0 else 1.0
    mx, my = -uy * side, ux * side
    # the zone's top across the line, and the wedge's: its support across
    # less the ramp's slope along, from the path's end
    top = _support(zone, mx, my) - (ex * mx + ey * my) + grown
    wx, wy = mx - GENTLE_SLOPE * ux, my - GENTLE_SLOPE * uy
    foot = _support(zone, wx, wy) - (ex * wx + ey * wy) + grown * math.hypot(wx, wy)
    top = max(top, 0.0)
    # the aim's offset is taken a time constant ahead along the path
    aim = travelled[:n] + numbers.look_ahead + numbers.time_constant * speed - end
    if math.isfinite(numbers.omega_acceleration) and speed > 0.0 and top > 0.0:
        # under a turn-rate acceleration limit the aim climbs as the limit
        # lets the robot turn onto the ramp: its slope grows over a stretch
        # at each end, so the climb starts that much sooner than the ramp
        bend = TURNABLE_SHARE * numbers.omega_acceleration / (speed * speed)
        stretch = min(math.sqrt(GENTLE_SLOPE / bend), (0.5 * top / bend) ** (1.0 / 3.0))
        aim = aim + 2.0 * stretch + top / (bend * stretch * stretch) - top / GENTLE_SLOPE
    across: FloatArray = np.clip(foot + GENTLE_SLOPE * aim, 0.0, top)
    return across + numbers.tracking_tolerance


def _zone_centre(zone: Zone) -> tuple[float, float]:
    region = zone.region
    if region["type"] in ("circle", "ellipse"):
        return float(region["center"][0]), float(region["center"][1])
    corners = (
        box_corners(region) if region["type"] == "box" else np.asarray(region["vertices"], float)
    )
    return float(np.mean(corners[:, 0])), float(np.mean(corners[:, 1]))


def _support(zone: Zone, nx: float, ny: float) -> float:
    """The keep-out zone's support function along (nx, ny): the most of
    (nx, ny) . q over its points q."""
    region = zone.region
    kind = region["type"]
    if kind in ("circle", "ellipse"):
        cx, cy = (float(v) for v in region["center"])
        if kind == "circle":
            a = b = float(region["radius"])
            rotation = 0.0
        else:
            a, b = (float(v) for v in region["semi_axes"])
            rotation = float(region.get("rotation") or 0.0)
        c, s = math.cos(rotation), math.sin(rotation)
        nu, nw = c * nx + s * ny, -s * nx + c * ny
        return cx * nx + cy * ny + math.sqrt(a * a * nu * nu + b * b * nw * nw)
    corners = box_corners(region) if kind == "box" else np.asarray(region["vertices"], float)
    return float(np.max(corners[:, 0] * nx + corners[:, 1] * ny))


def _kept_up(
    px: FloatArray,
    py: FloatArray,
    rx: FloatArray,
    ry: FloatArray,
    numbers: MissionNumbers,
    begin: int,
    end: int,
) -> int | None:
    """The first sample of ``begin`` .. ``end`` - 1 by which the robot has kept up
    with its reference point for SETTLING time constants: at each of those
    samples within the tracking tolerance of it, their velocities (from the
    sample before; none before the first) apart by at most ``keeping_up_speed``
    and by no more than MOVING of the reference's speed. None if there is none."""
    tolerance, dt = numbers.tracking_tolerance, numbers.dt
    window = _settling_window(numbers)
    if jit.judging_compiled():  # the same sample in one compiled pass (verdicts/passes.py)
        sample = jit.compiled(kept_up)(
            (px, py), (rx, ry), (begin, end, window), tolerance, MOVING,
            numbers.keeping_up_speed * dt, _NO_ENTRY,
        )[0]  # fmt: skip
        return None if sample < 0 else sample
    first = max(begin - window, 0)  # the window's first sample's one before, if any
    if end <= first:
        return None
    ex, ey = px[first:end] - rx[first:end], py[first:end] - ry[first:end]
    with_it = np.hypot(ex, ey) <= tolerance
    if np.count_nonzero(with_it) < window:  # never near it for long enough
        return None
    apart = np.hypot(np.diff(ex), np.diff(ey))
    # ... and moving with it: apart by no more than MOVING of the reference's own
    # speed too, or a robot at rest would keep up with a slow reference
    moved = MOVING * np.hypot(np.diff(rx[first:end]), np.diff(ry[first:end]))
    with_it[1:] &= apart <= np.minimum(moved, numbers.keeping_up_speed * dt)
    if first > 0:  # the sample before the window: there for its first one's velocity
        with_it[0] = False
    # runs of samples with it: each has kept up from its start + window - 1 on
    off = np.flatnonzero(~with_it)
    starts = np.concatenate(([0], off + 1))
    stops = np.concatenate((off, [with_it.size]))
    ready = np.maximum(starts + window - 1, begin - first)
    found = np.flatnonzero(ready < stops)
    return first + int(ready[found[0]]) if found.size else None


# No entry to find with the sample kept up from (passes.kept_up).
_NO_ENTRY = (np.zeros(0), 0.0, np.zeros(0, dtype=bool))


def _settling_window(numbers: MissionNumbers) -> int:
    """The samples of SETTLING time constants (one at least): how long a robot
    keeps up before it has (:func:`_kept_up`)."""
    return max(1, round(SETTLING * numbers.time_constant / numbers.dt))


def _entry_judged(
    t: FloatArray,
    bound: float,
    position: tuple[FloatArray, FloatArray],
    reference: tuple[FloatArray, FloatArray],
    numbers: MissionNumbers,
) -> tuple[NDArray[np.bool_], int]:
    """The samples in the entry, their time since the first below ``bound`` [s]
    until the robot has kept up with its reference point (:func:`_kept_up`):
    whether each is judged (not in it), and how many are in it."""
    (px, py), (rx, ry) = position, reference
    if jit.judging_compiled():  # the same samples in one compiled pass (verdicts/passes.py)
        judged = np.empty(t.size, dtype=bool)
        count: int = jit.compiled(kept_up)(
            position, reference, (0, 0, _settling_window(numbers)), numbers.tracking_tolerance,
            MOVING, numbers.keeping_up_speed * numbers.dt, (t, bound, judged),
        )[1]  # fmt: skip
        return judged, count
    excused = t - t[0] < bound
    kept = _kept_up(px, py, rx, ry, numbers, 0, int(np.count_nonzero(excused)))
    if kept is not None:
        excused[kept:] = False
    return ~excused, int(np.count_nonzero(excused))
