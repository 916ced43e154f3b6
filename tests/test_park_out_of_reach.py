"""A park whose target lies within the band the controller keeps round a zone
(the disc round a polygon body and the estimate's margin) cannot settle: its
timeout says why, the zone and the distances named
(wmr_mission/sim/plan.py, _out_of_reach; docs/paper-notes.md, eq. (28), "A
target within the band kept round a zone")."""

from __future__ import annotations

import math

from wmr_mission import mission_from_text, run_mission

# A user's park beside a shelf: the body, 0.8 x 0.3 m with the axle 0.25 m
# from its back, clears the shelf by 0.12 m at the target, but the disc round
# it (0.570 m) and the estimate's margin (0.05 m) hold the axle 0.62 m from the
# shelf: 0.35 m short of the target. Before, the robot stood at the band's edge
# from t = 3.7 s, v and omega ~0, until the timeout.
BESIDE_A_SHELF = """\
version: 1
name: park-beside-a-shelf
robot:
  dt: 0.01
  initial_state: {{x: 0, y: -1.5, theta: 0}}
  limits: {{v: 0.8, omega: 1.5, acceleration: {{v: 1.0, omega: 3.0}}}}
  footprint:
    polygon: [[0.55, 0.15], [-0.25, 0.15], [-0.25, -0.15], [0.55, -0.15]]
sensors:
  noise_std: {{x: 0.005, y: 0.005, theta: 0.005}}
  seed: 1
regions:
  shelf: {{type: box, min: [1.0, 0.27], max: [4.0, 0.87]}}
phases:
- name: park
  regulate:
    target: {{x: 2.5, y: {y}, theta: 0}}
  constraints:
  - {{stay_outside: shelf}}
  until:
    settled: {{position: 0.03, heading: 0.03}}
  timeout: {timeout}
{after}"""

NEXT = """\
  on_timeout: next
- name: back
  regulate:
    target: {x: 0, y: -1.5, theta: 0}
  until:
    settled: {position: 0.03, heading: 0.03}
  timeout: 15
"""


def test_a_park_within_the_band_kept_round_a_shelf_times_out_naming_it() -> None:
    """Before: the message 'phase 'park' timed out after 6 s at t = 6 s', the
    robot 0.65 m from its target, and nothing said why."""
    run = run_mission(mission_from_text(BESIDE_A_SHELF.format(y=0.0, timeout=6, after="")))
    assert run.outcome.value == "timeout"
    assert run.t[-1] == 6.0  # it ran to its timeout, as written
    for said in ("after 6 s", "0.27 m from keep-out zone 'shelf'", "keeps the axle 0.62 m"):
        assert said in run.message
    # stopped at the band's edge: 0.62 m from the shelf's face (y = 0.27)
    assert abs(0.27 - run.y[-1] - 0.62) < 0.01


def test_a_park_just_outside_the_band_runs_and_settles() -> None:
    """The axle's target 0.66 m from the shelf, 0.04 m beyond the band: the
    phase runs as before and parks."""
    run = run_mission(mission_from_text(BESIDE_A_SHELF.format(y=-0.39, timeout=12, after="")))
    assert run.outcome.value == "success"
    assert math.hypot(run.x[-1] - 2.5, run.y[-1] + 0.39) < 0.03


def test_a_timeout_that_goes_on_says_why_in_its_transition() -> None:
    """With on_timeout: next the phase runs its 3 s, its transition says why,
    and the next phase goes on."""
    text = BESIDE_A_SHELF.format(y=0.0, timeout=3, after=NEXT)
    run = run_mission(mission_from_text(text))
    first = run.transitions[0]
    assert first.condition == "timeout"
    assert abs(first.time - 3.0) < 1e-9
    assert first.why is not None
    assert "keep-out zone 'shelf'" in first.why
    assert run.outcome.value == "success"


def test_a_target_an_update_moved_is_not_blamed_on_the_written_one() -> None:
    """The written target within the band, an update moving it clear at 0.5 s,
    and too short a timeout: the message gives the distances to the target in
    force, and no band round the shelf, which no longer holds the robot off."""
    text = BESIDE_A_SHELF.format(y=0.0, timeout=3, after="").replace(
        "  until:\n",
        "  updates:\n  - when: {elapsed: 0.5}\n    target: {x: 2.5, y: -1, theta: 0}\n  until:\n",
    )
    run = run_mission(mission_from_text(text))
    assert run.outcome.value == "timeout"
    assert "from its target" in run.message
    assert "shelf" not in run.message


def test_validate_warns_of_a_target_the_body_clears_within_the_band() -> None:
    """The target 0.58 m from the shelf: beyond the body's disc (0.57 m), so
    the body's own warning is silent, but within the band with the estimate's
    margin (0.62 m) by more than the settled tolerance: said, and the run
    indeed times out; 0.66 m from it, neither."""
    from wmr_mission.spec.loader import check_mission_text

    def warned(y: float) -> list[str]:
        text = BESIDE_A_SHELF.format(y=y, timeout=8, after="")
        return [d.message for d in check_mission_text(text, "park.yaml")[1]]

    [said] = warned(-0.31)
    assert "0.58 m from keep-out zone 'shelf'" in said
    assert "keeps the axle 0.62 m from that edge" in said
    run = run_mission(mission_from_text(BESIDE_A_SHELF.format(y=-0.31, timeout=8, after="")))
    assert run.outcome.value == "timeout"
    assert warned(-0.39) == []


def test_a_target_inside_the_zone_is_said_to_be_inside_it() -> None:
    """Its distance from the zone was given as a negative number ('is -0.5 m
    from keep-out zone')."""
    run = run_mission(mission_from_text(BESIDE_A_SHELF.format(y=0.5, timeout=4, after="")))
    assert run.outcome.value == "timeout"
    assert "its target (2.5, 0.5) is inside keep-out zone 'shelf'" in run.message
    assert " -0." not in run.message
