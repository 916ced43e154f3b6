"""Eq. (28) under acceleration limits: a zone's row held on the whole line the
robot brakes along, not at its end alone (docs/paper-notes.md, "Acceleration
limits").

Held at the end alone, a robot whose braking line reached past a keep-out
circle was let on towards it: the end lay beyond the circle, outside it, while
the line crossed it, and the robot, braking and turning at its limits, went
0.23 m into the circle (the generated mission gen-041-polyline, 0.24 m with
its sensor noise).
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from scipy.optimize import minimize_scalar

from wmr_mission import mission_from_dict, run_mission
from wmr_mission.controllers.constrained_tracking import (
    held_on_braking_line,
    held_where_braking_ends,
    keep_constraints,
)
from wmr_mission.geometry.regions import CircleRegion, constraint_rows
from wmr_mission.kernels.corrective import row_value_with_margin
from wmr_mission.kernels.model import braking_distance
from wmr_mission.kernels.records import Plant, scratch

# gen-041-polyline's route phase, without its noise: a robot joining a
# polyline at 4.3 m/s, the corner's rock ahead of it.
ROUTE = """\
version: 1
name: braking-past-a-rock
robot:
  dt: 0.01
  initial_state: {x: -2.159, y: 0.33, theta: -1.689}
  limits:
    v: 5.106
    omega: 7.488
    acceleration: {v: 3.334, omega: 14.914}
regions:
  rock: {type: circle, center: [-8.912, 3.405], radius: 0.485}
phases:
- name: route
  track:
    path:
      type: polyline
      points: [[-4.132, 3.419], [-7.56, 4.403], [-10.512, 2.891], [-12.586, 2.873]]
      speed: 2.952
      corner_radius: 1.003
  until: {elapsed: 3.5}
  constraints:
  - {stay_outside: rock}
