"""A track phase that outlasts its path: the reference rests at the path's
end, and the robot holds there facing the way the path last went
(kernels/loop.py, ``path_point``; docs/paper-notes.md, eq. (27), "A resting
path's tangent held")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission import mission_from_text, run_mission
from wmr_mission.kernels.loop import path_point

# A user's patrol: a 2 m line at 0.5 m/s (4 s), the phase 14 s long, with
# 1.9 cm and 0.025 rad of measurement noise.
OUTLASTED = """\
version: 1
name: a-line-outlasted
robot:
  dt: 0.02
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 0.77, omega: 1.83}
sensors:
  measure: [x, y, theta]
  noise_std: {x: 0.019, y: 0.019, theta: 0.025}
  seed: SEED
phases:
- name: patrol
  track:
    path: {type: polyline, points: [[0, 0], [2, 0], [2, -2]], speed: 0.5}
  until: {elapsed: 14}
"""


@pytest.mark.parametrize("seed", [54, 7])
def test_a_robot_at_its_path_s_end_holds_its_heading_under_noise(seed: int) -> None:
    """With the robot's heading standing in for the resting path's tangent,
    the law's output (a point ahead of the axle) was aimed at a point that
    turned with the robot: turning closed no error, yet the law turned to
    close the estimate's error across the heading, and the robot spun in
    place, ever faster (a user's patrol: 2.11 rad in 12 s, at up to
    0.27 rad/s, noise-free not at all). Its last tangent held, the aim
    stands, and the robot keeps facing down the last leg."""
    mission = mission_from_text(OUTLASTED.replace("SEED", str(seed)))
    result = run_mission(mission)
    assert result.outcome.value == "success"
    # the path ends at 8 s; the robot, 0.29 m behind it after the corner, arrives by 10 s
    resting = result.t >= 10.0
    heading = np.unwrap(result.theta)[resting]
    # true heading within 0.1 rad of the last leg's (-pi/2) throughout the rest
    assert np.abs(heading - (-math.pi / 2)).max() < 0.1
    # and at the end point: no creep away along a circle either
    assert np.hypot(result.x[resting] - 2.0, result.y[resting] + 2.0).max() < 0.03
    assert np.sqrt(np.mean(result.omega[resting] ** 2)) < 0.06


def test_a_resting_path_keeps_the_tangent_it_last_moved_along() -> None:
    """``path_point``: a moving row's tangent is kept; a resting row (NaN)
    takes it, not the robot's heading; a path resting since the phase began
    takes the heading of its first resting row and keeps that."""
    rows = np.array([[0.0, 0.0, 0.6, 0.8], [1.0, 1.0, math.nan, math.nan]])
    held = np.full(2, math.nan)
    out = np.zeros(4)
    path_point(rows, 1, 0.3, held, out)  # resting since the phase began
    assert list(out) == [1.0, 1.0, math.cos(0.3), math.sin(0.3)]
    path_point(rows, 1, 1.2, held, out)  # the heading turned: the tangent did not
    assert list(out) == [1.0, 1.0, math.cos(0.3), math.sin(0.3)]
    path_point(rows, 0, 1.2, held, out)  # moving
    assert list(out) == [0.0, 0.0, 0.6, 0.8]
    path_point(rows, 1, 1.2, held, out)  # resting after moving: the last tangent
    assert list(out) == [1.0, 1.0, 0.6, 0.8]
