from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from pydantic import TypeAdapter

from wmr_mission.geometry import paths
from wmr_mission.geometry.paths import PathSpec, Trajectory, sample_positions
from wmr_mission.geometry.paths.waypoints import WaypointsTrajectory
from wmr_mission.geometry.regions import region_value
from wmr_mission.spec.models import Mission

PATH = TypeAdapter(PathSpec)
MISSION = Mission.model_validate(
    {
        "version": 1,
        "name": "paths",
        "parameters": {"k": 0.4},
        "regions": {
            "ellipse": {"type": "ellipse", "semi_axes": [5.5, 3]},
            "tilted": {"type": "ellipse", "center": [1, 2], "semi_axes": [3, 1], "rotation": 0.5},
            "ring": {"type": "circle", "center": [-1, 1], "radius": 2},
        },
        "phases": [{"name": "wait", "hold": {}, "until": {"elapsed": 1}}],
    }
)
ORIGIN = (0.0, 0.0, 0.0)
T = np.linspace(0.0, 10.0, 101)
W = 0.4 * math.pi


def trajectory(spec: dict[str, Any], pose: tuple[float, float, float] = ORIGIN) -> Trajectory:
    path = PATH.validate_python(spec, context={"parameters": MISSION.parameters})
    return paths.trajectory(path, MISSION.path_context(), pose)