"""


def test_a_robot_braking_at_its_limits_past_a_corner_keeps_out_of_the_rock() -> None:
    result = run_mission(mission_from_dict(yaml.safe_load(ROUTE)))
    x, y = result.x, result.y
    clearance = np.hypot(x + 8.912, y - 3.405) - 0.485
    # it passed the rock (3.5 s take it beyond), and never entered it
    assert np.min(np.hypot(x + 8.912, y - 3.405)) < 1.0
    assert clearance.min() > 0.0, clearance.min()


def test_a_row_is_held_where_the_braking_line_crosses_a_zone_its_end_is_beyond() -> None:
    """At 3 m/s and 1.5 m/s^2 the line runs 3 m on: through a circle of radius
    0.5 m 1.5 m ahead, to 1 m past it. Its end is outside the circle (the
    row's value there is -7.9); held at the line's point furthest in, the
    row's value is its value at the centre, 1 (the ellipse row's
    ``1 - (d / r)^2``), inside the line."""
    rock = CircleRegion(type="circle", center=(1.5, 0.0), radius=0.5)
    kinds, params = constraint_rows(rock, "outside")
    # next_: (x, y, heading, v, omega) at k+1; the row's value there, -1 m
    held, *_, inner = held_where_braking_ends(
        int(kinds[0]), params[0], 0.0, 0.0, -1.0, -1.0, 0.0,
        (0.0, 0.0, 0.0, 3.0), (0.0, 0.0, 0.0, 3.0, 0.0), (0.0, 0.0, 0.0, 0.0), 1.5, 0.01,
    )  # fmt: skip
    assert held > 0.96
    assert inner


def test_a_circle_the_line_crosses_between_sixteen_points_is_held_where_it_is_deepest() -> None:
    """At 5.1 m/s and 1 m/s^2 the line runs 12.98 m on: 16 points on it were
    0.81 m apart, and a circle of radius 0.5 m 0.4 m off the line, midway
    between two of them, lay outside both (the row's value -0.30 there),
    though the line crosses it 0.3 m either side of its middle. The row is
    quadratic along the line: held at its vertex, ``1 - (0.4 / 0.5)^2``."""
    spacing = braking_distance(5.1, 1.0, 0.01) / 16
    rock = CircleRegion(type="circle", center=(4.5 * spacing, 0.4), radius=0.5)
    kinds, params = constraint_rows(rock, "outside")
    held, *_, inner = held_on_braking_line(
        int(kinds[0]), params[0], 0.0, 0.0, 0.0, 0.0, 5.1, 1.0, 0.01
    )
    assert held == pytest.approx(1.0 - (0.4 / 0.5) ** 2, abs=1e-12)
    assert inner


def _largest_on_line(
    kind: int, p: np.ndarray, theta: float, v: float, rate: float, dt: float
) -> float:
    """The row's largest value over the braking line from the origin, found
    by a bounded search along it (the circle row is concave along a line)."""
    ahead = braking_distance(v, rate, dt)
    c, s = np.cos(theta), np.sin(theta)

    def minus(share: float) -> float:
        return -row_value_with_margin(kind, p, 0.0, ahead * share * c, ahead * share * s)[0]

    found = minimize_scalar(minus, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-12})
    return -min(float(found.fun), minus(1.0), minus(0.0))


@pytest.mark.parametrize(
    ("theta", "v", "omega", "where"),
    [
        (0.3, 3.0, 0.5, "inside"),  # the circle astride the line, its end beyond
        (0.3 + np.pi, -3.0, 0.5, "inside"),  # the same, reversing
        (0.1, 2.0, -1.0, "end"),  # the line ends inside the circle
        (0.1 + np.pi, -2.0, -1.0, "end"),  # the same, reversing
        (0.25, 0.005, 0.0, "stopped"),  # stopped within the next sample
    ],
)
def test_the_braking_lines_sensitivities_are_those_of_its_largest_value(
    theta: float, v: float, omega: float, where: str
) -> None:
    """Finite differences of the row's largest value over the line (found
    along it, not at the 16 points) against the sensitivities returned:
    d/dv is the end's where the end is furthest in, 0 inside the line (the
    row's gradient is across it there) and when stopped; d/domega turns the
    line about its start."""
    rock = CircleRegion(type="circle", center=(1.5, 0.4), radius=0.5)
    kinds, params = constraint_rows(rock, "outside")
    kind, p = int(kinds[0]), params[0]
    rate, dt, h = 1.5, 0.05, 1e-5

    def largest(v: float, omega: float) -> float:
        return _largest_on_line(kind, p, theta + omega * dt, v, rate, dt)

    by_v = (largest(v + h, omega) - largest(v - h, omega)) / (2 * h)
    by_omega = (largest(v, omega + h) - largest(v, omega - h)) / (2 * h)
    _, hx, hy, e00, e01, e10, e11, inner = held_on_braking_line(
        kind, p, 0.0, 0.0, 0.0, theta + omega * dt, v, rate, dt
    )
    assert inner == (where == "inside")
    if where == "end":
        assert abs(by_v) > 0.5
    else:
        assert by_v == pytest.approx(0.0, abs=1e-6)
    assert hx * e00 + hy * e10 == pytest.approx(by_v, rel=1e-6, abs=1e-9)
    # the sampled point lies within half a spacing of the largest's, 1/32 of the line
    assert hx * e01 + hy * e11 == pytest.approx(by_omega, rel=0.1, abs=1e-9)
    if where == "stopped":
        assert (e00, e01, e10, e11) == (0.0, 0.0, 0.0, 0.0)


def _speed_steps(v_prev: float) -> float:
    """The speed's change the zone filter asks for at heading 0 at v_prev,
    a circle astride the braking line, the turn at its acceleration limit."""
    kinds, params = constraint_rows(
        CircleRegion(type="circle", center=(1.8, 0.25), radius=0.5), "outside"
    )
    u = np.array([v_prev, 0.0])
    keep_constraints(
        np.zeros(3), np.array([v_prev, 0.0]), kinds, params, 0.05,
        Plant(0.01, np.array([4.0, 3.0, 1.5, 5.0])), scratch(), u, 0.2,
    )  # fmt: skip
    return float(u[0] - v_prev)


def test_the_speed_asked_for_does_not_swing_as_the_deepest_point_moves_along_the_line() -> None:
    """Held at a point inside the braking line, the row's largest value over
    the line does not move with v (the line's points move along it, the
    row's gradient is across it). Taken from the sampled point's gradient,
    the speed's change swung between +a dt and -a dt from one v_prev to the
    next (7 swings over 2.0..3.0 m/s)."""
    steps = [_speed_steps(v) for v in np.linspace(2.0, 3.0, 41)]
    signs = np.sign([step for step in steps if round(step, 9) != 0.0])
    swings = int(np.count_nonzero(np.diff(signs)))
    assert swings == 0, np.round(steps, 4)


def test_braking_past_the_rock_does_not_swing_the_speed_between_its_limits() -> None:
    """ROUTE at its acceleration limit 3.334 m/s^2: the speed's acceleration
    swings from beyond half the limit one way to beyond half the other only
    where braking ends (a switch, each held 0.1 s and more), never back and
    forth within a few samples (the chatter the sampled gradient made, three
    swings in 0.04 s past the rock)."""
    result = run_mission(mission_from_dict(yaml.safe_load(ROUTE)))
    rate = np.diff(np.asarray(result.v)) / (3.334 * result.dt)
    swings = np.flatnonzero(
        (np.abs(rate[1:]) > 0.5) & (np.abs(rate[:-1]) > 0.5) & (rate[1:] * rate[:-1] < 0)
    )
    assert swings.size >= 1  # the switches where braking ends
    assert np.diff(swings).min(initial=10**6) >= 10, np.asarray(result.t)[swings + 1]
