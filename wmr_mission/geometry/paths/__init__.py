"""Path primitives: instantiated once at phase entry, then sampled vectorised.

``instantiate`` turns a path of the mission (plus the robot's pose at phase
entry, for ``start: current``) into a :class:`Trajectory` whose ``sample``
returns positions and velocities for a whole array of phase-local times:
numpy's arithmetic, and wmr_mission.kernels.scalar_math's sin, cos and exp, which give
the same bits on every CPU. Primitives have analytic velocities; expression
paths use a central difference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wmr_mission.expressions import Expression, parse
from wmr_mission.geometry.regions import constraint_rows, ellipse_geometry, region_vertices
from wmr_mission.geometry.routes import (
    RouteTrajectory,
    coverage_points,
    distinct_points,
    polyline_route,
)
from wmr_mission.kernels import scalar_math
from wmr_mission.spec import models
from wmr_mission.spec.models import Mission, PathSpec

__all__ = [
    "EllipseTrajectory",
    "EllipticalSpiralTrajectory",
    "ExpressionTrajectory",
    "LineTrajectory",
    "RouteTrajectory",
    "SpiralTrajectory",
    "Trajectory",
    "WaypointsTrajectory",
    "drawn_points",
    "ellipse_angle",
    "instantiate",
    "sample_positions",
    "waypoints_trajectory",
]

FloatArray = NDArray[np.float64]
Sample = tuple[FloatArray, FloatArray, FloatArray, FloatArray]

# Dense arc-length table of a waypoint curve: samples per segment.
_TABLE_SAMPLES_PER_SEGMENT = 128


class Trajectory(Protocol):
    """A reference path in phase-local time."""

    def sample(self, t: ArrayLike) -> Sample:
        """x, y, dx/dt, dy/dt at phase-local times ``t`` (vectorised)."""
        ...


def _times(t: ArrayLike) -> FloatArray:
    return np.asarray(t, dtype=np.float64)


@dataclass(frozen=True)
class LineTrajectory:
    """p(t) = p0 + speed * t * (cos h, sin h)."""

    x0: float
    y0: float
    heading: float
    speed: float

    def sample(self, t: ArrayLike) -> Sample:
        time = _times(t)
        vx = self.speed * math.cos(self.heading)
        vy = self.speed * math.sin(self.heading)
        return (
            self.x0 + vx * time,
            self.y0 + vy * time,
            np.full(time.shape, vx),
            np.full(time.shape, vy),
        )


@dataclass(frozen=True)
class EllipseTrajectory:
    """eq. (31): p = c + Rot(rotation) (a cos(w t + phi0), b sin(w t + phi0)).

    A circle is the case a = b.
    """

    cx: float
    cy: float
    a: float
    b: float
    rotation: float
    angular_rate: float
    phase: float

    def sample(self, t: ArrayLike) -> Sample:
        angle = self.angular_rate * _times(t) + self.phase
        cos, sin = scalar_math.cos(angle), scalar_math.sin(angle)
        u, w = self.a * cos, self.b * sin
        du, dw = -self.a * self.angular_rate * sin, self.b * self.angular_rate * cos
        return _placed(self.cx, self.cy, self.rotation, u, w, du, dw)


@dataclass(frozen=True)
class SpiralTrajectory:
    """eq. (30): radius r0 exp(growth t) at angle w t + phi0 about the centre."""

    cx: float
    cy: float
    initial_radius: float
    growth_rate: float
    angular_rate: float
    phase: float

    def sample(self, t: ArrayLike) -> Sample:
        time = _times(t)
        angle = self.angular_rate * time + self.phase
        cos, sin = scalar_math.cos(angle), scalar_math.sin(angle)
        g, w = self.growth_rate, self.angular_rate
        # a spiral grown past float64 gives inf or nan, the caller's to judge
        with np.errstate(over="ignore", invalid="ignore"):
            radius = self.initial_radius * scalar_math.exp(g * time)
            return (
                self.cx + radius * cos,
                self.cy + radius * sin,
                radius * (g * cos - w * sin),
                radius * (g * sin + w * cos),
            )


@dataclass(frozen=True)
class EllipticalSpiralTrajectory:
    """eq. (32): the ellipse of eq. (31) scaled by exp(-decay t)."""

    cx: float
    cy: float
    a: float
    b: float
    rotation: float
    decay_rate: float
    angular_rate: float
    phase: float

    def sample(self, t: ArrayLike) -> Sample:
        time = _times(t)
        angle = self.angular_rate * time + self.phase
        cos, sin = scalar_math.cos(angle), scalar_math.sin(angle)
        with np.errstate(over="ignore", invalid="ignore"):  # far negative times overflow
            scale = scalar_math.exp(-self.decay_rate * time)
            u, w = self.a * scale * cos, self.b * scale * sin
            du = -self.decay_rate * u - self.angular_rate * self.a * scale * sin
            dw = -self.decay_rate * w + self.angular_rate * self.b * scale * cos
            return _placed(self.cx, self.cy, self.rotation, u, w, du, dw)


def _placed(
    cx: float,
    cy: float,
    rotation: float,
    u: FloatArray,
    w: FloatArray,
    du: FloatArray,
    dw: FloatArray,
) -> Sample:
    """Rotate ellipse-frame position and velocity by ``rotation`` and move them to the centre."""
    c, s = math.cos(rotation), math.sin(rotation)
    return cx + c * u - s * w, cy + s * u + c * w, c * du - s * dw, s * du + c * dw


@dataclass(frozen=True)
class ExpressionTrajectory:
    """x(t), y(t) from expressions, moved by ``offset``; velocity by a central difference."""

    x: Expression
    y: Expression
    parameters: dict[str, float]
    offset_x: float = 0.0
    offset_y: float = 0.0

    def positions(self, t: FloatArray) -> tuple[FloatArray, FloatArray]:
        return (
            self.x.evaluate(t, self.parameters) + self.offset_x,
            self.y.evaluate(t, self.parameters) + self.offset_y,
        )

    def sample(self, t: ArrayLike) -> Sample:
        time = _times(t)
        # a step suited to float64: about the cube root of the machine epsilon, relative
        step = 1e-5 * np.maximum(1.0, np.abs(time))
        stacked = np.concatenate([time.ravel(), (time + step).ravel(), (time - step).ravel()])
        xs, ys = self.positions(stacked)
        n = time.size
        width = (2.0 * step).ravel()
        vx = (xs[n : 2 * n] - xs[2 * n :]) / width
        vy = (ys[n : 2 * n] - ys[2 * n :]) / width
        shape = time.shape
        return (
            xs[:n].reshape(shape),
            ys[:n].reshape(shape),
            vx.reshape(shape),
            vy.reshape(shape),
        )


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
        time = _times(t)
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


def _ellipse_of(
    path: models.EllipsePath | models.EllipticalSpiralPath, mission: Mission
) -> tuple[float, float, float, float, float]:
    """``cx, cy, a, b, rotation`` from the path's region or its own fields."""
    if path.region is not None:
        if path.region not in mission.regions:
            raise ValueError(f"undefined region {path.region!r}")
        return ellipse_geometry(mission.regions[path.region])
    if path.center is None or path.semi_axes is None:
        raise ValueError("an ellipse path needs 'region' or 'center' and 'semi_axes'")
    (cx, cy), (a, b) = path.center, path.semi_axes
    return cx, cy, a, b, path.rotation or 0.0


