"""A failed run's line points at what the mission wrote for what failed
(wmr_mission.spec.located): its end-of-run line's FILE:LINE:COL."""

from __future__ import annotations

from wmr_mission.spec.loader import read_document
from wmr_mission.spec.located import failure_path

MISSION = """\
version: 1
name: patrol
phases:
  - name: out
    regulate: {target: {x: 1, y: 0}}
    timeout: 20
  - name: laps
    repeat:
      times: 2
      phases:
        - name: leg
          track: {path: {type: line, heading: 0, speed: 0.5}}
          until: {elapsed: 1}
          expect:
            estimation_rms: {x: 0.1}
expect:
  estimation_rms: {y: 0.2}
  final_position_error: {max: 0.05}
"""


def _at(path: tuple[str | int, ...] | None) -> tuple[int, int]:
    document, _ = read_document(MISSION)
    assert document is not None
    assert path is not None
    return document.position(path, at_key=True)


def test_each_failure_points_at_its_own_key() -> None:
    data = read_document(MISSION)[0].data  # type: ignore[union-attr]
    assert _at(failure_path(data, "timeout", "out")) == (6, 5)
    assert _at(failure_path(data, "diverged", "out")) == (4, 5)  # the phase's name
    # a repeated phase, run as name#lap: its own key, inside its group
    assert _at(failure_path(data, "expect-failed", "leg#2", "estimation_rms.x")) == (15, 30)
    # a phase without an `expect`: the mission's bound, of the state
    assert _at(failure_path(data, "expect-failed", "out", "estimation_rms.y")) == (17, 20)
    assert _at(failure_path(data, "expect-failed", None, "final_position_error")) == (18, 3)
    # an `auto` bound, written nowhere: the phase
    assert _at(failure_path(data, "expect-failed", "leg#1", "turn_rate_jitter")) == (11, 11)
    assert _at(failure_path(data, "timeout", "leg#1")) == (11, 11)  # no timeout of its own


def test_nothing_written_points_nowhere() -> None:
    assert failure_path(None, "timeout", "out") is None
    assert failure_path({"phases": []}, "timeout", "out") is None
    assert failure_path({"phases": [{"name": "out"}]}, "expect-failed", None, "duration") is None


def test_a_contingencys_phase_is_found_in_its_contingency() -> None:
    text = (
        MISSION
        + """\
contingencies:
  detour:
    phases:
      - name: round
        hold: {}
        timeout: 5
"""
    )
    document, _ = read_document(text)
    assert document is not None
    path = failure_path(document.data, "timeout", "round")
    assert path == ("contingencies", "detour", "phases", 0, "timeout")
    assert document.position(path, at_key=True) == (24, 9)
