"""A smooth (C1) curve through points at constant speed, kept close to their convex hull."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from wmr_mission.basics import FloatArray
from wmr_mission.fields import Flag, Model, Point, PositiveScalar
from wmr_mission.geometry.paths.line import LineTrajectory
from wmr_mission.geometry.paths.registry import Context, PathType, Pose, Sample, times
from wmr_mission.geometry.routes import distinct_points

# Dense arc-length table of a waypoint curve: samples per segment.
_TABLE_SAMPLES_PER_SEGMENT = 128


class WaypointsPath(Model):
    """A smooth (C1) curve through the points at constant speed, kept close to their
    convex hull."""

    type: Literal["waypoints"] = Field(description="Path kind.")
    points: list[Point] = Field(
        min_length=2, max_length=10000, description="At least 2 points [[x, y], ...] [m]."
    )
    speed: PositiveScalar = Field(description="Speed along the curve [m/s], > 0.")
    start: Literal["current", "first"] = Field(
        default="current",
        description=(
            "current: an open curve starts at the robot's position, a closed one where it "
            "passes nearest the robot; first: at the first point."
        ),
    )
    closed: Flag = Field(default=False, description="Return to the first point and loop.")


@dataclass(frozen=True)
class WaypointsTrajectory:
    """A C1 piecewise cubic through the points, traversed at constant speed.

    The curve is parametrised by cumulative chord length and keeps close to the
    points' convex hull (``_bezier_coefficients`` bounds how close). A dense
    table of arc length against the curve parameter, built once, turns the
    distance travelled ``speed * t`` into a curve parameter by cubic Hermite
    interpolation (the slopes are the exact ``1 / |dp/ds|``), so the velocity
    returned is the exact derivative of the positions returned and its magnitude
    is ``speed`` to table accuracy. An open path holds its last point with zero
    velocity after the end; a closed one loops, starting ``start_distance``
    along the curve from its first point.
    """

    knots: FloatArray  # (m + 1,) chord-length parameter of each point
    coefficients: FloatArray  # (m, 4, 2) cubic coefficients per segment, highest power first
    table_length: FloatArray  # (n,) arc length at each table entry ...
    table_parameter: FloatArray  # ... the spline parameter there ...
    # d(parameter)/d(arc length) at the start and end of each table interval: the
    # curve is only G1 at its points, so the two sides of a point differ
    table_slope_start: FloatArray  # (n - 1,)
    table_slope_end: FloatArray  # (n - 1,)
    speed: float
    closed: bool
    points: FloatArray  # (m, 2) the points the curve passes through (for figures)
    start_distance: float = 0.0
    length: float = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "length", float(self.table_length[-1]))

    def sample(self, t: ArrayLike) -> Sample:
        time = times(t)
        distance = self.speed * time + self.start_distance
        if self.closed:
            distance = np.mod(distance, self.length)
        moving = (distance < self.length) & (distance >= 0.0)
        distance = np.clip(distance, 0.0, self.length)
        parameter, slope = self._parameter_at(distance)
        position, tangent = _evaluate_spline(self.knots, self.coefficients, parameter)
        factor = np.where(moving, self.speed * slope, 0.0)[..., None]
        velocity = tangent * factor
        return position[..., 0], position[..., 1], velocity[..., 0], velocity[..., 1]

    def _parameter_at(self, distance: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Spline parameter at arc length ``distance`` and its derivative (cubic Hermite)."""
        lengths, parameters = self.table_length, self.table_parameter
        j = np.clip(np.searchsorted(lengths, distance, side="right") - 1, 0, len(lengths) - 2)
        h = lengths[j + 1] - lengths[j]
        tau = (distance - lengths[j]) / h
        p0, p1 = parameters[j], parameters[j + 1]
        m0, m1 = h * self.table_slope_start[j], h * self.table_slope_end[j]
        tau2 = tau * tau
        tau3 = tau2 * tau
        parameter = (
            (2 * tau3 - 3 * tau2 + 1) * p0
            + (tau3 - 2 * tau2 + tau) * m0
            + (3 * tau2 - 2 * tau3) * p1
            + (tau3 - tau2) * m1
        )
        derivative = (
            (6 * tau2 - 6 * tau) * p0
            + (3 * tau2 - 4 * tau + 1) * m0
            + (6 * tau - 6 * tau2) * p1
            + (3 * tau2 - 2 * tau) * m1
        ) / h
        return parameter, derivative