def ellipse_angle(geometry: tuple[float, float, float, float, float], x: float, y: float) -> float:
    """The angle phi0 of eq. (31) at which the ray from the centre meets the point (x, y)."""
    cx, cy, a, b, rotation = geometry
    c, s = math.cos(rotation), math.sin(rotation)
    dx, dy = x - cx, y - cy
    u, w = c * dx + s * dy, -s * dx + c * dy
    return math.atan2(w / b, u / a)


def _phase(start: float | str, current: float) -> float:
    return current if start == "current" else float(start)


def instantiate(path: PathSpec, mission: Mission, pose: tuple[float, float, float]) -> Trajectory:
    """The trajectory of ``path`` for a phase entered at the (estimated) ``pose``."""
    x, y, theta = (float(value) for value in pose)
    if isinstance(path, models.LinePath):
        x0, y0 = (x, y) if path.start == "current" else path.start
        if path.towards is not None:
            dx, dy = path.towards[0] - x0, path.towards[1] - y0
            # already there: keep the robot's heading rather than an arbitrary one
            heading = math.atan2(dy, dx) if (dx, dy) != (0.0, 0.0) else theta
        else:
            heading = path.heading if path.heading is not None else theta
        return LineTrajectory(x0, y0, heading, path.speed)
    if isinstance(path, models.CirclePath):
        cx, cy = path.center
        phase = _phase(path.start, math.atan2(y - cy, x - cx))
        radius = path.radius
        return EllipseTrajectory(cx, cy, radius, radius, 0.0, path.angular_rate, phase)
    if isinstance(path, models.EllipsePath):
        geometry = _ellipse_of(path, mission)
        phase = _phase(path.start, ellipse_angle(geometry, x, y))
        return EllipseTrajectory(*geometry, angular_rate=path.angular_rate, phase=phase)
    if isinstance(path, models.SpiralPath):
        cx, cy = path.center
        phase = _phase(path.start, math.atan2(y - cy, x - cx))
        return SpiralTrajectory(
            cx, cy, path.initial_radius, path.growth_rate, path.angular_rate, phase
        )
    if isinstance(path, models.EllipticalSpiralPath):
        geometry = _ellipse_of(path, mission)
        phase = _phase(path.start, ellipse_angle(geometry, x, y))
        return EllipticalSpiralTrajectory(
            *geometry, decay_rate=path.decay_rate, angular_rate=path.angular_rate, phase=phase
        )
    if isinstance(path, models.WaypointsPath):
        points = np.asarray(path.points, dtype=np.float64)
        if path.start == "current" and not path.closed:
            points = np.vstack([[x, y], points])
        curve = waypoints_trajectory(points, path.speed, path.closed)
        if path.start == "current" and isinstance(curve, WaypointsTrajectory):
            # a closed route is joined where it passes nearest the robot
            return replace(curve, start_distance=nearest_distance(curve, x, y))
        return curve
    if isinstance(path, models.PolylinePath):
        points = np.asarray(path.points, dtype=np.float64)
        return _joined(
            points, (x, y), path.start, path.closed, path.speed, path.corner_radius, path.turn_rate
        )
    if isinstance(path, models.CoveragePath):
        ends = drawn_points(path, mission)
        assert ends is not None
        radius = 0.5 * path.spacing if path.turn_radius is None else path.turn_radius
        # a turn sharper than a right angle cuts no more than its radius off a lane
        return _joined(
            ends, (x, y), path.start, False, path.speed, radius, path.turn_rate, longest_cut=radius
        )
    if isinstance(path, models.ExpressionPath):
        parameters = dict(mission.parameters)
        written = ExpressionTrajectory(
            parse(path.x, parameters), parse(path.y, parameters), parameters
        )
        if path.start == "as-written":
            return written
        x_start, y_start = written.positions(np.zeros(1))
        return ExpressionTrajectory(
            written.x,
            written.y,
            parameters,
            offset_x=x - float(x_start[0]),
            offset_y=y - float(y_start[0]),
        )
    raise ValueError(f"unknown path type {path.type!r}")


