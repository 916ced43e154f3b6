"""Paths drawn through points stay where they are drawn: polyline, coverage, waypoints."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from geometry import outside_hull
from pydantic import TypeAdapter
from scipy.interpolate import CubicSpline

from wmr_mission.geometry import paths
from wmr_mission.geometry.paths import PathSpec
from wmr_mission.geometry.paths.waypoints import WaypointsTrajectory
from wmr_mission.geometry.routes import TURN_CREEP, RouteTrajectory, polyline_route
from wmr_mission.spec.models import Mission

PATH = TypeAdapter(PathSpec)
FIELD = [[0, 0], [12, 0], [13, 6], [4, 8], [-1, 4]]
MISSION = Mission.model_validate(
    {
        "version": 1,
        "name": "routes",
        "regions": {
            "field": {"type": "polygon", "vertices": FIELD},
            "yard": {"type": "box", "min": [-1, -1], "max": [9, 7]},
        },
        "phases": [{"name": "wait", "hold": {}, "until": {"elapsed": 1}}],
    }
)
# missions/patrol.yaml
PATROL = np.array([[1, 0], [7, 0.5], [8, 5], [4, 6], [0.5, 4]], dtype=float)
# a lawnmower drawn by hand: lanes at y = 1..5 across x = 1..9
LAWNMOWER = np.array(
    [[1, 1], [9, 1], [9, 2], [1, 2], [1, 3], [9, 3], [9, 4], [1, 4], [1, 5], [9, 5]], dtype=float
)
ORIGIN = (0.0, 0.0, 0.0)


def build(spec: dict[str, Any], pose: tuple[float, float, float] = ORIGIN) -> Any:
    return paths.trajectory(PATH.validate_python(spec), MISSION.path_context(), pose)


def whole(trajectory: Any, extra: float = 0.0, count: int = 40001) -> tuple[np.ndarray, ...]:
    """Samples over one traversal (plus ``extra`` seconds)."""
    if isinstance(trajectory, RouteTrajectory):
        duration = trajectory.period
    else:
        duration = trajectory.length / trajectory.speed
    t = np.linspace(0.0, duration + extra, count)
    return (t, *trajectory.sample(t))


def old_spline(points: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """The former `waypoints` curve: a natural (or periodic) cubic spline in chord length."""
    nodes = np.vstack([points, points[:1]]) if closed else points
    knots = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(nodes, axis=0).T))])
    spline = CubicSpline(knots, nodes, bc_type="periodic" if closed else "natural")
    curve = spline(np.linspace(0.0, knots[-1], 40001))
    return curve[:, 0], curve[:, 1]


def bezier_bound(points: np.ndarray, closed: bool) -> float:
    """The hull bound of the waypoint curve: max over turning points of
    min(chord before, chord after) / 3 * sin(turn / 2)."""
    count = len(points)
    bound = 0.0
    for i in range(count) if closed else range(1, count - 1):
        before, after = points[i] - points[i - 1], points[(i + 1) % count] - points[i]
        turn = math.atan2(before[0] * after[1] - before[1] * after[0], float(np.dot(before, after)))
        arm = min(np.hypot(*before), np.hypot(*after)) / 3.0
        bound = max(bound, arm * math.sin(abs(turn) / 2.0))
    return bound


# --- polyline ---------------------------------------------------------------


@pytest.mark.parametrize("corner_radius", [0.0, 0.5, 1.0, 100.0])
@pytest.mark.parametrize("closed", [False, True])
def test_polyline_stays_in_the_hull_of_its_points(corner_radius: float, closed: bool) -> None:
    spec = {
        "type": "polyline",
        "points": PATROL.tolist(),
        "speed": 1.0,
        "corner_radius": corner_radius,
        "closed": closed,
        "start": "first",
    }
    route = build(spec)
    _, x, y, _, _ = whole(route)
    assert outside_hull(PATROL, x, y) < 1e-9


def test_polyline_legs_and_arcs_run_at_the_speed_and_velocity_is_the_derivative() -> None:
    spec = {"type": "polyline", "points": PATROL.tolist(), "speed": 0.7, "corner_radius": 1.0}
    route = build(spec, (0.0, -1.0, 0.0))
    t, x, y, vx, vy = whole(route)
    inside = t < route.period
    np.testing.assert_allclose(np.hypot(vx, vy)[inside], 0.7, rtol=1e-12)
    # central differences of the positions
    step = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(x, step)[1:-2], vx[1:-2], atol=2e-3)
    np.testing.assert_allclose(np.gradient(y, step)[1:-2], vy[1:-2], atol=2e-3)
    # arcs are tangent to both legs: the direction never jumps
    heading = np.unwrap(np.arctan2(vy[inside], vx[inside]))
    assert np.max(np.abs(np.diff(heading))) < 0.7 * step / 1.0 * 1.01 + 1e-9


def test_a_corner_without_room_for_its_radius_gets_the_largest_that_fits() -> None:
    # 90 degree corners with 2 m legs: an arc's tangent length r may use 1 m of each leg
    square = [[0, 0], [2, 0], [2, 2], [0, 2]]
    route = build(
        {"type": "polyline", "points": square, "speed": 1, "corner_radius": 5, "closed": True}
    )
    assert isinstance(route, RouteTrajectory)
    radii = route.parameters[route.kinds == 1, 2]
    np.testing.assert_allclose(radii, 1.0)
    assert route.period == pytest.approx(4 * (math.pi / 2))  # a circle of radius 1


def test_turn_in_place_holds_the_point_and_turns_at_the_turn_rate() -> None:
    route = build(
        {"type": "polyline", "points": [[0, 0], [2, 0], [2, 2]], "speed": 1, "turn_rate": 0.5},
    )
    assert isinstance(route, RouteTrajectory)
    # leg 2 s, turn pi/2 at 0.5 rad/s = pi s, leg 2 s
    np.testing.assert_allclose(route.durations, [2.0, math.pi, 2.0])
    t = 2.0 + np.linspace(0.0, math.pi, 9)[1:-1]
    x, y, vx, vy = route.sample(t)
    np.testing.assert_array_equal([x, y], [[2.0] * 7, [0.0] * 7])
    np.testing.assert_allclose(np.hypot(vx, vy), TURN_CREEP)
    np.testing.assert_allclose(np.arctan2(vy, vx), 0.5 * (t - 2.0), atol=1e-12)


def test_open_polyline_holds_its_last_point_and_closed_one_loops() -> None:
    drawn = {"type": "polyline", "points": PATROL.tolist(), "speed": 1, "start": "first"}
    open_route = build(drawn)
    x, y, vx, vy = open_route.sample(np.array([open_route.period + 1.0, 1e4]))
    np.testing.assert_allclose([x, y], [[0.5, 0.5], [4.0, 4.0]])
    np.testing.assert_array_equal([vx, vy], 0.0)
    loop = build({**drawn, "closed": True, "corner_radius": 0.5})
    t = np.linspace(0.0, loop.period, 11)
    for now, later in zip(loop.sample(t), loop.sample(t + 3 * loop.period), strict=True):
        np.testing.assert_allclose(now, later, atol=1e-9)


@pytest.mark.parametrize("kind", ["polyline", "waypoints"])
def test_closed_route_start_current_joins_at_the_nearest_point(kind: str) -> None:
    spec = {"type": kind, "points": PATROL.tolist(), "speed": 1.0, "closed": True}
    robot = (1.0, 1.0, 0.0)  # the patrol's estimated start, inside the loop
    joined = build(spec, robot)
    drawn = build({**spec, "start": "first"}, robot)
    _, x, y, _, _ = whole(drawn)
    nearest = float(np.min(np.hypot(x - 1.0, y - 1.0)))
    x0, y0, _, _ = joined.sample(np.zeros(1))
    assert math.hypot(x0[0] - 1.0, y0[0] - 1.0) == pytest.approx(nearest, abs=2e-3)
    # the robot's position is not a vertex: the route is the one drawn, shifted in time
    _, jx, jy, _, _ = whole(joined)
    assert outside_hull(PATROL, jx, jy) == pytest.approx(outside_hull(PATROL, x, y), abs=1e-6)
    assert np.min(np.hypot(jx - 1.0, jy - 1.0)) == pytest.approx(nearest, abs=2e-3)


# --- waypoints ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("points", "closed"),
    [(PATROL, True), (PATROL, False), (LAWNMOWER, False), (np.array(FIELD, float), True)],
    ids=["patrol-closed", "patrol-open", "lawnmower", "field-closed"],
)
def test_waypoints_stay_within_their_stated_bound_of_the_hull(
    points: np.ndarray, closed: bool
) -> None:
    spec = {
        "type": "waypoints",
        "points": points.tolist(),
        "speed": 1.0,
        "closed": closed,
        "start": "first",
    }
    curve = build(spec)
    assert isinstance(curve, WaypointsTrajectory)
    _, x, y, _, _ = whole(curve)
    new = outside_hull(points, x, y)
    old = outside_hull(points, *old_spline(points, closed))
    assert new <= bezier_bound(points, closed) + 1e-9
    assert new < old  # measured: test_waypoint_overshoot_measured_on_the_patrol_and_the_lawnmower


def test_waypoint_overshoot_measured_on_the_patrol_and_the_lawnmower() -> None:
    """The numbers quoted in docs/mission-format.md and docs/paper-notes.md."""
    patrol = build({"type": "waypoints", "points": PATROL.tolist(), "speed": 1, "closed": True,
                    "start": "first"})  # fmt: skip
    _, x, y, _, _ = whole(patrol)
    assert outside_hull(PATROL, x, y) == pytest.approx(0.70, abs=0.01)
    assert outside_hull(PATROL, *old_spline(PATROL, True)) == pytest.approx(1.18, abs=0.01)
    assert float(np.min(y)) == pytest.approx(-0.48, abs=0.01)  # old: -0.96
    assert float(np.min(old_spline(PATROL, True)[1])) == pytest.approx(-0.96, abs=0.01)
    mower = build({"type": "waypoints", "points": LAWNMOWER.tolist(), "speed": 1,
                   "start": "first"})  # fmt: skip
    _, x, y, _, _ = whole(mower)
    assert outside_hull(LAWNMOWER, x, y) == pytest.approx(0.18, abs=0.01)
    old_x, old_y = old_spline(LAWNMOWER, False)
    assert outside_hull(LAWNMOWER, old_x, old_y) == pytest.approx(1.52, abs=0.01)
    assert (float(np.min(old_y)), float(np.max(old_y))) == pytest.approx((-0.52, 6.52), abs=0.01)
    assert (float(np.min(y)), float(np.max(y))) == pytest.approx((0.90, 5.10), abs=0.01)


# --- coverage -----------------------------------------------------------------


def share_covered(field: list[list[float]], x: np.ndarray, y: np.ndarray, radius: float) -> float:
    """Share of a convex field's area within ``radius`` of the points (x, y), on a 5 cm grid."""
    from scipy.spatial import Delaunay, cKDTree

    corners = np.array(field, dtype=float)
    low, high = corners.min(axis=0), corners.max(axis=0)
    # cell centres: a grid on the lanes' midlines would sit at exactly half a spacing
    gx, gy = np.meshgrid(
        np.arange(low[0] + 0.025, high[0], 0.05), np.arange(low[1] + 0.025, high[1], 0.05)
    )
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    grid = grid[Delaunay(corners).find_simplex(grid) >= 0]
    distance, _ = cKDTree(np.column_stack([x, y])).query(grid)
    return float(np.mean(distance <= radius))


