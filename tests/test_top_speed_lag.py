"""`validate` warns at a straight path's `speed` where the robot, starting slower
and accelerating within its limit, cannot be near its reference point by the
time its lag is judged: a path at the speed limit leaves it v^2 / (2 a)
behind for good (docs/mission-format.md, "What `validate` checks"). The
warning fires exactly on the missions of a grid whose runs fail
along_track_lag_max (scripts/top_speed_lag.py)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from wmr_mission import mission_from_text, run_mission
from wmr_mission.cli import app
from wmr_mission.spec.loader import check_mission_text

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from top_speed_lag import judge  # noqa: E402

TOP_SPEED = """\
version: 1
name: topspeed
robot:
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: 1.0, omega: 2, acceleration: {{v: {acceleration}, omega: 2}}}}
phases:
{hold}  - name: line
    track: {{path: {{type: line, heading: 0, speed: {speed}}}}}
    until: {{elapsed: {elapsed}}}
{expect}"""

# the mission as a user wrote it
USERS = """\
version: 1
name: topspeed
robot: {initial_state: {x: 0, y: 0, theta: 0}, limits: {v: 1.0, omega: 2, acceleration: {v: 0.5, omega: 2}}}
phases:
  - name: line
    track: {path: {type: line, heading: 0, speed: 1.0}}
    until: {elapsed: 10}
