"""A detour starts as far before its zone as the controller keeps off it:
the judge grows the zone by that margin (the body's reach and the
estimate's) when it decides which samples are a detour
(verdicts/tracking.py, _detours)."""

from __future__ import annotations

from wmr_mission import mission_from_text, run_mission
from wmr_mission.verdicts.metrics import judge

# A user's mission: a line straight through a boulder's centre, the robot a
# 0.4 m box (reach 0.36 m from its axle).
THROUGH_A_BOULDER = """\
version: 1
name: line-through-a-boulder
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1.0, omega: 2.0}
  footprint: {polygon: [[0.3, 0.2], [-0.1, 0.2], [-0.1, -0.2], [0.3, -0.2]]}
regions:
  boulder: {type: circle, center: [3, 0], radius: 0.5}
phases:
  - name: go
    track: {path: {type: line, towards: [6, 0], speed: 0.5}}
    constraints: [{stay_outside: boulder}]
    until: {near: {point: [6, 0], tolerance: 0.05}}
    timeout: 25
"""


def test_a_bodys_detour_is_not_judged_as_tracking() -> None:
    """Before: the detour's first 0.7 m, begun 1.4 m before the boulder,
    was judged as tracking: cross-track 0.286 m where 0.1 is allowed, a
    failure of a run that went round cleanly."""
    run = run_mission(mission_from_text(THROUGH_A_BOULDER))
    assert run.outcome.value == "success"
    tracking = judge(run, run.mission)["phases"][0]["tracking"]
    assert tracking["cross_track_error_max"] < 0.1
    assert tracking["detour_offset_max"] > 0.9  # round the boulder, not through it
