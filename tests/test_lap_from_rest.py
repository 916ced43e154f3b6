"""A lap of a repeated polyline entered where the lap before rested: its
route is joined from the robot's estimate to a first point a hair away, a
leg of micrometres across the heading that the path leaves within its first
sample (kernels/loop.py, ``first_tangent``; docs/paper-notes.md, eq. (27),
"at a phase's first sample: a tangent left within it")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission import mission_from_text, run_mission
from wmr_mission.kernels.loop import first_tangent
from wmr_mission.verdicts.metrics import judge

# A user's laps: a closed polyline at 0.8 m/s whose 20.6 m take 25.8 s,
# each lap 26.5 s long: the reference rests 0.7 s at the route's end, where
# the next lap starts; 1 cm of measurement noise.
LAPS = """\
version: 1
name: laps-from-rest
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1.5, omega: 2}
sensors: {measure: [x, y, theta], noise_std: {x: 0.01, y: 0.01, theta: 0.01}, seed: 2}
estimator: {type: constrained-observer, initial_estimate: {x: 0, y: 0, theta: 0}}
controller: {type: CONTROLLER}
phases:
  - name: laps
    repeat:
      times: 2
      phases:
        - name: lap
          track:
            path:
              type: polyline
              points: [[0, 0], [4, 0], [4, 3], [-4, 3], [-4, 0], [0, 0]]
              corner_radius: 0.8
              speed: 0.8
          until: {elapsed: 26.5}
"""


@pytest.mark.parametrize("controller", ["paper", "kanayama"])
def test_a_lap_entered_at_rest_starts_without_a_kick(controller: str) -> None:
    """Lap 2's route starts with a leg from the estimate, 72 um from the first
    point and across the heading, run through in 45 us: its tangent, at
    t_0 only, made the law turn the output towards it and feed its turn back
    forward in one sample. The turn rate went to its limit on the lap's first
    sample (-2 rad/s, the paper's law; Kanayama's feed-forward the same) and
    back: `turn_rate_jump_max` 2.39 and 2.40 where 2 is allowed. With the
    tangent at t_1 standing in, the lap starts as the first did."""
    mission = mission_from_text(LAPS.replace("CONTROLLER", controller))
    result = run_mission(mission)
    summary = judge(result, mission.model_dump(mode="json"))
    first, second = summary["phases"]
    assert second["name"] == "lap#2"
    start = int(np.argmax(result.t >= second["start"] - 1e-9))
    # the lap's first input: at speed along the heading, hardly turning
    assert abs(result.omega[start]) < 0.3
    assert abs(result.v[start] - 0.8) < 0.05
    # the lap's largest jump no larger than the first lap's, away from the limit
    assert second["inputs"]["turn_rate_jump_max"] < 1.1 * first["inputs"]["turn_rate_jump_max"]
    assert second["inputs"]["turn_rate_jump_max"] < 1.2
    assert summary["outcome"] == "success"


def test_the_first_tangent_gives_way_to_the_next_beyond_a_sample_s_turn() -> None:
    """``first_tangent``: a tangent turning by more than the robot's turn in a
    sample is replaced by the next one; within it, kept to the bit."""
    most = 2.0 * 0.01
    now = np.array([0.0, 0.0, -0.0702, 0.9975, 9.0, 9.0, 0.0, 1.0])
    ahead = np.array([0.008, 0.0, 1.0, 0.0, 9.0, 9.0, 0.0, 1.0])
    first_tangent(now, ahead, most)
    assert list(now[:4]) == [0.0, 0.0, 1.0, 0.0]
    turn = 0.9 * most  # a curve the robot can follow: unchanged
    now = np.array([0.0, 0.0, 1.0, 0.0])
    ahead = np.array([0.008, 0.0, math.cos(turn), math.sin(turn)])
    first_tangent(now, ahead, most)
    assert list(now) == [0.0, 0.0, 1.0, 0.0]
