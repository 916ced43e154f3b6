"""A phase entered while the robot goes round a zone (a lap of a repeat that
begins mid-detour) aims round the zone from its first sample, where its
zones ask, not from the path itself (controllers/paper.py, ``next_input``)."""

from __future__ import annotations

import numpy as np

from wmr_mission import mission_from_text, run_mission
from wmr_mission.verdicts.metrics import judge

# A user's laps: a closed polyline round a yard, a polygon rock on its first
# leg, a round body, 1.5 cm of noise; each 25 s lap ends somewhere else, the
# third begins while the robot is round the rock.
LAPS = """\
version: 1
name: laps-round-a-rock
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1, omega: 2}
  footprint: {radius: 0.2}
sensors:
  measure: [x, y, theta]
  noise_std: {x: 0.015, y: 0.015, theta: 0.005}
  seed: 3
regions:
  rock: {type: polygon, vertices: [[2.5, -0.3], [3.5, -0.3], [3.2, 0.4], [2.7, 0.4]]}
phases:
  - name: laps
    repeat:
      times: 3
      phases:
        - name: loop
          track:
            path:
              type: polyline
              points: [[0, 0], [5, 0], [5, 2.5], [0, 2.5]]
              closed: true
              corner_radius: 0.5
              speed: 0.6
          constraints: [{stay_outside: rock}]
          until: {elapsed: 25}
"""


def test_a_lap_entered_mid_detour_goes_on_round_the_zone() -> None:
    """The third lap began with the robot 0.35 m beside its path, round the
    rock's side: its aim was pulled back to the path, the robot crept up to
    the rock, stopped, reversed at 0.40 m/s and jumped its turn rate by
    2.39 rad/s where 2 is allowed (an expect-failed run)."""
    mission = mission_from_text(LAPS)
    result = run_mission(mission)
    summary = judge(result, mission)
    assert summary["outcome"] == "success", summary["message"]
    third = result.phase == 2
    start = int(np.argmax(third))
    # the third lap begins beside the path, round the rock
    assert 1.5 < result.x[start] < 3.6
    assert abs(result.y[start]) > 0.3
    # it goes on forwards, never backing off the rock (from the recorded columns)
    assert result.v[third].min() > 0.0
    assert np.abs(np.diff(result.omega[third])).max() < 1.5