def _evaluate_spline(
    knots: FloatArray,
    coefficients: FloatArray,
    parameter: FloatArray,
    segment: NDArray[np.intp] | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Positions ``(..., 2)`` and derivatives ``(..., 2)`` of a piecewise cubic, on
    the given segments (by default the segment each parameter falls in)."""
    if segment is None:
        segment = np.clip(np.searchsorted(knots, parameter, side="right") - 1, 0, len(knots) - 2)
    local = (parameter - knots[segment])[..., None]
    c = coefficients[segment]  # (..., 4, 2)
    position = ((c[..., 0, :] * local + c[..., 1, :]) * local + c[..., 2, :]) * local + c[..., 3, :]
    derivative = (3.0 * c[..., 0, :] * local + 2.0 * c[..., 1, :]) * local + c[..., 2, :]
    return position, derivative


def _bezier_coefficients(points: FloatArray, closed: bool) -> tuple[FloatArray, FloatArray]:
    """Cubic through ``points`` in chord length that keeps close to their hull:
    ``(knots, coefficients)``.

    Each segment is a cubic Bezier curve from P_i to P_i+1 whose inner control
    points lie on the tangents at its ends: the tangent at a point bisects the
    turn of the two chords meeting there (along the chord at the ends of an
    open curve), and its arm is a third of the shorter of those chords. A
    Bezier curve lies in the convex hull of its control points, and an arm
    ``a`` at a turn of angle ``phi`` ends within ``a sin(phi / 2)`` of the
    chord it turns to; so the curve never leaves the hull of the points by
    more than the largest ``min(chord before, chord after) / 3 * sin(phi / 2)``.
    (No smooth curve stays inside the hull at a point where it turns: its
    tangent there points out of the hull on one side.)
    """
    nodes = np.vstack([points, points[:1]]) if closed else points
    chords = np.diff(nodes, axis=0)
    steps = np.hypot(*chords.T)  # (m,)
    knots = np.concatenate([[0.0], np.cumsum(steps)])
    m = len(steps)
    units = chords / steps[:, None]
    count = len(points)
    tangents = np.empty((count, 2))
    arms = np.empty(count)
    for i in range(count):
        if not closed and i in (0, count - 1):
            segment = 0 if i == 0 else m - 1
            tangents[i], arms[i] = units[segment], steps[segment] / 3.0
            continue
        before, after = (i - 1) % m, i % m
        bisector = units[before] + units[after]
        norm = math.hypot(float(bisector[0]), float(bisector[1]))
        if norm < 1e-12:  # the route reverses: leave square to it
            bisector, norm = np.array([-units[before][1], units[before][0]]), 1.0
        tangents[i] = bisector / norm
        arms[i] = min(steps[before], steps[after]) / 3.0
    if closed:
        tangents, arms = np.vstack([tangents, tangents[:1]]), np.concatenate([arms, arms[:1]])
    start, end = nodes[:-1], nodes[1:]
    inner_start = start + arms[:-1, None] * tangents[:-1]
    inner_end = end - arms[1:, None] * tangents[1:]
    h = steps[:, None]
    h2 = (
        h * h
    )  # products, not h**3: numpy's power is chosen by CPU (wmr_mission.kernels.scalar_math)
    coefficients = np.empty((m, 4, 2))
    # Bezier to power basis in the local chord-length parameter s = u h
    coefficients[:, 0] = (-start + 3.0 * inner_start - 3.0 * inner_end + end) / (h2 * h)
    coefficients[:, 1] = (3.0 * start - 6.0 * inner_start + 3.0 * inner_end) / h2
    coefficients[:, 2] = 3.0 * (inner_start - start) / h
    coefficients[:, 3] = start
    return knots, coefficients


def waypoints_trajectory(
    points: ArrayLike, speed: float, closed: bool
) -> WaypointsTrajectory | LineTrajectory:
    """The constant-speed spline through ``points``; a single point is held still."""
    distinct = distinct_points(points, closed)
    if len(distinct) == 1:
        return LineTrajectory(float(distinct[0, 0]), float(distinct[0, 1]), 0.0, 0.0)
    knots, coefficients = _bezier_coefficients(distinct, closed)
    segments = len(coefficients)
    parameter = np.concatenate(
        [
            np.linspace(knots[i], knots[i + 1], _TABLE_SAMPLES_PER_SEGMENT, endpoint=False)
            for i in range(segments)
        ]
        + [knots[-1:]]
    )
    # Simpson's rule on each table interval: arc length to about 1e-10 relative
    middle = 0.5 * (parameter[1:] + parameter[:-1])
    # each table interval lies in one segment: evaluate both its ends there
    segment = np.repeat(np.arange(segments), _TABLE_SAMPLES_PER_SEGMENT)
    rate_start = _rate_along(knots, coefficients, parameter[:-1], segment)
    rate_end = _rate_along(knots, coefficients, parameter[1:], segment)
    pieces = (
        np.diff(parameter)
        / 6.0
        * (rate_start + 4.0 * _rate_along(knots, coefficients, middle, segment) + rate_end)
    )
    length = np.concatenate([[0.0], np.cumsum(pieces)])
    return WaypointsTrajectory(
        knots=knots,
        coefficients=coefficients,
        table_length=length,
        table_parameter=parameter,
        table_slope_start=1.0 / np.maximum(rate_start, 1e-12),
        table_slope_end=1.0 / np.maximum(rate_end, 1e-12),
        speed=float(speed),
        closed=bool(closed),
        points=distinct,
    )


def nearest_distance(trajectory: WaypointsTrajectory, x: float, y: float) -> float:
    """Arc length from the first point to the table entry nearest (x, y)."""
    position, _ = _evaluate_spline(
        trajectory.knots, trajectory.coefficients, trajectory.table_parameter
    )
    nearest = np.argmin(np.hypot(position[:, 0] - x, position[:, 1] - y))
    return float(trajectory.table_length[nearest])


def _rate_along(
    knots: FloatArray, coefficients: FloatArray, parameter: FloatArray, segment: NDArray[np.intp]
) -> FloatArray:
    """|dp/ds| of the curve at ``parameter`` on ``segment``."""
    _, tangent = _evaluate_spline(knots, coefficients, parameter, segment)
    return np.hypot(tangent[..., 0], tangent[..., 1])


def trajectory(
    path: WaypointsPath, context: Context, pose: Pose
) -> WaypointsTrajectory | LineTrajectory:
    x, y, _ = pose
    points = np.asarray(path.points, dtype=np.float64)
    if path.start == "current" and not path.closed:
        points = np.vstack([[x, y], points])
    curve = waypoints_trajectory(points, path.speed, path.closed)
    if path.start == "current" and isinstance(curve, WaypointsTrajectory):
        # a closed route is joined where it passes nearest the robot
        return replace(curve, start_distance=nearest_distance(curve, x, y))
    return curve


def points(path: WaypointsPath, context: Context) -> FloatArray:
    return np.asarray(path.points, dtype=np.float64).reshape(-1, 2)


# Registered by wmr_mission.geometry.paths.
PATH = PathType(WaypointsPath, trajectory, points)
