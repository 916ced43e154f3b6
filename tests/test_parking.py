"""Regulation without limit cycles (the bearing form of Case 1), from any
entry speed and bearing to the target (docs/paper-notes.md, "Eq. (19):
forwards or backwards, with hysteresis").

A grid of entries: the robot drives a line at the entry speed for a second
(none at speed 0), then regulates to a target 2 m away at a bearing from its
heading; it must settle (0.02 m, 0.02 rad) by the `settled` condition, not
time out. A small grid by default, the whole one marked sweep.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from wmr_mission import mission_from_dict, run_mission

V_LIMIT = 4.0
OMEGA_LIMIT = 4.8


def parking(speed: float, bearing: float, dt: float, distance: float = 2.0) -> dict[str, Any]:
    phases: list[dict[str, Any]] = []
    x0 = 0.0
    if speed > 0.0:
        phases.append(
            {
                "name": "dash",
                "track": {"path": {"type": "line", "start": [0, 0], "heading": 0, "speed": speed}},
                "until": {"elapsed": 1.0},
            }
        )
        x0 = speed * 1.0
    target = {
        "x": x0 + distance * math.cos(bearing),
        "y": distance * math.sin(bearing),
        "theta": 0,
    }
    phases.append(
        {
            "name": "park",
            "regulate": {"target": target},
            "until": {"settled": {"position": 0.02, "heading": 0.02}},
            "timeout": 30,
        }
    )
    return {
        "version": 1,
        "name": "parking",
        "robot": {
            "dt": dt,
            "initial_state": {"x": 0, "y": 0, "theta": 0},
            "limits": {"v": V_LIMIT, "omega": OMEGA_LIMIT},
        },
        "estimator": {
            "type": "constrained-observer",
            "initial_estimate": {"x": 0, "y": 0, "theta": 0},
        },
        "phases": phases,
    }


def settles(speed: float, bearing: float, dt: float) -> None:
    result = run_mission(mission_from_dict(parking(speed, bearing, dt)))
    park = next(t for t in result.transitions if t.from_phase == "park")
    assert park.condition == "settled", (speed, bearing, dt, park)
    # no period-2 swing of the inputs at the end
    omega = result.omega[-20:]
    assert np.count_nonzero(np.diff(np.sign(omega[np.abs(omega) > 0.05]))) <= 2


def test_the_parking_limit_cycle_of_the_issue() -> None:
    """A line at 2.5 m/s for 2 s, then regulate to (4.95, -5, 0): the target
    ends up abeam. Forwards and backwards were chosen by turns every sample
    (v +-0.16 m/s, omega +-3.19 rad/s); the robot moved 8 mm in 30 s and timed
    out. With hysteresis it parks."""
    data = parking(2.5, 0.0, 0.01)
    data["phases"][0]["until"] = {"elapsed": 2.0}
    data["phases"][1]["regulate"]["target"] = {"x": 4.95, "y": -5, "theta": 0}
    result = run_mission(mission_from_dict(data))
    park = next(t for t in result.transitions if t.from_phase == "park")
    assert park.condition == "settled"
    assert park.time < 2.0 + 15.0
    final = np.hypot(result.x[-1] - 4.95, result.y[-1] + 5.0)
    assert final < 0.03


@pytest.mark.parametrize("dt", [0.01, 0.05])
@pytest.mark.parametrize("bearing", [-math.pi / 2, math.pi / 2, math.pi, 0.3])
@pytest.mark.parametrize("speed", [0.0, V_LIMIT])
def test_parks_from_a_few_entries(speed: float, bearing: float, dt: float) -> None:
    settles(speed, bearing, dt)


@pytest.mark.sweep
@pytest.mark.parametrize("dt", [0.005, 0.01, 0.02, 0.05])
@pytest.mark.parametrize("bearing", list(np.linspace(-math.pi, math.pi, 13)))
@pytest.mark.parametrize("speed", [0.0, 0.25 * V_LIMIT, 0.5 * V_LIMIT, V_LIMIT])
def test_parks_from_every_entry(speed: float, bearing: float, dt: float) -> None:
    settles(speed, bearing, dt)


@pytest.mark.parametrize(("speed", "bearing"), [(V_LIMIT, math.pi), (1.0, math.pi / 2)])
def test_the_parks_turn_rate_moves_from_the_input_before(speed: float, bearing: float) -> None:
    """A park after a dash, its target behind or abeam: eq. (19)'s heading
    reference jumps where the park takes over from the track (and where
    aligning begins), and the regulator answered with its whole turn rate in
    one sample (4.69 and 2.51 rad/s where the verdict allows 4.8;
    gen-104-waypoints of the generated set, 2.06 where 2.05 is allowed, as
    it began aligning). Now by at most half the limit a sample, and it still
    parks."""
    data = parking(speed, bearing, 0.01)
    result = run_mission(mission_from_dict(data))
    park = next(t for t in result.transitions if t.from_phase == "park")
    assert park.condition == "settled"
    entry = int(np.flatnonzero(result.phase == result.phase[-1])[0])
    # from the dash's last input on: the take-over is the park's first change
    jumps = np.abs(np.diff(result.omega[entry - 1 :]))
    assert jumps.max() <= 0.5 * OMEGA_LIMIT + 1e-9


@pytest.mark.parametrize("bearing", [math.radians(95), math.radians(100), math.radians(-100)])
@pytest.mark.parametrize("speed", [0.0, 1.0])
def test_a_target_just_past_abeam_is_turned_to_not_backed_from(
    speed: float, bearing: float
) -> None:
    """A target more than abeam but within the hysteresis: the bearing form
    goes forwards, yet eq. (19) gave the error along the heading, behind, a
    negative speed: the robot backed at up to 0.35 m/s while it turned, then
    drove on (gen-170-ellipse's park: +0.57, -0.70, +0.51 m/s in three
    samples). No speed against the direction chosen: it turns first. Up to
    the aligning radius the park's speed never goes negative."""
    mission = mission_from_dict(parking(speed, bearing, 0.01))
    result = run_mission(mission)
    park = next(t for t in result.transitions if t.from_phase == "park")
    assert park.condition == "settled"
    target = mission.phases[-1].regulate.target
    entry = int(np.flatnonzero(result.phase == result.phase[-1])[0])
    far = np.hypot(result.x_est - target.x, result.y_est - target.y) > 0.02
    before_aligning = np.arange(result.v.size) < np.argmin(far[entry:]) + entry
    assert result.v[entry:][before_aligning[entry:]].min() >= 0.0