@pytest.mark.parametrize("direction", [0.0, 0.3, -1.2, math.pi / 2])
def test_coverage_path_covers_its_field_and_stays_inside(direction: float) -> None:
    spec = {"type": "coverage", "region": "field", "spacing": 1.0, "direction": direction,
            "speed": 1.0, "start": "first"}  # fmt: skip
    route = build(spec)
    _, x, y, _, _ = whole(route, count=50001)
    assert outside_hull(np.array(FIELD, float), x, y) < 1e-9
    assert share_covered(FIELD, x, y, 0.5) >= 0.98  # measured 0.982 (pi/2) to 0.991
    # lanes run along the direction: most of the time the velocity points along it (or back)
    _, _, vx, vy = route.sample(np.linspace(0.0, route.period, 2001))
    along = np.abs(vx * math.cos(direction) + vy * math.sin(direction))
    assert np.mean(along > 0.999) > 0.6


def test_coverage_lanes_are_at_most_the_spacing_apart_with_semicircle_turns() -> None:
    spec = {"type": "coverage", "region": "yard", "spacing": 0.75, "speed": 1.0, "start": "first"}
    route = build(spec)
    assert isinstance(route, RouteTrajectory)
    lanes = np.unique(np.round(route.points[:, 1], 9))
    np.testing.assert_allclose(np.diff(lanes), 8.0 / 11.0)  # ceil(8 / 0.75) = 11 lanes
    assert lanes[0] == pytest.approx(-1.0 + 4.0 / 11.0)
    radii = route.parameters[route.kinds == 1, 2]
    np.testing.assert_allclose(radii, 4.0 / 11.0)  # half the spacing: semicircles


