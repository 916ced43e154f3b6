"""The tracking law's turns on the generated missions that failed on them
(docs/soundness.md): the speed while the turn rate is at its limit, and the
aim's offset round a zone where the path's tangent swings."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from wmr_mission import mission_from_dict, mission_from_text, run_mission
from wmr_mission.verdicts.metrics import judge

GENERATED = Path(__file__).resolve().parent / "data" / "generated"


def _first_phase(name: str) -> tuple[dict, dict]:
    data = yaml.safe_load((GENERATED / f"{name}.yaml").read_text())
    data["phases"] = data["phases"][:1]
    mission = mission_from_dict(data)
    result = run_mission(mission)
    return data, judge(result, mission.model_dump(mode="json"))


def test_a_robot_turning_at_its_limit_slows_to_the_way_it_must_go() -> None:
    """A line 2.5 rad off the robot's heading (gen-198-line, no acceleration
    limits): the law drove on while it turned at the 2.53 rad/s limit, and
    turned 3.3 rad, more than half a turn, to come back to the line: a fight
    at the limit. With the speed cut by the cosine of the angle to the way
    while the turn is at its limit it turns less than half a turn."""
    data, summary = _first_phase("gen-198-line")
    assert "acceleration" not in data["robot"]["limits"]
    assert summary["outcome"] == "success", summary["message"]
    inputs = summary["phases"][0]["inputs"]
    assert inputs["turn_rate_fight_time"] == 0.0


# A user's mission: the robot put down facing 2.8 rad away from its line.
FACING_AWAY = """\
version: 1
name: line-facing-away
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 2.8}
  limits: {v: 1.0, omega: 1.5}
phases:
  - name: go
    track: {path: {type: line, heading: 0, speed: 0.6}}
    until: {elapsed: 15}
"""


def test_a_robot_facing_away_turns_before_it_drives_even_where_the_law_asks_more_speed() -> None:
    """The law asked up to 2 m/s, more than the 1 m/s limit, to catch its
    reference up, and the cosine cut that speed, not the one the robot can
    have: it drove at its limit while it still turned, and turned 3.2 rad at
    the 1.5 rad/s limit in one stretch to come back, more than half a turn (a
    fight, turn_rate_fight_time 2.13 s). With the speed counted no higher than
    the limit over cos FULL_SPEED_TURN, 3.06 rad."""
    mission = mission_from_text(FACING_AWAY)
    result = run_mission(mission)
    summary = judge(result, mission.model_dump(mode="json"))
    assert summary["outcome"] == "success", summary["message"]
    assert summary["phases"][0]["inputs"]["turn_rate_fight_time"] == 0.0
    at_limit = np.abs(result.omega) >= 1.5
    stretch = np.flatnonzero(~at_limit)[0]  # the first stretch at the limit, from the start
    assert 2.8 < stretch * 0.01 * 1.5 < 3.1  # the turn it must make, and less than half a turn


def test_a_robot_turning_away_from_its_way_at_its_limit_keeps_its_speed() -> None:
    """An elliptical spiral started from an estimate 0.3 m off
    (gen-091-elliptical-spiral): the law turns the long way round at its
    5.14 rad/s limit, away from the way its tracked point must move for the
    first samples. Cut by the cosine there too, the robot stood and turned
    4.6 rad at the limit in one stretch, a fight; the cut applies only to a
    turn towards the way."""
    _, summary = _first_phase("gen-091-elliptical-spiral")
    assert summary["outcome"] == "success", summary["message"]
    assert summary["phases"][0]["inputs"]["turn_rate_fight_time"] == 0.0


def test_the_aim_round_a_zone_at_a_corner_does_not_leap_from_side_to_side() -> None:
    """A polyline whose first corner faces a keep-out circle (gen-039-polyline,
    dt 0.025 s): as the corner's tangent swept across the circle the aim
    leapt 0.11 m to its left and then 0.12 m to its right, and the turn rate
    jumped from 6.4 to -7.3 rad/s in one sample (limit 7.29)."""
    data, summary = _first_phase("gen-039-polyline")
    assert data["phases"][0]["constraints"]
    assert summary["outcome"] == "success", summary["message"]
    limit = data["robot"]["limits"]["omega"]
    assert summary["phases"][0]["inputs"]["turn_rate_jump_max"] < limit


def test_the_aims_offset_moves_at_most_its_slope_of_the_paths_step() -> None:
    """Within the slope the offset asked for is kept exactly (a straight
    path's ramp is never cut); beyond it, the offset moves towards it by the
    slope times the path's step."""
    from wmr_mission.controllers.constrained_tracking import OFFSET_SLOPE, ramped_offset

    assert ramped_offset(0.03, 0.04, 0.0, 0.0, 0.05 / OFFSET_SLOPE) == (0.03, 0.04)
    x, y = ramped_offset(0.3, 0.4, 0.0, 0.0, 0.05 / OFFSET_SLOPE)
    assert abs(x - 0.03) < 1e-15
    assert abs(y - 0.04) < 1e-15
    assert ramped_offset(0.0, 0.0, 0.1, 0.0, 0.0) == (0.1, 0.0)  # a path at rest
