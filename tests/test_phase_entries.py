"""summary.json's `phases`: an entry per entry into a phase, in run order, as
transitions.json has them: a phase retried, or left and resumed, has an entry
each time it was entered, and a phase whose `until` held as it was entered an
entry of no duration."""

from __future__ import annotations

import math
from typing import Any

import pytest

from wmr_mission.api import mission_from_text
from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome
from wmr_mission.sim.runner import run_mission

HEAD = """
version: 1
name: t
robot:
  dt: 0.02
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 2, omega: 3}
"""


def _run(text: str) -> tuple[RunResult, list[dict[str, Any]]]:
    result = run_mission(mission_from_text(HEAD + text))
    return result, result.summary()["phases"]


def _entered(result: RunResult) -> list[tuple[str | None, float]]:
    """(phase, time) of each entry: the first phase's at 0, then the transitions'."""
    first = result.transitions[0].from_phase
    return [(first, 0.0)] + [
        (tr.to_phase, tr.time)
        for tr in result.transitions
        if tr.to_phase is not None and tr.condition != "update"
    ]


def test_a_phase_entered_after_its_mission_time_has_an_entry_of_no_duration() -> None:
    # `late` and `lane` are entered at 1 s, after their mission_time of 0.5 s:
    # each ends at its first sample and runs none; `rest` begins at that sample.
    result, phases = _run(
        """
regions:
  yard: {type: box, min: [-5, -5], max: [5, 5]}
phases:
  - name: out
    regulate: {target: {x: 1, y: 0, theta: 0}}
    until: {elapsed: 1}
  - name: lane
    track:
      path: {type: polyline, points: [[3, 0]], speed: 1.0}
    constraints: [{stay_inside: yard}]
    until: {mission_time: 0.5}
  - name: late
    regulate: {target: {x: 2, y: 0, theta: 0}}
    until: {mission_time: 0.5}
  - name: rest
    hold: {}
    until: {elapsed: 0.5}
"""
    )
    assert result.outcome is Outcome.success
    assert [(tr.from_phase, tr.to_phase, tr.time) for tr in result.transitions] == [
        ("out", "lane", 1.0),
        ("lane", "late", 1.0),
        ("late", "rest", 1.0),
        ("rest", None, 1.5),
    ]
    assert [result.phase_names[i] for i in sorted(set(result.phase.tolist()))] == ["out", "rest"]
    assert [(p["name"], p["start"], p["end"], p["duration"]) for p in phases] == [
        ("out", 0.0, 1.0, 1.0),
        ("lane", 1.0, 1.0, 0.0),
        ("late", 1.0, 1.0, 0.0),
        ("rest", 1.0, 1.5, 0.5),
    ]
    assert [(p["name"], p["start"]) for p in phases] == _entered(result)
    lane = phases[1]
    assert lane["tracking"]["cross_track_error_max"] is None
    assert lane["tracking_error"]["rms"] is None
    assert lane["constraint"]["max_violation"] is None
    late = phases[2]
    assert late["settled_samples"] == 0
    assert late["max_abs_v"] is None
    assert late["max_abs_omega"] is None
    assert late["inputs"]["judged_from"] is None
    assert late["estimation"]["convergence_time"] is None
    assert late["phase2_iterations"] == {"total": 0, "max": 0}
    assert late["regulation"]["stall_time"] is None
    assert late["regulation"]["overshoot_max"] is None
    # measured where it was entered and left: sample 50, the next phase's first
    assert late["target_error"]["position"] == math.hypot(result.x[50] - 2.0, result.y[50])
    # no metric of samples is judged where there is none: no check missed
    checks = [c for c in result.summary()["expectations"] if c["phase"] in ("lane", "late")]
    assert all(c["met"] for c in checks)
    assert {c["metric"] for c in checks} <= {"zone_intrusion_max"}


def test_a_retried_phase_has_an_entry_per_try_as_a_resumed_one_has() -> None:
    # settling 3 m away takes 3.66 s: the first try times out at 2 s, the retry settles
    retried, phases = _run(
        """
phases:
  - name: reach
    regulate: {target: {x: 3, y: 0, theta: 0}}
    until: {settled: {position: 0.05, heading: 0.05}}
    timeout: 2
    on_timeout: {retry: {times: 3}}
"""
    )
    assert retried.outcome is Outcome.success
    assert [(p["name"], p["start"], p["end"]) for p in phases] == [
        ("reach", 0.0, 2.0),
        ("reach", 2.0, retried.transitions[-1].time),
    ]
    assert [(p["name"], p["start"]) for p in phases] == _entered(retried)
    # each try judged from its own entry: the retry's estimate converged at once
    assert phases[1]["estimation"]["convergence_time"] == 0.0
    assert phases[1]["settle_time"] == phases[0]["settle_time"]
    assert phases[0]["duration"] + phases[1]["duration"] == pytest.approx(retried.t[-1])

    # A leg left for a detour round a pond and resumed: an entry each time, too.
    resumed, phases = _run(
        """
regions:
  pond: {type: circle, center: [4, 0], radius: 1}
geofence: {keep_out: [pond], margin: 0.1}
contingencies:
  detour:
    phases:
      - name: around
        track:
          path:
            type: polyline
            points: [[3.4, -1.4], [5, -1.4], [6.2, 0]]
            corner_radius: 0.3
            speed: 1.0
        until: {near: {point: [6.2, 0], tolerance: 0.1}}
        timeout: 20
phases:
  - name: leg
    track:
      path: {type: polyline, points: [[8, 0]], speed: 1.0}
    until: {near: {point: [8, 0], tolerance: 0.1}}
    timeout: 30
    on_breach: detour
"""
    )
    assert resumed.outcome is Outcome.success
    assert [p["name"] for p in phases] == ["leg", "around", "leg"]
    assert [(p["name"], p["start"]) for p in phases] == _entered(resumed)


def test_each_try_of_a_retried_phase_is_judged_by_how_it_ended() -> None:
    """A try that timed out within its entry is not judged at its end; the try
    that ended on time is. Keyed by the phase's name, every try was judged by
    how the last one ended: the first try's 0.636 m lag at its timeout failed
    a run that succeeds."""
    text = """
version: 1
name: retried
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1.2, omega: 2.0, acceleration: {v: 0.5, omega: 3.0}}
phases:
- name: run
  track: {path: {type: line, heading: 0, speed: 1.0}}
  until: {mission_time: 6}
  timeout: 4
  on_timeout: {retry: {times: 1}}
"""
    result = run_mission(mission_from_text(text))
    phases = result.summary()["phases"]
    assert [tr.condition for tr in result.transitions] == ["timeout", "mission_time"]
    first, second = phases
    assert first["tracking"]["along_track_lag_max"] is None  # ended in its entry, timed out
    assert second["tracking"]["along_track_lag_max"] is not None  # ended on time: judged
    assert result.outcome is Outcome.success, result.message
