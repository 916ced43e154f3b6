"""Routes made of straight legs and corners: ``polyline`` and ``coverage`` paths.

A route is a sequence of pieces traversed one after the other in phase-local
time: straight legs and circular corner arcs at the route's speed, and turns in
place at its turn rate. Each corner arc is tangent to both legs it joins, so it
lies inside the angle of its corner: a route never leaves the convex hull of
its points (``docs/mission-format.md``, "Paths").

A coverage path is a route over the lane ends of a boustrophedon (lawnmower)
pattern: parallel lanes across a convex field, run alternately forwards and
backwards, joined at their ends by the corner arcs of the turn radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import scalar_math

__all__ = [
    "ROUTE_ACCELERATION_SHARE",
    "TURN_CREEP",
    "RouteTrajectory",
    "coverage_points",
    "distinct_points",
    "polyline_route",
]

Sample = tuple[FloatArray, FloatArray, FloatArray, FloatArray]

LEG = 0  # start x, y; unit direction x, y; length
ARC = 1  # centre x, y; radius; start angle; signed sweep
TURN = 2  # point x, y; start heading; signed turn angle

# During a turn in place the position holds; the velocity is this small speed
# [m/s] along the heading being turned to, so that the reference keeps a
# direction for the tracking output to aim along (a zero velocity has none).
TURN_CREEP = 1e-9

# The share of the robot's speed acceleration a route slows down and speeds up
# at about its stops; the rest is the controller's to correct errors with.
ROUTE_ACCELERATION_SHARE = 0.5

# Corners turning less than this [rad] are straight through.
_STRAIGHT = 1e-9


@dataclass(frozen=True)
class RouteTrajectory:
    """Pieces (kind, 5 parameters, duration) traversed in order from ``start_time``.

    An open route holds its last point after the end; a closed route loops.
    ``points`` are the vertices the route was drawn through (for figures).
    """

    kinds: NDArray[np.int64]  # (n,)
    parameters: FloatArray  # (n, 5)
    durations: FloatArray  # (n,) [s]
    speed: float
    turn_rate: float
    closed: bool
    points: FloatArray  # (m, 2)
    start_time: float = 0.0
    # Per piece, for a leg that speeds up or slows down (_ramped): its speed at
    # entry, at most, at exit, and its acceleration; None: every leg at `speed`.
    profiles: FloatArray | None = None
    period: float = field(init=False)
    _ends: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        ends = np.cumsum(self.durations)
        object.__setattr__(self, "_ends", ends)
        object.__setattr__(self, "period", float(ends[-1]) if len(ends) else 0.0)

    def sample(self, t: ArrayLike) -> Sample:
        time = np.asarray(t, dtype=np.float64) + self.start_time
        shape = time.shape  # sampled flat (a mask per kind of piece), returned as t is
        time = time.ravel()
        if self.closed and self.period > 0.0:
            time = np.mod(time, self.period)
        moving = (time >= 0.0) & (time < self.period)
        time = np.clip(time, 0.0, self.period)
        piece = np.clip(np.searchsorted(self._ends, time, side="right"), 0, len(self.kinds) - 1)
        local = time - (self._ends[piece] - self.durations[piece])
        kind = self.kinds[piece]
        p = self.parameters[piece]
        x = np.empty(time.shape)
        y = np.empty(time.shape)
        vx = np.empty(time.shape)
        vy = np.empty(time.shape)
        # Each kind of piece computed only where the times fall on one, and
        # without a mask where all do: a call's fixed cost is most of what a
        # run's paths ahead cost (the empty arcs and turns alone 25 us of
        # keep-out's 70 us per call).
        present = np.bincount(kind, minlength=3)
        every = slice(None)
        if present[LEG]:
            leg = every if present[LEG] == kind.size else kind == LEG
            if self.profiles is None:
                distance = self.speed * local[leg]
                speed = np.full(distance.shape, self.speed)
            else:
                distance, speed = _along_leg(
                    self.profiles[piece[leg]], local[leg], self.durations[piece[leg]]
                )
            x[leg] = p[leg, 0] + p[leg, 2] * distance
            y[leg] = p[leg, 1] + p[leg, 3] * distance
            vx[leg] = speed * p[leg, 2]
            vy[leg] = speed * p[leg, 3]
        if present[ARC]:
            arc = every if present[ARC] == kind.size else kind == ARC
            radius = p[arc, 2]
            direction = np.sign(p[arc, 4])
            angle = p[arc, 3] + direction * self.speed * local[arc] / radius
            cos, sin = scalar_math.cos(angle), scalar_math.sin(angle)
            x[arc] = p[arc, 0] + radius * cos
            y[arc] = p[arc, 1] + radius * sin
            vx[arc] = -direction * self.speed * sin
            vy[arc] = direction * self.speed * cos
        if present[TURN]:
            turn = every if present[TURN] == kind.size else kind == TURN
            heading = p[turn, 2] + np.sign(p[turn, 3]) * self.turn_rate * local[turn]
            x[turn] = p[turn, 0]
            y[turn] = p[turn, 1]
            vx[turn] = TURN_CREEP * scalar_math.cos(heading)
            vy[turn] = TURN_CREEP * scalar_math.sin(heading)
        vx = np.where(moving, vx, 0.0)
        vy = np.where(moving, vy, 0.0)
        return x.reshape(shape), y.reshape(shape), vx.reshape(shape), vy.reshape(shape)

    def nearest_time(self, x: float, y: float) -> float:
        """Route time of the point nearest to (x, y), to 1 mm of route or better."""
        length = self.period * self.speed
        count = int(min(200_001, max(1001, length / 0.001)))
        times = np.linspace(0.0, self.period, count)
        px, py, _, _ = self.sample(times - self.start_time)
        return float(times[int(np.argmin(np.hypot(px - x, py - y)))])


def _along_leg(
    profile: FloatArray, local: FloatArray, duration: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Distance and speed along legs of trapezoidal speed (``profile`` rows:
    entry speed, top speed, exit speed, acceleration) at their local times."""
    entry, top, leave, rate = profile[:, 0], profile[:, 1], profile[:, 2], profile[:, 3]
    rising = (top - entry) / rate
    falling = (top - leave) / rate
    left = duration - local  # time to the leg's end
    length = top * (duration - rising - falling) + 0.5 * (top + entry) * rising
    length += 0.5 * (top + leave) * falling
    distance = np.where(
        local < rising,
        entry * local + 0.5 * rate * local * local,
        np.where(
            left < falling,
            length - leave * left - 0.5 * rate * left * left,
            0.5 * (top + entry) * rising + top * (local - rising),
        ),
    )
    speed = np.where(
        local < rising, entry + rate * local, np.where(left < falling, leave + rate * left, top)
    )
    return distance, speed


