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
import yaml

from wmr_mission import mission_from_dict, run_mission
from wmr_mission.controllers.constrained_tracking import (
    held_where_braking_ends,
    keep_constraints,
)
from wmr_mission.geometry.regions import CircleRegion, constraint_rows
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
    row's value is nearly its value at the centre, 1 (the ellipse row's
    ``1 - (d / r)^2``, the line's points 0.19 m apart), inside the line."""
    rock = CircleRegion(type="circle", center=(1.5, 0.0), radius=0.5)
    kinds, params = constraint_rows(rock, "outside")
    # next_: (x, y, heading, v, omega) at k+1; the row's value there, -1 m
    held, *_, inner = held_where_braking_ends(
        int(kinds[0]), params[0], 0.0, 0.0, -1.0, -1.0, 0.0,
        (0.0, 0.0, 0.0, 3.0), (0.0, 0.0, 0.0, 3.0, 0.0), (0.0, 0.0, 0.0, 0.0), 1.5, 0.01,
    )  # fmt: skip
    assert held > 0.96
    assert inner


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
