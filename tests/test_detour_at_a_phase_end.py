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


# A line at 0.5 m/s for 6 s, ending at (3, 0) still moving; then another phase
# turns away. ZONES and CONSTRAINTS: the first phase's.
ENDS_MOVING = """\
version: 1
name: a-line-that-turns-away
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1, omega: 2}
regions:
ZONES
phases:
  - name: a
    track: {path: {type: line, towards: [10, 0], speed: 0.5}}
    constraints: CONSTRAINTS
    until: {elapsed: 6}
  - name: b
    track: {path: {type: line, towards: [3, -5], speed: 0.5}}
    until: {elapsed: 8}
"""


def _spoiled(zones: str, constraints: str, drift: np.ndarray) -> dict[str, object]:
    """The first phase's tracking, judged with its recorded y moved by
    ``drift`` (a function of t): a robot that left its path there."""
    text = ENDS_MOVING.replace("ZONES", zones).replace("CONSTRAINTS", constraints)
    mission = mission_from_text(text)
    result = run_mission(mission)
    assert judge(result, mission)["outcome"] == "success"  # as driven
    result.y[:] = result.y + drift(result.t) * (result.phase == 0)
    return judge(result, mission)


def test_a_zone_only_the_path_s_continuation_meets_excuses_nothing() -> None:
    """A rock 1.2 m past the first phase's end, on its straight continuation
    only: the law never goes round it (the next phase turns away), so a robot
    0.5 m off its path over the phase's last second is off its path, not on
    a detour's ramp (it was excused: a success)."""
    summary = _spoiled(
        "  rock: {type: circle, center: [4.2, 0], radius: 0.5}",
        "[{stay_outside: rock}]",
        lambda t: np.clip((t - 5.0) / 0.3, 0.0, 1.0) * 0.5,
    )
    assert summary["outcome"] == "expect-failed"
    assert summary["phases"][0]["tracking"]["cross_track_error_max"] == pytest.approx(0.5)


def test_a_keep_in_region_s_depth_past_its_edge_widens_no_detour_bound() -> None:
    """The path continued past the first phase's end runs out of the arena it
    keeps inside: its depth there counted as a zone's reach into the path
    (2.985 m where the rock's is 0.35), and a detour 1.1 m wide round a rock
    0.6 m across passed its bound."""
    summary = _spoiled(
        "  rock: {type: circle, center: [1.5, 0], radius: 0.3}\n"
        "  arena: {type: box, min: [-1, -6], max: [3.3, 1]}",
        "[{stay_outside: rock}, {stay_inside: arena}]",
        lambda t: -1.2 * np.exp(-(((t - 4.6) / 0.4) ** 2)),
    )
    tracking = summary["phases"][0]["tracking"]
    assert tracking["zone_reach"] < 0.5
    assert summary["outcome"] == "expect-failed"
    assert tracking["detour_offset_max"] > 1.0


# A line past a crate, split in two phases at 5 s, while the robot starts its
# swerve round the crate: the first phase's own path ends 0.5 m before it.
# CRATE: the crate's corners.
SWERVE = """\
version: 1
name: a-line-split-on-the-ramp
robot: {dt: 0.01, initial_state: {x: 0, y: 0, theta: 0}, limits: {v: 1.0, omega: 2.0}}
regions:
  crate: {type: box, CRATE}
phases:
  - name: first
    track: {path: {type: line, heading: 0, speed: 0.5}}
    constraints: [{stay_outside: crate}]
    until: {elapsed: 5}
  - name: second
    track: {path: {type: line, heading: 0, speed: 0.5, start: current}}
    constraints: [{stay_outside: crate}]
    until: {elapsed: 6}
"""


@pytest.mark.parametrize(
    "crate",
    ["min: [3, -0.2], max: [3.5, 0.4]", "min: [3, -0.45], max: [3.5, 0.25]"],
    ids=["round-the-right", "round-the-left"],
)
def test_a_phase_that_ends_on_the_ramp_into_a_zone_only_ahead_is_a_detour(crate: str) -> None:
    """The first phase's path never comes near the crate, its continuation
    does: the robot left its line 0.8 m before the phase's end, ramping away
    from the crate as the law does, and was judged as tracking there:
    `first: cross_track_error_max = 0.117 (max 0.1)`, a false failure."""
    mission = mission_from_text(SWERVE.replace("CRATE", crate))
    result = run_mission(mission)
    summary = judge(result, mission)
    assert summary["outcome"] == "success", summary["message"]
    first = result.phase == 0
    # the robot's widest offset from the line in the first phase, from the
    # recorded columns alone: it had started round the crate
    offset = float(np.max(np.abs(result.y[first])))
    assert offset > 0.1
    tracking = summary["phases"][0]["tracking"]
    assert tracking["detour_time"] > 0.0
    assert tracking["detour_offset_max"] == pytest.approx(offset, abs=0.02)
    assert tracking["zone_reach"] > 0.1


def test_the_ramp_into_a_zone_only_ahead_excuses_no_more_than_the_ramp() -> None:
    """The same drive, the robot's recorded y moved 0.3 m further off over
    the first phase's last half second, to the side it ramps to: the ramp
    lets the aim be 0.17 m across at the phase's end, so the robot is off
    its path, not on a detour's ramp."""
    mission = mission_from_text(SWERVE.replace("CRATE", "min: [3, -0.2], max: [3.5, 0.4]"))
    result = run_mission(mission)
    assert judge(result, mission)["outcome"] == "success"  # as driven
    drift = np.clip((result.t - 4.5) / 0.2, 0.0, 1.0) * -0.3
    result.y[:] = result.y + drift * (result.phase == 0)
    summary = judge(result, mission)
    assert summary["outcome"] == "expect-failed"
    tracking = summary["phases"][0]["tracking"]
    assert tracking["cross_track_error_max"] > 0.3