def _ramped(
    kinds: list[int], lengths: list[float], speed: float, closed: bool, acceleration: float
) -> tuple[FloatArray, FloatArray]:
    """Each leg's speed profile (entry, top, exit speed, acceleration) and
    duration when the route stops where it turns in place and at its end
    (an open route's), at ``acceleration``: from rest up to ``speed`` and down
    again, no sudden stop a robot with that acceleration limit cannot make.
    A leg too short to brake on from ``speed`` brakes harder."""
    count = len(kinds)
    profiles = np.zeros((count, 4))
    durations = np.zeros(count)
    for i, kind in enumerate(kinds):
        if kind != LEG:
            continue
        before = kinds[i - 1] if i > 0 or closed else None
        after = kinds[(i + 1) % count] if i + 1 < count or closed else None
        entry = 0.0 if before == TURN else speed
        leave = 0.0 if after in (TURN, None) else speed
        length = lengths[i]
        rate = acceleration
        top = min(speed, math.sqrt(rate * length + 0.5 * (entry * entry + leave * leave)))
        if top < max(entry, leave):  # one speed change at speed, too short for it
            rate = 0.5 * speed * speed / length
            top = speed
        rising = (top - entry) / rate
        falling = (top - leave) / rate
        ramps = 0.5 * (top + entry) * rising + 0.5 * (top + leave) * falling
        profiles[i] = (entry, top, leave, rate)
        durations[i] = rising + falling + max(length - ramps, 0.0) / top
    return profiles, durations


