"""`validate` warns where the first phase, a track phase that ends on time,
ends before the robot can catch its path: the phase ends within its entry,
so its tracking is judged at its end, and there the robot, from rest, within
its speed and acceleration limits, is farther from its reference point than
the cross-track and along-track bounds together allow (spec/checks.py,
``_catching_up``). A user's run-and-return (a line at 1 m/s from rest at
0.5 m/s^2, for 4 s) passed `validate` and then failed its lag, 0.636 m where
0.41 m is allowed."""

from __future__ import annotations

import random

import pytest

from wmr_mission import mission_from_text, run_mission
from wmr_mission.spec.loader import Diagnostic, check_mission_text

RUN = """\
version: 1
name: run-short
robot:
  dt: 0.01
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: 1.2, omega: 2.0, acceleration: {{v: {acceleration}, omega: 3.0}}}}
sensors:
  noise_std: {{x: 0.01, y: 0.01, theta: 0.01}}
  seed: 5
controller: {{type: {controller}}}
phases:
- name: run
  track:
    path: {{type: line, heading: 0, speed: {speed}}}
  until: {{elapsed: {elapsed}}}
"""

WARNING = "phase 'run' ends before the robot can catch its path"


def _diagnostics(text: str) -> list[Diagnostic]:
    return check_mission_text(text, "run.yaml")[1]


def _warnings(text: str) -> list[str]:
    return [d.message for d in _diagnostics(text) if d.severity == "warning"]


def test_the_user_s_run_is_warned_at_its_until_with_the_numbers() -> None:
    text = RUN.format(acceleration=0.5, speed=1.0, elapsed=4, controller="paper")
    [found] = [d for d in _diagnostics(text) if WARNING in d.message]
    assert (found.line, found.column) == (15, 10)  # the phase's `until`
    # 4 m of path against 3.366 m sampled (1.44 m accelerating to 1.2 m/s, 1.6 s
    # at it, a sample's head start), and 4 std of the first estimate's noise
    assert "at least 0.577 m from its reference point" in found.message
    assert "allow 0.11 m and 0.41 m" in found.message


@pytest.mark.parametrize(
    ("acceleration", "speed", "elapsed", "controller", "expected"),
    [
        (0.5, 1.0, 4, "paper", True),  # the user's run
        (0.5, 1.0, 4, "kanayama", True),  # whatever the law
        (0.5, 1.0, 4, "pure-pursuit", True),
        (0.3, 1.1, 6, "paper", True),
        (0.5, 1.0, 12, "paper", False),  # time to catch up: no warning, a success
        (2.0, 1.0, 4, "paper", False),  # at speed within 0.5 s: no warning, a success
    ],
)
def test_a_warned_run_fails_its_tracking_and_one_not_warned_can_pass(
    acceleration: float, speed: float, elapsed: float, controller: str, expected: bool
) -> None:
    text = RUN.format(
        acceleration=acceleration, speed=speed, elapsed=elapsed, controller=controller
    )
    warned = any(WARNING in message for message in _warnings(text))
    run = run_mission(mission_from_text(text))
    summary = run.summary()
    missed = {e["metric"] for e in summary["expectations"] if not e["met"]}
    tracking = {"cross_track_error_max", "along_track_lag_max"}
    assert warned == expected
    if warned:
        assert missed & tracking, summary["message"]
    else:
        assert summary["outcome"] == "success", summary["message"]


def test_no_warning_where_the_phase_may_end_otherwise_or_a_zone_excuses() -> None:
    """A phase a timeout (with no `until` on time) ends is not judged at its end;
    a zone's detour is excused; an update that slows the path lets the robot
    catch it; a path made from an estimate elsewhere starts elsewhere (both
    ran to success): none is warned."""
    short = RUN.format(acceleration=0.5, speed=1.0, elapsed=4, controller="paper")
    timed_out = short.replace(
        "until: {elapsed: 4}", "until: {near: {point: [9, 0], tolerance: 0.1}}\n  timeout: 4"
    )
    assert not any(WARNING in m for m in _warnings(timed_out))
    zoned = short.replace(
        "phases:", "regions:\n  rock: {type: circle, center: [2, 0.6], radius: 0.3}\nphases:"
    ).replace(
        "  until: {elapsed: 4}", "  constraints: [{stay_outside: rock}]\n  until: {elapsed: 4}"
    )
    assert not any(WARNING in m for m in _warnings(zoned))
    slowed = short.replace(
        "  until: {elapsed: 4}",
        "  updates:\n  - when: {elapsed: 0.5}\n    speed: 0.2\n  until: {elapsed: 4}",
    )
    assert not any(WARNING in m for m in _warnings(slowed))
    assert run_mission(mission_from_text(slowed)).outcome.value == "success"
    elsewhere = (
        short.replace(
            "controller:",
            "estimator: {initial_estimate: {x: 5, y: 0, theta: 3.14159}}\ncontroller:",
        )
        .replace("theta: 0}}\n  limits", "theta: 3.14159}}\n  limits")
        .replace("heading: 0, speed: 1.0", "heading: 3.14159, speed: 1.2")
    )
    assert not any(WARNING in m for m in _warnings(elsewhere))


def _random_first_phase(rng: random.Random, seed: int) -> str:
    """A first phase of a user's: a line or a circle at a random share of a
    random speed limit, with or without an acceleration limit, from a random
    pose, under a random law and noise, for a random time."""
    v = rng.uniform(0.5, 2.0)
    speed = rng.uniform(0.3, 1.0) * v
    rate = rng.choice(["", f", acceleration: {{v: {rng.uniform(0.2, 2):.3f}, omega: 4}}"])
    if rng.random() < 0.5:
        path = f"{{type: line, heading: {rng.uniform(-3, 3):.3f}, speed: {speed:.3f}}}"
    else:
        path = f"{{type: circle, center: [0, 1.5], radius: 1.5, angular_rate: {speed / 1.5:.3f}}}"
    noise = rng.choice([0, 0.005, 0.01])
    x, y, theta = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-3, 3)
    return f"""\
version: 1
name: first-phase-{seed}
robot:
  dt: 0.02
  initial_state: {{x: {x:.3f}, y: {y:.3f}, theta: {theta:.3f}}}
  limits: {{v: {v:.3f}, omega: 2.0{rate}}}
sensors:
  noise_std: {{x: {noise}, y: {noise}, theta: {noise}}}
  seed: {seed}
controller: {{type: {rng.choice(["paper", "kanayama", "pure-pursuit"])}}}
phases:
- name: go
  track:
    path: {path}
  until: {{elapsed: {rng.uniform(1.5, 8):.2f}}}
"""


@pytest.mark.parametrize(
    "count", [30, pytest.param(150, marks=pytest.mark.sweep)], ids=["small", "full"]
)
def test_no_warned_run_succeeds_on_random_first_phases(count: int) -> None:
    """The warning's claim, judged by running each mission: a warned run fails
    its tracking. The small sweep warns 3 of 30, the full one (pytest -m
    sweep) 8 of 150 (seed 1), none of them a success."""
    rng = random.Random(1)
    warned = []
    for seed in range(count):
        text = _random_first_phase(rng, seed)
        if any(WARNING.replace("'run'", "'go'") in m for m in _warnings(text)):
            warned.append(seed)
            run = run_mission(mission_from_text(text))
            assert run.outcome.value != "success", text
    assert len(warned) == {30: 3, 150: 8}[count]  # as docs/mission-format.md says