def test_compiled_track_phases_expose_the_points_their_paths_are_drawn_through() -> None:
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.spec.loader import load_mission

    root = Path(__file__).resolve().parents[1]
    patrol = plan_mission(load_mission(root / "missions" / "patrol.yaml"))
    np.testing.assert_array_equal(patrol.phases[0].points, PATROL)
    assert patrol.phases[1].points is None  # the dock: a regulate phase
    coverage = plan_mission(load_mission(root / "missions" / "coverage.yaml"))
    route = coverage.phases[0].make_trajectory((-1.0, 0.5, 0.0))  # type: ignore[misc]
    assert isinstance(route, RouteTrajectory)
    np.testing.assert_array_equal(route.points[1:], coverage.phases[0].points)  # after the robot


@pytest.mark.parametrize(
    ("points", "braking"),
    [
        ([[0, 0], [4, 0], [4, 3], [0, 3]], 0.5),  # long legs: up to speed and down again
        ([[0, 0], [4, 0], [4, 0.5], [0, 0.5]], 0.5),  # a leg too short for full speed
        ([[0, 0], [0.1, 0], [0.1, 3]], 5.0),  # too short to brake on from 1 m/s: harder
    ],
)
def test_a_route_under_an_acceleration_limit_slows_into_its_stops(
    points: list, braking: float
) -> None:
    """Into each turn in place and into the end the reference slows at the
    acceleration, and out of a turn it speeds up at it; it still passes
    through every point. Without the limit it stops there in one sample."""
    free = polyline_route(points, 1.0, False, 0.0, 1.0)
    route = polyline_route(points, 1.0, False, 0.0, 1.0, acceleration=0.5)
    dt = 0.001
    t = np.arange(0.0, route.period + 1.0, dt)
    x, y, vx, vy = route.sample(t)
    speed = np.hypot(vx, vy)
    assert speed.max() <= 1.0 + 1e-12
    for vertex in np.asarray(points, dtype=float)[1:]:
        assert np.hypot(x - vertex[0], y - vertex[1]).min() < 1e-9
    # the velocity is the position's rate of change
    np.testing.assert_allclose(np.diff(x) / dt, 0.5 * (vx[1:] + vx[:-1]), atol=2e-3)
    np.testing.assert_allclose(np.diff(y) / dt, 0.5 * (vy[1:] + vy[:-1]), atol=2e-3)
    assert speed[-1] == 0.0
    assert np.abs(np.diff(speed)).max() <= braking * dt + 1e-9
    assert route.period > free.period
    _, _, fvx, fvy = free.sample(t)
    assert np.abs(np.diff(np.hypot(fvx, fvy))).max() == pytest.approx(1.0)


