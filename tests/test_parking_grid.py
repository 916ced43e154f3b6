"""Parking from every bearing and distance (docs/paper-notes.md, "Eq. (19):
linearised at the direction of travel"): a park to a target at a bearing
from the robot's heading and a distance from it, with its own heading, under
several limit pairs, sampling periods, with and without acceleration limits;
it must settle by its `settled` condition, not time out.

Targets 91-101 degrees from the heading, 1.7-2.5 m away, timed out across
limit pairs: the forwards choice (the target not yet far enough past abeam to
reverse) linearised eq. (1) at the small backwards speed the robot had, where
T's lateral terms turn against the heading error; the robot crawled
backwards and never turned. A small grid by default, the whole one (1,584
parks) marked sweep.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from wmr_mission import mission_from_dict, run_mission

# (limits.v, limits.omega)
LIMITS = [(2.644, 4.511), (1.0, 1.5), (4.0, 4.8)]
ACCELERATIONS: list[dict[str, float] | None] = [None, {"v": 1.5, "omega": 6.0}]
DT = [0.0125, 0.05]
DISTANCES = [0.3, 1.0, 1.7, 2.1, 2.5, 4.0]
# every 20 degrees, and the band that failed
BEARINGS = [*range(-180, 180, 20), 91, 95, 101, -95]
# the target's heading from the robot's
TURNS = [0.964, -2.0]


def park(
    bearing: float,
    distance: float,
    limits: tuple[float, float],
    dt: float,
    acceleration: dict[str, float] | None,
    turn: float,
    start: tuple[float, float, float] = (0.0, 0.0, 0.3),
) -> dict[str, Any]:
    x0, y0, theta0 = start
    angle = theta0 + math.radians(bearing)
    robot_limits: dict[str, Any] = {"v": limits[0], "omega": limits[1]}
    if acceleration is not None:
        robot_limits["acceleration"] = acceleration
    target = {
        "x": x0 + distance * math.cos(angle),
        "y": y0 + distance * math.sin(angle),
        "theta": theta0 + turn,
    }
    return {
        "version": 1,
        "name": "park",
        "robot": {
            "dt": dt,
            "initial_state": {"x": x0, "y": y0, "theta": theta0},
            "limits": robot_limits,
        },
        "phases": [
            {
                "name": "park",
                "regulate": {"target": target},
                "until": {"settled": {"position": 0.03, "heading": 0.03}},
                "timeout": 60,
            }
        ],
    }


def settles(data: dict[str, Any]) -> None:
    result = run_mission(mission_from_dict(data))
    transition = result.transitions[-1]
    target = data["phases"][0]["regulate"]["target"]
    short = np.hypot(result.x[-1] - target["x"], result.y[-1] - target["y"])
    assert transition.condition == "settled", (data["robot"], target, transition, short)


def test_the_park_of_the_issue_settles() -> None:
    """Timed out 1.70 m short: the target 97 degrees off the heading, 1.89 m away."""
    data = park(0.0, 0.0, (2.644, 4.511), 0.0125, None, 0.0, (-9.036, 0.155, -3.554))
    data["phases"][0]["regulate"]["target"] = {"x": -8.071, "y": 1.783, "theta": -2.59}
    result = run_mission(mission_from_dict(data))
    assert result.transitions[-1].condition == "settled"
    assert result.t[-1] < 15.0
    assert np.hypot(result.x[-1] + 8.071, result.y[-1] - 1.783) <= 0.03


@pytest.mark.parametrize("acceleration", ACCELERATIONS, ids=["free", "accelerating"])
@pytest.mark.parametrize("bearing", [-95, 91, 95, 101, 180, 40])
@pytest.mark.parametrize("distance", [1.7, 2.5])
def test_parks_from_a_few_bearings(
    bearing: float, distance: float, acceleration: dict[str, float] | None
) -> None:
    settles(park(bearing, distance, LIMITS[0], DT[0], acceleration, TURNS[0]))


@pytest.mark.sweep
@pytest.mark.parametrize("acceleration", ACCELERATIONS, ids=["free", "accelerating"])
@pytest.mark.parametrize("dt", DT)
@pytest.mark.parametrize("limits", LIMITS)
@pytest.mark.parametrize("distance", DISTANCES)
@pytest.mark.parametrize("bearing", BEARINGS)
def test_parks_from_every_bearing(
    bearing: float,
    distance: float,
    limits: tuple[float, float],
    dt: float,
    acceleration: dict[str, float] | None,
) -> None:
    turn = TURNS[(BEARINGS.index(bearing) + DISTANCES.index(distance)) % len(TURNS)]
    settles(park(bearing, distance, limits, dt, acceleration, turn))
