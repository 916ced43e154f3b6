"""The robot's acceleration limits (`robot.limits.acceleration`): the plant
applies the commands no faster, and the controller commands no faster."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission import mission_from_dict, run_mission
from wmr_mission.kernels.disturbances import Actuation, applied_input
from wmr_mission.sim.plan import plan_mission


def test_the_plant_applies_a_jump_of_the_command_as_a_ramp() -> None:
    """Whatever the controller asks (a baseline that knows no limits), the
    plant's input changes by at most acceleration * dt per sample."""
    actuation = Actuation(0, 1.0, 0.0, 1.0 * 0.01, 4.0 * 0.01)
    commands = np.zeros((1, 2))
    applied = np.zeros(2)
    seen = []
    for k in range(300):
        applied_input(actuation, k, np.array([2.0, -3.0]), commands, applied)
        seen.append(applied.copy())
    path = np.array(seen)
    np.testing.assert_allclose(path[:200, 0], 0.01 * np.arange(1, 201), rtol=1e-12)
    np.testing.assert_allclose(path[:75, 1], -0.04 * np.arange(1, 76), rtol=1e-12)
    assert path[-1, 0] == 2.0
    assert path[-1, 1] == -3.0
    # without limits the command is applied as it is
    free = Actuation(0, 1.0, 0.0)
    applied_input(free, 0, np.array([2.0, -3.0]), np.zeros((1, 2)), applied := np.zeros(2))
    assert applied.tolist() == [2.0, -3.0]


def _mission(acceleration: dict[str, float] | None) -> dict:
    limits: dict = {"v": 2, "omega": 3}
    if acceleration is not None:
        limits["acceleration"] = acceleration
    return {
        "version": 1,
        "name": "accelerate",
        "robot": {"dt": 0.01, "initial_state": {"x": 0, "y": 0, "theta": 0}, "limits": limits},
        "phases": [
            {
                "name": "go",
                "track": {"path": {"type": "line", "start": [0, 0], "heading": 0, "speed": 1.5}},
                "until": {"elapsed": 6},
            },
            {
                "name": "park",
                "regulate": {"target": {"x": 10, "y": 3, "theta": 1.5}},
                "until": {"settled": {"position": 0.02, "heading": 0.02}},
                "timeout": 30,
            },
        ],
    }


def test_the_controller_commands_no_faster_than_the_robot_accelerates() -> None:
    mission = mission_from_dict(_mission({"v": 1.0, "omega": 4.0}))
    limits = plan_mission(mission).plant.limits
    assert limits[2:].tolist() == [1.0, 4.0]
    result = run_mission(mission)
    # from rest: the first command too
    assert np.abs(np.diff(result.v, prepend=0.0)).max() <= 1.0 * 0.01 + 1e-12
    assert np.abs(np.diff(result.omega, prepend=0.0)).max() <= 4.0 * 0.01 + 1e-12
    park = next(t for t in result.transitions if t.from_phase == "park")
    assert park.condition == "settled"
    # unlimited, the same mission starts at its path's speed in one sample
    free = run_mission(mission_from_dict(_mission(None)))
    assert free.v[0] == pytest.approx(1.5)


def test_v_rate_and_the_acceleration_the_tighter_wins() -> None:
    data = _mission({"v": 1.0, "omega": 4.0})
    data["robot"]["limits"] |= {"v_rate": 0.5, "omega_rate": 8.0}
    limits = plan_mission(mission_from_dict(data)).plant.limits
    assert limits[2:].tolist() == [0.5, 4.0]
    assert math.isinf(plan_mission(mission_from_dict(_mission(None))).plant.limits[2])