@pytest.mark.parametrize("acceleration", [math.inf, 0.5])
def test_a_route_sampled_at_once_or_time_by_time_gives_the_same_bits(acceleration: float) -> None:
    """sample() computes each kind of piece only where the times fall on one,
    without a mask where all do: a call over legs, arcs and turns in place
    together, one within a single piece, and one time at a time agree to
    the bit."""
    points = [[0, 0], [2, 0], [2, 2], [0, 3]]
    rounded = polyline_route(points, 1.0, False, 0.5, 1.0, acceleration=acceleration)
    turned = polyline_route(points, 1.0, False, 0.0, 0.5, acceleration=acceleration)
    for route in (rounded, turned):
        t = np.linspace(-1.0, route.period + 1.0, 501)
        together = np.array(route.sample(t))
        alone = np.array([np.array(route.sample(t[i : i + 1]))[:, 0] for i in range(t.size)]).T
        assert together.tobytes() == alone.tobytes()
        for kind in (0, 1, 2):  # a piece of each kind alone
            piece = np.flatnonzero(route.kinds == kind)
            if piece.size:
                end = route._ends[piece[0]]
                inside = np.linspace(end - route.durations[piece[0]], end, 9)[1:-1]
                alone_piece = np.array(route.sample(inside)).tobytes()
                assert alone_piece == together_at(route, inside), kind
    assert 1 in rounded.kinds
    assert 2 in turned.kinds


def together_at(route: RouteTrajectory, t: np.ndarray) -> bytes:
    """The samples at ``t`` taken from a call that also samples a time on
    every piece (so each kind of piece is computed under its mask)."""
    every = np.concatenate([route._ends - 0.5 * route.durations, [-1.0]])
    return np.array(route.sample(np.concatenate([t, every])))[:, : t.size].tobytes()


def test_a_coverage_of_too_many_lanes_is_refused_not_built() -> None:
    """A field of a billion metres at a micrometre's spacing: 1e15 lanes are
    counted, never laid (validate answers in a second, tests/data/missions/
    invalid/coverage_of_too_many_lanes.yaml); the most lanes are laid."""
    from wmr_mission.geometry.routes import MAX_LANES, coverage_lanes, coverage_points

    field = [[-5e8, -5e8], [5e8, -5e8], [5e8, 5e8], [-5e8, 5e8]]
    rows = [[1.0, 0.0, 5e8], [0.0, 1.0, 5e8], [-1.0, 0.0, 5e8], [0.0, -1.0, 5e8]]
    assert coverage_lanes(field, 1e-6, 0.0) == 10**15
    with pytest.raises(ValueError, match="more than 5000"):
        coverage_points(field, rows, 1e-6, 0.0)
    square = [[0, 0], [MAX_LANES, 0], [MAX_LANES, 1], [0, 1]]
    edges = [[1.0, 0.0, MAX_LANES], [0.0, 1.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
    assert coverage_points(square, edges, 1.0, math.pi / 2).shape == (2 * MAX_LANES, 2)
