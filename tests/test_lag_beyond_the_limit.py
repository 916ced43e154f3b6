"""A path faster than the robot's speed limit leaves a lag no time can take
out: after a detour it is judged, not excused as the robot rejoining its
reference (spec/numbers.py, ``MissionNumbers.recovery_time``)."""

from __future__ import annotations

import numpy as np

from wmr_mission import mission_from_text, run_mission
from wmr_mission.spec.numbers import mission_numbers
from wmr_mission.verdicts.metrics import judge

# A user's delivery: a line at 0.8 m/s past a rock, the robot's limit 0.62 m/s
# (`validate` warns that the path is faster than the limit).
DELIVERY = """\
version: 1
name: a-path-too-fast
robot:
  dt: 0.02
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 0.62, omega: 2.5}
sensors:
  measure: [x, y, theta]
  noise_std: {x: 0.005, y: 0.005, theta: 0.005}
  seed: 7
regions:
  rock: {type: circle, center: [3, 0.45], radius: 0.5}
phases:
  - name: out
    track:
      path: {type: polyline, points: [[6, 0]], speed: 0.8}
    constraints: [{stay_outside: rock}]
    until: {near: {point: [6, 0], tolerance: 0.05}}
    timeout: 20
"""


def test_a_robot_that_cannot_keep_up_after_a_detour_fails_its_lag() -> None:
    """The robot fell 1.3 m behind its reference, yet the lag was excused for
    the rest of the phase as its rejoining, judged at a tenth of the limit
    over a reference it could never catch: `lag max 0.234 m`, a success."""
    mission = mission_from_text(DELIVERY)
    result = run_mission(mission)
    summary = judge(result, mission)
    # how far the reference point is from the robot once the rock is passed
    # (x beyond 4 m): measured here from the recorded columns alone
    past = result.x > 4.0
    behind = np.hypot(result.x_ref - result.x, result.y_ref - result.y)[past]
    behind = behind[np.isfinite(behind)]  # the closing row has no reference
    assert behind.max() > 1.0
    lag = summary["phases"][0]["tracking"]["along_track_lag_max"]
    assert lag > 0.8 * behind.max()
    assert summary["outcome"] == "expect-failed"
    missed = [e["metric"] for e in summary["expectations"] if not e["met"]]
    assert "along_track_lag_max" in missed


def test_no_time_is_allowed_to_close_a_gap_on_a_reference_at_the_limit() -> None:
    numbers = mission_numbers(None, 0.02, (0.62, 2.5))
    at_limit = [numbers.recovery_time(gap, 0.62) for gap in (0.0, 1.0, 10.0)]
    beyond = [numbers.recovery_time(gap, 0.8) for gap in (0.0, 1.0, 10.0)]
    assert at_limit[0] == at_limit[1] == at_limit[2]
    assert beyond[0] == beyond[1] == beyond[2]
    # below the limit a gap still takes time to close
    assert numbers.recovery_time(1.0, 0.5) > numbers.recovery_time(0.0, 0.5) + 1.0