def test_spiral_is_eq_30() -> None:
    spiral = trajectory(
        {"type": "spiral", "initial_radius": 2, "growth_rate": 0.5, "angular_rate": "0.4*pi"}
    )
    x, y, _, _ = spiral.sample(T)
    np.testing.assert_allclose(x, 2 * np.exp(0.5 * T) * np.cos(W * T), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(y, 2 * np.exp(0.5 * T) * np.sin(W * T), rtol=1e-12, atol=1e-12)


def test_ellipse_of_a_region_is_eq_31() -> None:
    ellipse = trajectory({"type": "ellipse", "region": "ellipse", "angular_rate": W, "start": 0})
    x, y, _, _ = ellipse.sample(T)
    np.testing.assert_allclose(x, 5.5 * np.cos(W * T), atol=1e-12)
    np.testing.assert_allclose(y, 3 * np.sin(W * T), atol=1e-12)


def test_elliptical_spiral_is_eq_32() -> None:
    spiral = trajectory(
        {
            "type": "elliptical-spiral",
            "center": [0, 0],
            "semi_axes": [5.5, 3],
            "decay_rate": 0.2,
            "angular_rate": W,
            "start": 0,
        }
    )
    x, y, _, _ = spiral.sample(T)
    np.testing.assert_allclose(x, 5.5 * np.exp(-0.2 * T) * np.cos(W * T), atol=1e-12)
    np.testing.assert_allclose(y, 3 * np.exp(-0.2 * T) * np.sin(W * T), atol=1e-12)


def test_expression_path_matches_the_spiral_it_writes() -> None:
    text = {"x": "2*exp(0.5*t)*cos(k*pi*t)", "y": "2*exp(0.5*t)*sin(k*pi*t)"}
    written = trajectory({"type": "expression", **text}, pose=(3.0, 3.0, 1.0))
    spiral = trajectory(
        {"type": "spiral", "initial_radius": 2, "growth_rate": 0.5, "angular_rate": W}
    )
    x, y, vx, vy = written.sample(T)
    sx, sy, svx, svy = spiral.sample(T)
    np.testing.assert_allclose([x, y], [sx, sy], rtol=1e-13, atol=1e-13)
    # central difference: relative error well below 1e-6 of the path's scale
    scale = np.max(np.abs([svx, svy]))
    np.testing.assert_allclose([vx, vy], [svx, svy], rtol=0, atol=1e-8 * scale)


def test_line_towards_a_point() -> None:
    line = trajectory({"type": "line", "start": [1, 1], "towards": [4, 5], "speed": 2})
    x, y, vx, vy = line.sample(np.array([0.0, 2.5]))
    np.testing.assert_allclose([x, y], [[1, 4], [1, 5]])
    np.testing.assert_allclose([vx, vy], [[1.2, 1.2], [1.6, 1.6]])


PRIMITIVES: list[dict[str, Any]] = [
    {"type": "line", "heading": 0.3, "speed": 1.5},
    {"type": "circle", "center": [1, 2], "radius": 3, "angular_rate": -0.7},
    {"type": "ellipse", "region": "tilted", "angular_rate": 0.9, "start": 1.0},
    {"type": "ellipse", "region": "ring", "angular_rate": 0.9},
    {"type": "ellipse", "center": [0, 1], "semi_axes": [2, 1], "rotation": 1, "angular_rate": 1},
    {
        "type": "spiral",
        "center": [1, 0],
        "initial_radius": 1,
        "growth_rate": -0.1,
        "angular_rate": 2,
    },
    {"type": "elliptical-spiral", "region": "tilted", "decay_rate": 0.3, "angular_rate": -1.2},
    {"type": "expression", "x": "t**2 + sin(3*t)", "y": "log(1 + t) * k", "start": "current"},
    {"type": "waypoints", "points": [[1, 0], [2, 2], [0, 3], [-1, 1]], "speed": 0.5},
]


@pytest.mark.parametrize("spec", PRIMITIVES, ids=[str(spec["type"]) for spec in PRIMITIVES])
def test_velocities_match_finite_differences(spec: dict[str, Any]) -> None:
    path = trajectory(spec, pose=(0.5, -0.5, 0.2))
    times = np.linspace(0.01, 6.0, 40)  # within the waypoint curve's 8.2 s, its ends aside
    h = 1e-6
    x_plus, y_plus, _, _ = path.sample(times + h)
    x_minus, y_minus, _, _ = path.sample(times - h)
    _, _, vx, vy = path.sample(times)
    np.testing.assert_allclose(vx, (x_plus - x_minus) / (2 * h), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(vy, (y_plus - y_minus) / (2 * h), rtol=1e-5, atol=1e-5)


# Routes of legs, arcs and turns in place (sharp corners turn on the spot),
# beside the primitives.
ROUTES: list[dict[str, Any]] = [
    {"type": "polyline", "points": [[1, 0], [1, 1], [0, 1]], "speed": 1.0},
    {"type": "polyline", "points": [[2, 0], [2, 2]], "speed": 1.0, "corner_radius": 0.5},
]


@pytest.mark.parametrize(
    "spec", PRIMITIVES + ROUTES, ids=[str(spec["type"]) for spec in PRIMITIVES + ROUTES]
)
def test_sampling_keeps_the_shape_of_t(spec: dict[str, Any]) -> None:
    path = trajectory(spec)
    times = np.linspace(0.0, 3.0, 12).reshape(3, 4)
    flat = path.sample(times.ravel())
    for block, values in zip(path.sample(times), flat, strict=True):
        assert block.shape == (3, 4)
        np.testing.assert_array_equal(block.ravel(), values)
    for k, at in enumerate(times.ravel()):  # one time alone: its values, as numbers
        for alone, values in zip(path.sample(at), flat, strict=True):
            assert np.shape(alone) == ()
            assert alone == values[k]


ROBOT = (2.0, 1.5, 0.3)


@pytest.mark.parametrize(
    "spec",
    [
        {"type": "line", "heading": 1.0, "speed": 1},
        {"type": "waypoints", "points": [[0, 0], [3, 3]], "speed": 1},
        {"type": "expression", "x": "3 + cos(t)", "y": "sin(t) - 2", "start": "current"},
    ],
)
def test_start_current_begins_at_the_robot(spec: dict[str, Any]) -> None:
    x, y, _, _ = trajectory(spec, pose=ROBOT).sample(np.zeros(1))
    assert (x[0], y[0]) == pytest.approx(ROBOT[:2], abs=1e-12)


def test_circle_current_starts_at_the_robots_angle() -> None:
    circle = trajectory(
        {"type": "circle", "center": [1, 1], "radius": 2, "angular_rate": 1}, pose=ROBOT
    )
    x, y, _, _ = circle.sample(np.zeros(1))
    direction = np.array(ROBOT[:2]) - [1, 1]
    expected = np.array([1, 1]) + 2 * direction / np.linalg.norm(direction)
    np.testing.assert_allclose([x[0], y[0]], expected, atol=1e-12)
    fixed = trajectory(
        {"type": "circle", "center": [1, 1], "radius": 2, "angular_rate": 1, "start": "pi/2"},
        pose=ROBOT,
    )
    x, y, _, _ = fixed.sample(np.zeros(1))
    np.testing.assert_allclose([x[0], y[0]], [1, 3], atol=1e-12)


@pytest.mark.parametrize("kind", ["ellipse", "elliptical-spiral"])
def test_ellipse_current_from_a_point_on_the_ellipse_is_exactly_there(kind: str) -> None:
    # a point of the tilted ellipse, at angle 2.2 of eq. (31)
    c, s = math.cos(0.5), math.sin(0.5)
    u, w = 3 * math.cos(2.2), 1 * math.sin(2.2)
    on_curve = (1 + c * u - s * w, 2 + s * u + c * w, 0.0)
    rate = {"ellipse": {}, "elliptical-spiral": {"decay_rate": 0.2}}[kind]
    path = trajectory({"type": kind, "region": "tilted", "angular_rate": 0.4, **rate}, on_curve)
    x, y, _, _ = path.sample(np.zeros(1))
    assert (x[0], y[0]) == pytest.approx(on_curve[:2], abs=1e-12)


def test_ellipse_current_off_the_ellipse_starts_on_the_robots_ray() -> None:
    path = trajectory({"type": "ellipse", "region": "tilted", "angular_rate": 1}, ROBOT)
    x, y, _, _ = path.sample(np.zeros(1))
    start = np.array([x[0], y[0]]) - [1, 2]
    robot = np.array(ROBOT[:2]) - [1, 2]
    assert start[0] * robot[1] - start[1] * robot[0] == pytest.approx(0.0, abs=1e-12)
    assert np.dot(start, robot) > 0
    assert region_value(MISSION.regions["tilted"], x, y) == pytest.approx(0.0, abs=1e-12)


def test_expression_as_written_ignores_the_robot() -> None:
    path = trajectory({"type": "expression", "x": "3 + t", "y": "k"}, pose=ROBOT)
    x, y, vx, vy = path.sample(np.array([0.0, 1.0]))
    np.testing.assert_allclose(np.vstack([x, y]), [[3.0, 4.0], [0.4, 0.4]])
    np.testing.assert_allclose(np.vstack([vx, vy]), [[1.0, 1.0], [0.0, 0.0]], atol=1e-9)


WAYPOINTS = [[0.0, 0.0], [2.0, 1.0], [3.0, 3.0], [1.0, 4.0], [-1.0, 2.0]]


def _speeds(path: Trajectory, times: np.ndarray) -> np.ndarray:
    x, y, _, _ = path.sample(times)
    return np.hypot(np.diff(x), np.diff(y)) / np.diff(times)


def test_waypoints_pass_every_point_at_constant_speed() -> None:
    path = trajectory({"type": "waypoints", "points": WAYPOINTS, "speed": 0.8, "start": "first"})
    assert isinstance(path, WaypointsTrajectory)
    duration = path.length / 0.8
    times, x, y = sample_positions(path, duration, 0.001)
    for point in WAYPOINTS:
        assert np.min(np.hypot(x - point[0], y - point[1])) < 0.8 * 0.001
    inner = times[(times > 0.05 * duration) & (times < 0.95 * duration)]
    np.testing.assert_allclose(_speeds(path, inner), 0.8, rtol=0.02)
    _, _, vx, vy = path.sample(inner)
    np.testing.assert_allclose(np.hypot(vx, vy), 0.8, rtol=1e-5)


def test_open_waypoints_hold_the_last_point_after_the_end() -> None:
    path = trajectory({"type": "waypoints", "points": WAYPOINTS, "speed": 0.8, "start": "first"})
    assert isinstance(path, WaypointsTrajectory)
    after = path.length / 0.8 + np.array([0.0, 1.0, 100.0])
    x, y, vx, vy = path.sample(after)
    np.testing.assert_allclose([x, y], [[-1.0] * 3, [2.0] * 3], atol=1e-12)
    np.testing.assert_array_equal([vx, vy], 0.0)


def test_closed_waypoints_loop() -> None:
    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    spec = {"type": "waypoints", "points": square, "speed": 0.5, "closed": True, "start": "first"}
    path = trajectory(spec, ROBOT)
    assert isinstance(path, WaypointsTrajectory)
    period = path.length / 0.5
    times = np.linspace(0.0, period, 7)
    for now, later in zip(path.sample(times), path.sample(times + 2 * period), strict=True):
        np.testing.assert_allclose(now, later, atol=1e-9)
    # the loop is smooth through its first point: speed stays constant across it
    np.testing.assert_allclose(_speeds(path, np.linspace(0.9, 1.1, 41) * period), 0.5, rtol=0.02)


def test_waypoints_start_current_prepends_the_robot_once() -> None:
    path = trajectory({"type": "waypoints", "points": [[0, 0], [1, 0]], "speed": 1}, (0, 0, 0))
    assert isinstance(path, WaypointsTrajectory)
    assert path.length == pytest.approx(1.0)
    path = trajectory({"type": "waypoints", "points": [[1, 0], [2, 0]], "speed": 1}, (0, 0, 0))
    assert isinstance(path, WaypointsTrajectory)
    assert path.length == pytest.approx(2.0)


def test_a_diverging_spiral_returns_non_finite_values_without_warnings() -> None:
    spiral = trajectory(
        {"type": "spiral", "initial_radius": 1, "growth_rate": 5, "angular_rate": 1}
    )
    x, _, _, _ = spiral.sample(np.array([0.0, 1000.0]))
    assert np.isfinite(x[0])
    assert not np.isfinite(x[1])


def test_sample_positions_covers_the_duration() -> None:
    line = trajectory({"type": "line", "heading": 0, "speed": 2})
    times, x, y = sample_positions(line, 1.0, 0.1)
    assert len(times) == 11
    assert times[-1] == pytest.approx(1.0)
    np.testing.assert_allclose(x, 2 * times)
    np.testing.assert_array_equal(y, 0.0)