def distinct_points(points: ArrayLike, closed: bool) -> FloatArray:
    """Drop consecutive repeats (and a closing repeat of the first point)."""
    array = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    keep = np.ones(len(array), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(array, axis=0)) > 1e-12, axis=1)
    distinct = array[keep]
    if closed and len(distinct) > 1 and np.all(np.abs(distinct[-1] - distinct[0]) <= 1e-12):
        distinct = distinct[:-1]
    return distinct


def _unit(vector: FloatArray) -> FloatArray:
    unit: FloatArray = vector / math.hypot(float(vector[0]), float(vector[1]))
    return unit


def _corner(
    before: FloatArray, vertex: FloatArray, after: FloatArray, radius: float, longest_cut: float
) -> tuple[FloatArray, FloatArray, tuple[int, list[float]] | None]:
    """Entry point, exit point and the piece of the corner at ``vertex``.

    The arc's tangent length ``radius * tan(|turn| / 2)`` may use at most half
    of each leg it cuts, so neighbouring corners never overlap, and at most
    ``longest_cut``: a radius that does not fit shrinks to the largest that
    does. A corner with no room for an arc (a reversal, or ``radius = 0``) is a
    turn in place.
    """
    incoming, outgoing = vertex - before, after - vertex
    e_in, e_out = _unit(incoming), _unit(outgoing)
    cross = float(e_in[0] * e_out[1] - e_in[1] * e_out[0])
    # written out, not np.dot: BLAS's kernels, chosen by CPU, may fuse a multiply-add
    dot = float(e_in[0] * e_out[0] + e_in[1] * e_out[1])
    turn = math.atan2(cross, dot)
    if abs(turn) < _STRAIGHT:
        return vertex, vertex, None
    room = min(0.5 * float(np.hypot(*incoming)), 0.5 * float(np.hypot(*outgoing)), longest_cut)
    half = math.tan(0.5 * abs(turn))
    fitted = min(radius, room / half) if math.isfinite(half) else 0.0
    if fitted <= 1e-9:
        heading = math.atan2(float(e_in[1]), float(e_in[0]))
        return vertex, vertex, (TURN, [float(vertex[0]), float(vertex[1]), heading, turn, 0.0])
    tangent = fitted * half
    entry, exit_ = vertex - tangent * e_in, vertex + tangent * e_out
    side = math.copysign(1.0, turn)  # centre to the left for a left turn
    centre = entry + side * fitted * np.array([-e_in[1], e_in[0]])
    start = math.atan2(float(entry[1] - centre[1]), float(entry[0] - centre[0]))
    return entry, exit_, (ARC, [float(centre[0]), float(centre[1]), fitted, start, turn])


def polyline_route(
    points: ArrayLike,
    speed: float,
    closed: bool,
    corner_radius: float,
    turn_rate: float,
    longest_cut: float = math.inf,
    acceleration: float = math.inf,
) -> RouteTrajectory:
    """Straight legs through ``points`` at ``speed``, corners rounded by arcs of
    ``corner_radius`` (or turned in place at ``turn_rate`` when it is 0); an arc
    cuts at most ``longest_cut`` off each leg. With a finite ``acceleration``
    [m/s^2] the legs slow down at it into each turn in place and into the end
    of an open route, and speed up out of a turn (_ramped).

    A closed route starts where it leaves the first point's corner and ends
    where it enters it again.
    """
    vertices = distinct_points(points, closed)
    n = len(vertices)
    closed = closed and n > 1
    if n == 1:
        p = [float(vertices[0, 0]), float(vertices[0, 1]), 1.0, 0.0, 0.0]
        return RouteTrajectory(
            np.array([LEG]), np.array([p]), np.array([0.0]), speed, turn_rate, False, vertices
        )
    corners = range(n) if closed else range(1, n - 1)
    entries = {i: vertices[i] for i in range(n)}
    exits = dict(entries)
    pieces: dict[int, tuple[int, list[float]]] = {}
    for i in corners:
        entries[i], exits[i], piece = _corner(
            vertices[i - 1], vertices[i], vertices[(i + 1) % n], corner_radius, longest_cut
        )
        if piece is not None:
            pieces[i] = piece
    kinds: list[int] = []
    parameters: list[list[float]] = []
    durations: list[float] = []
    lengths: list[float] = []
    legs = range(n) if closed else range(n - 1)
    for i in legs:
        j = (i + 1) % n
        start, end = exits[i], entries[j]
        length = float(np.hypot(*(end - start)))
        if length > 1e-12:
            direction = _unit(end - start)
            kinds.append(LEG)
            parameters.append(
                [float(start[0]), float(start[1]), float(direction[0]), float(direction[1]), 0.0]
            )
            durations.append(length / speed)
            lengths.append(length)
        if j in pieces:
            kind, values = pieces[j]
            kinds.append(kind)
            parameters.append(values)
            lengths.append(0.0)
            if kind == ARC:
                durations.append(values[2] * abs(values[4]) / speed)
            else:
                durations.append(abs(values[3]) / turn_rate)
    profiles = None
    times = np.array(durations, dtype=np.float64)
    if math.isfinite(acceleration):
        profiles, ramped = _ramped(kinds, lengths, float(speed), closed, acceleration)
        legs_at = np.array(kinds) == LEG
        times[legs_at] = ramped[legs_at]
    return RouteTrajectory(
        np.array(kinds, dtype=np.int64),
        np.array(parameters, dtype=np.float64),
        times,
        float(speed),
        float(turn_rate),
        closed,
        vertices,
        profiles=profiles,
    )