def drawn_points(path: PathSpec, mission: Mission) -> FloatArray | None:
    """The points a path is drawn through, ``(m, 2)``, for figures: a waypoint or
    polyline path's points, a coverage path's lane ends; None for other paths.
    (With ``start: current`` the route also passes the robot's position.)"""
    if isinstance(path, models.WaypointsPath | models.PolylinePath):
        return np.asarray(path.points, dtype=np.float64).reshape(-1, 2)
    if isinstance(path, models.CoveragePath):
        region = mission.regions[path.region]
        _, rows = constraint_rows(region, "inside")
        return coverage_points(region_vertices(region), rows[:, :3], path.spacing, path.direction)
    return None


def _joined(
    points: FloatArray,
    robot: tuple[float, float],
    start: str,
    closed: bool,
    speed: float,
    corner_radius: float,
    turn_rate: float,
    longest_cut: float = math.inf,
) -> RouteTrajectory:
    """The route through ``points``; with ``start: current`` an open route begins
    at the robot and a closed one at its point nearest the robot."""
    if start == "current" and not closed:
        points = np.vstack([robot, points])
    route = polyline_route(points, speed, closed, corner_radius, turn_rate, longest_cut)
    if start == "current" and route.closed:
        return replace(route, start_time=route.nearest_time(*robot))
    return route


def sample_positions(
    trajectory: Trajectory, t_end: float, dt: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Times ``0, dt, ..., <= t_end`` and the positions there: ``(t, x, y)``."""
    count = math.floor(t_end / dt + 1e-9) + 1
    time = np.arange(count, dtype=np.float64) * dt
    x, y, _, _ = trajectory.sample(time)
    return time, x, y
