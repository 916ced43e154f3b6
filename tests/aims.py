"""How far aim_round_zones moves the aims of a sampled path across it: the
zone filter's aim, read without a run (controllers/constrained_tracking)."""

from __future__ import annotations

import numpy as np

from wmr_mission.controllers.constrained_tracking import aim_round_zones, ways_round


def moved_across(path: np.ndarray, kinds: np.ndarray, params: np.ndarray) -> np.ndarray:
    """How far aim_round_zones moves each aim (rows x, y, tx, ty) across its
    path, its ways round found on the path itself (look-ahead 0.05 m, margin
    0.1 m, gap 0.05 m)."""
    ways = ways_round(path[:, 0], path[:, 1], kinds, params)
    moved = []
    for row in path:
        aim = row.copy()
        aim_round_zones(aim, kinds, params, ways, 0.05, 0.1, 0.05)
        moved.append(-row[3] * (aim[0] - row[0]) + row[2] * (aim[1] - row[1]))
    return np.array(moved)


def spiral_past(rock: str) -> str:
    """A user's mission: a spiral out at 0.5 rad/s, growing 0.06 m a second,
    until it reaches a rim of radius 3 m, keeping out of ``rock`` (a region's
    YAML flow mapping)."""
    return f"""\
version: 1
name: spiral-past-a-rock
robot:
  dt: 0.01
  initial_state: {{x: 0.5, y: 0, theta: 1.5708}}
  limits: {{v: 1.6, omega: 2.5}}
regions:
  rock: {rock}
  rim: {{type: circle, center: [0, 0], radius: 3}}
phases:
  - name: spiral
    track:
      path: {{type: spiral, center: [0, 0], initial_radius: 0.5, growth_rate: 0.06,
             angular_rate: 0.5, start: 0}}
    constraints: [{{stay_outside: rock}}]
    until: {{reaches: rim}}
    timeout: 60
"""