# Most lanes a coverage path may have: its lane ends are at most the 10 000
# points a polyline may list (a field of a billion metres at a micrometre's
# spacing would be built lane by lane for hours).
MAX_LANES = 5000


def _across(corners: FloatArray, direction: float) -> tuple[float, float]:
    """The least and the largest offset of the field's ``corners`` across lanes
    along ``direction``."""
    offsets = corners[:, 0] * -math.sin(direction) + corners[:, 1] * math.cos(direction)
    return float(offsets.min()), float(offsets.max())  # not BLAS: see _corner


def coverage_lanes(vertices: ArrayLike, spacing: float, direction: float) -> int:
    """How many lanes :func:`coverage_points` lays over the field of corners
    ``vertices`` at ``spacing`` along ``direction``."""
    return _lanes(*_across(np.asarray(vertices, dtype=np.float64), direction), spacing)


def _lanes(low: float, high: float, spacing: float) -> int:
    """Lanes across ``low .. high`` at most ``spacing`` apart (more than
    MAX_LANES where the count is beyond a float's)."""
    lanes = (high - low) / spacing - 1e-9
    return max(1, math.ceil(lanes)) if math.isfinite(lanes) else MAX_LANES + 1


def coverage_points(
    vertices: ArrayLike, rows: ArrayLike, spacing: float, direction: float
) -> FloatArray:
    """Lane ends of a boustrophedon over a convex field, in the order driven.

    ``vertices`` are the field's corners and ``rows`` its outward half-plane
    rows ``nx, ny, offset`` (``regions``). Lanes run along ``direction`` [rad];
    ``ceil(width / spacing)`` of them, evenly spread so that every point of the
    field is at most half a lane spacing across from a lane: the first and
    last lie half a spacing inside the field's extremes. Each lane ends on the
    field's boundary; the first runs along ``direction``, the next back.
    """
    corners = np.asarray(vertices, dtype=np.float64)
    edges = np.asarray(rows, dtype=np.float64)
    along = np.array([math.cos(direction), math.sin(direction)])
    across = np.array([-along[1], along[0]])
    low, high = _across(corners, direction)
    count = _lanes(low, high, spacing)
    if count > MAX_LANES:
        raise ValueError(f"{count} lanes, more than {MAX_LANES}: widen the spacing")
    step = (high - low) / count
    ends: list[FloatArray] = []
    for lane in range(count):
        offset = low + step * (lane + 0.5)
        # the lane p = offset * across + s * along, clipped to n . p <= c
        first, last = -math.inf, math.inf
        for nx, ny, c in edges:
            rate = nx * along[0] + ny * along[1]
            room = c - offset * (nx * across[0] + ny * across[1])
            if abs(rate) < 1e-15:
                if room < 0.0:
                    first, last = math.inf, -math.inf
                continue
            bound = room / rate
            if rate > 0.0:
                last = min(last, bound)
            else:
                first = max(first, bound)
        if not last - first > 1e-9:
            continue
        a, b = offset * across + first * along, offset * across + last * along
        ends.extend([a, b] if len(ends) % 4 == 0 else [b, a])
    return np.array(ends, dtype=np.float64).reshape(-1, 2)