"""  # noqa: E501

WARNING = "phase 'line': its path runs at"


def _mission(
    speed: float = 1.0,
    acceleration: float = 0.5,
    elapsed: float = 10,
    hold: str = "",
    expect: str = "",
) -> str:
    return TOP_SPEED.format(
        speed=speed, acceleration=acceleration, elapsed=elapsed, hold=hold, expect=expect
    )


def _warnings(text: str) -> list[str]:
    return [d.message for d in check_mission_text(text, "top.yaml")[1] if d.severity == "warning"]


def _lag(text: str) -> dict[str, float]:
    summary = run_mission(mission_from_text(text)).summary()
    return next(e for e in summary["expectations"] if e["metric"] == "along_track_lag_max")


def test_the_user_s_mission_is_warned_at_its_speed_with_the_lag_the_run_shows(
    tmp_path: Path,
) -> None:
    path = tmp_path / "topspeed.yaml"
    path.write_text(USERS)
    result = CliRunner().invoke(app, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    # line 6, at the path's `speed`; one warning for the phase
    assert f"{path}:6:51: warning: {WARNING} 1 m/s, limits.v is 1 m/s" in result.output
    assert "ok (1 warning)" in result.output
    assert "at least 0.995 m behind its reference point" in result.output
    assert "5.08 s into the phase, where along_track_lag_max allows 0.4 m" in result.output
    assert "slow the path to 0.93 m/s, raise the acceleration limit to 1.24 m/s^2" in (
        result.output
    )
    lag = _lag(USERS)
    assert not lag["met"]
    assert lag["value"] == pytest.approx(0.995, abs=1e-9)


@pytest.mark.parametrize(
    ("speed", "acceleration"),
    [
        (0.9, 0.5),  # 10 % below the limit
        (0.93, 0.5),  # the warning's slower path
        (1.0, 1.24),  # its larger acceleration limit
    ],
)
def test_a_path_below_the_limit_or_a_faster_robot_is_not_warned_and_passes(
    speed: float, acceleration: float
) -> None:
    text = _mission(speed=speed, acceleration=acceleration)
    assert not _warnings(text)
    assert _lag(text)["met"]


def test_after_a_hold_the_robot_starts_from_rest_too() -> None:
    hold = "  - name: wait\n    hold: {}\n    until: {elapsed: 1}\n"
    text = _mission(hold=hold).replace("speed: 1.0}", "speed: 1.0, start: current}")
    [warning] = _warnings(text)
    assert warning.startswith(WARNING)
    assert "at least 0.995 m behind" in warning
    assert not _lag(text)["met"]


def test_a_phase_entered_moving_is_not_judged() -> None:
    """After a track phase the robot may enter at up to its limit, a hold
    between them too short to stop it: only the first phase is warned of, and the
    last keeps up."""
    moving = (
        "  - name: first\n    track: {path: {type: line, heading: 0, speed: 1.0}}\n"
        "    until: {elapsed: 10}\n"
        "  - name: wait\n    hold: {}\n    until: {elapsed: 0.1}\n"
    )
    text = _mission(hold=moving).replace(
        "  - name: line\n    track: {path: {type: line, heading: 0, speed: 1.0}}",
        "  - name: line\n    track: {path: {type: line, heading: 0, speed: 1.0, start: current}}",
    )
    warnings = _warnings(text)
    assert [w.split(":")[0] for w in warnings] == ["phase 'first'"], warnings
    # it enters at speed and keeps up (a lag of about 2 mm)
    summary = run_mission(mission_from_text(text)).summary()
    [line] = [
        e
        for e in summary["expectations"]
        if e["metric"] == "along_track_lag_max" and e["phase"] == "line"
    ]
    assert line["met"]


def test_a_bound_that_allows_the_lag_or_none_is_not_warned() -> None:
    """A phase's bound above the lag, or none for the mission (a phase's null
    takes the mission's value), is not warned of; a bound below it is, with
    its number."""
    below = "    expect: {along_track_lag_max: {max: 0.9}}\n    until:"
    [warning] = _warnings(_mission().replace("    until:", below))
    assert "along_track_lag_max allows 0.9 m" in warning
    above = "    expect: {along_track_lag_max: {max: 1.0}}\n    until:"
    assert not _warnings(_mission().replace("    until:", above))
    assert _lag(_mission().replace("    until:", above))["met"]
    unchecked = _mission() + "expect: {along_track_lag_max: null}\n"
    assert not _warnings(unchecked)


def test_a_phase_too_short_to_catch_up_keeps_its_own_warning() -> None:
    """Ended within its entry, the phase is warned of at its `until` where a
    longer phase helps (0.9 of the limit: 30 s pass), once; at the limit a
    longer phase never helps, and the lag is said instead."""
    [warning] = _warnings(_mission(speed=0.9, elapsed=4))
    assert "phase 'line' ends before the robot can catch its path" in warning
    assert _warnings(_mission(speed=0.9, elapsed=30)) == []
    [warning] = _warnings(_mission(elapsed=4))
    assert warning.startswith("phase 'line': its path runs at 1 m/s")
    assert "lengthen" not in warning


@pytest.mark.parametrize(
    ("share", "acceleration", "ramped", "held", "length"),
    [
        (1.0, 0.5, False, False, 40),
        (1.0, 0.5, True, False, 40),  # a path that ramps up at the robot's acceleration
        (0.97, 0.25, False, True, 40),
        (0.97, 1.0, False, False, 40),
        (0.95, 0.5, False, False, 8),
        (0.9, 0.5, False, False, 8),
    ],
)
def test_the_warning_fires_exactly_where_the_run_fails_its_lag(
    share: float, acceleration: float, ramped: bool, held: bool, length: float
) -> None:
    warned, lag = judge(share, acceleration, ramped, held, length)
    assert warned == (not lag["met"]), lag


@pytest.mark.sweep
def test_the_warning_fires_exactly_where_the_run_fails_its_lag_over_the_grid() -> None:
    for share in (0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 0.97, 0.99, 1.0):
        for acceleration in (0.25, 0.5, 1.0, 2.0, 4.0):
            for ramped in (False, True):
                for held in (False, True):
                    for length in (8.0, 40.0):
                        warned, lag = judge(share, acceleration, ramped, held, length)
                        assert warned == (not lag["met"]), (share, acceleration, ramped, held)


def test_only_advice_that_helps_is_given() -> None:
    """Within a tenth of the limit a longer phase is judged later and still
    fails: no "lengthen the phase" (the warning of a phase that ends too soon
    gives way); a path beyond the limit is refused as such, not told to slow
    to a speed still above it or given an acceleration no limit reaches."""
    _, said = check_mission_text(_mission(speed=0.99, elapsed=10), "m.yaml")
    assert [d.message.startswith("phase 'line': its path runs at 0.99") for d in said] == [True]
    assert "lengthen" not in said[0].message
    _, said = check_mission_text(_mission(speed=1.2), "m.yaml")
    assert not any("its path runs at" in d.message for d in said)
    assert any("above robot.limits.v" in d.message for d in said)
