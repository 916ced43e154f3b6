"""A timeout says how far the phase's goal still was: a park that ran out of
time 3 rad short of its heading said only `phase 'dock' timed out after
6.82 s`, leaving the user to dig the pose out of trajectory.csv
(sim/runner.py, ``_Run._timed_out``)."""

from __future__ import annotations

import math
import re

from wmr_mission import mission_from_text, run_mission

# A user's dock: 2.6 m away, then a turn of more than 3 rad, in too little time.
DOCK = """\
version: 1
name: short-dock
robot:
  dt: 0.02
  initial_state: {x: 0, y: 0, theta: 0.195}
  limits: {v: 0.89, omega: 2.35}
phases:
  - name: dock
    regulate:
      target: {x: 1.258, y: 2.281, theta: -2.055}
    until:
      settled: {position: 0.03, heading: 0.03}
    timeout: 3
"""


def _wrapped(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def test_a_timed_out_park_says_how_far_its_target_was() -> None:
    result = run_mission(mission_from_text(DOCK))
    assert result.outcome.value == "timeout"
    found = re.fullmatch(
        r"phase 'dock' timed out after 3 s at t = 3 s, its estimate (\S+) m and (\S+) rad "
        r"from its target(?:, its last input \S+ m/s)? \(settled asks 0\.03 m(?:,| and) 0\.03 rad"
        r"(?: and at most \S+ m/s)?\)",
        result.message,
    )
    assert found is not None, result.message
    # the numbers are the last sample's estimate, as the condition reads it
    x, y, theta = result.x_est[-1], result.y_est[-1], result.theta_est[-1]
    position = math.hypot(x - 1.258, y - 2.281)
    heading = abs(_wrapped(theta + 2.055))
    assert float(found[1]) == float(f"{position:.3g}")
    assert float(found[2]) == float(f"{heading:.3g}")
    assert position > 0.03 or heading > 0.03  # it did time out short of its goal
    # as docs/run-directory.md quotes it
    assert result.message == (
        "phase 'dock' timed out after 3 s at t = 3 s, its estimate 0.158 m and "
        "3.09 rad from its target, its last input 0.322 m/s (settled asks 0.03 "
        "m, 0.03 rad and at most 0.01 m/s)"
    )


def test_a_timeout_on_a_region_or_with_a_reaction_says_where_and_when() -> None:
    """A `reaches` goal gets its distance too (it had none), and a timeout a
    reaction takes says its mission time as a failing one does."""
    text = """\
version: 1
name: seek
robot:
  dt: 0.02
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1, omega: 2}
regions:
  goal: {type: circle, center: [6, 0], radius: 1}
phases:
  - name: first
    track: {path: {type: line, heading: 0, speed: 0.5}}
    until: {elapsed: 1}
  - name: seek
    track: {path: {type: line, heading: 0, speed: 1}}
    until: {reaches: goal}
    timeout: 2
    on_timeout: {retry: {times: 1, then: fail}}
"""
    result = run_mission(mission_from_text(text))
    assert result.outcome.value == "timeout"
    x, y = result.x_est[-1], result.y_est[-1]
    left = math.hypot(x - 6.0, y) - 1.0  # from the circle's edge
    found = re.search(
        r"at t = 5 s, its estimate (\S+) m from the edge of region 'goal'", result.message
    )
    assert found is not None, result.message
    assert abs(float(found[1]) - left) < 0.01  # the edge sampled
    retried = result.transitions[1]
    assert retried.why is not None
    assert retried.why.startswith("phase 'seek' timed out after 2 s at t = 3 s, its estimate")


def test_a_hold_waiting_for_a_heading_says_it_keeps_its_pose() -> None:
    """A hold keeps the pose it was entered at: a `heading` (or `near`,
    `reaches`) that pose does not meet never holds, and the timeout said only
    how far the heading was, as if the robot had been turning to it."""
    text = """\
version: 1
name: wait-for-a-heading
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
phases:
  - name: wait
    hold: {}
    until: {heading: {target: 1.57, tolerance: 0.05}}
    timeout: 2
"""
    result = run_mission(mission_from_text(text))
    assert result.outcome.value == "timeout"
    assert result.message == (
        "phase 'wait' timed out after 2 s at t = 2 s, its estimate 1.57 rad from heading "
        "1.57 (heading asks 0.05 rad): a hold keeps the pose it was entered at"
    )
