"""A phase that ends on the ramp into a detour, or in it: the path goes on past
the phase's end, the law aims along it, and the detour is judged against the
zone as the path meets it there (verdicts/tracking.py, ``_continued``)."""

from __future__ import annotations

import numpy as np
import pytest

from wmr_mission import mission_from_text, run_mission
from wmr_mission.verdicts.metrics import judge

# A user's line past a rock 1 m across, split in two phases at FIRST seconds.
SPLIT = """\
version: 1
name: a-line-split-at-a-rock
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1, omega: 2}
regions:
  rock: {type: circle, center: [3, 0], radius: 0.5}
phases:
  - name: first
    track: {path: {type: line, towards: [8, 0], speed: 0.6}}
    constraints: [{stay_outside: rock}]
    until: {elapsed: FIRST}
  - name: second
    track: {path: {type: line, towards: [8, 0], speed: 0.6}}
    constraints: [{stay_outside: rock}]
    until: {elapsed: 8}
"""


@pytest.mark.parametrize("first", [4.3, 4.8])
def test_a_phase_that_ends_in_a_detour_is_judged_by_the_whole_zone(first: float) -> None:
    """The first phase's path ends 0.42 m (4.3 s) or 0.12 m (4.8 s) before
    the rock's centre, the robot already round its side: its detour was
    judged against how far the rock reaches into the first phase's own
    stretch (0.124 m at 4.3 s): `detour_offset_max = 0.515 (max 0.274)`, a
    false failure; a split 0.8 s sooner passed the same drive."""
    mission = mission_from_text(SPLIT.replace("FIRST", str(first)))
    result = run_mission(mission)
    summary = judge(result, mission)
    assert summary["outcome"] == "success", summary["message"]
    tracking = summary["phases"][0]["tracking"]
    # the robot's widest offset from the line in the first phase, from the
    # recorded columns alone: it went round the rock, not along the line
    offset = float(np.max(np.abs(result.y[result.phase == 0])))
    assert offset > 0.5
    assert tracking["detour_offset_max"] == pytest.approx(offset, abs=0.02)
    assert tracking["zone_reach"] >= 0.5  # the rock's radius, through its centre
