"""A track phase's zones are held no further ahead of the axle than the
default look-ahead (paper.rows_ahead; docs/paper-notes.md, eq. (28), "The
rows held no further ahead than the default look-ahead").

Held at a tracking output 0.3 m ahead and shrunk by 0.3 m, the rows of an
aisle 1.17 m wide beside a turned pallet left the output no place (a body
of radius 0.3 m needs 0.70 m): the robot stood at the pallet's corner from
t = 3.7 s, its speed reversing 72 times, until its 20 s timeout 5.1 m from
its goal.
"""

from __future__ import annotations

import numpy as np

from wmr_mission import mission_from_text, run_mission
from wmr_mission.controllers.constrained_tracking import keep_constraints
from wmr_mission.controllers.paper import rows_ahead
from wmr_mission.geometry.regions import BoxRegion, constraint_rows
from wmr_mission.kernels.records import Plant, scratch
from wmr_mission.verdicts.metrics import judge

AISLE = """\
version: 1
name: aisle-past-a-pallet
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 1.2, omega: 2.0}
  footprint: {radius: 0.3}
controller: {tracking: {look_ahead: 0.3}}
regions:
  aisle: {type: box, min: [-1, -1.5], max: [14, 1.5]}
  pallet: {type: box, center: [4, 0.1], size: [1.0, 0.6], heading: 0.3}
phases:
  - name: pass
    track: {path: {type: line, start: [0, 0], heading: 0, speed: 0.8}}
    constraints: [{stay_inside: aisle}, {stay_outside: pallet}]
    until: {near: {point: [8, 0], tolerance: 0.1}}
    timeout: 20
"""


def _pinch_rows() -> tuple[np.ndarray, np.ndarray]:
    aisle = BoxRegion(type="box", min=(-1.0, -1.5), max=(14.0, 1.5))
    pallet = BoxRegion(type="box", center=(4.0, 0.1), size=(1.0, 0.6), heading=0.3)
    (k1, p1), (k2, p2) = constraint_rows(aisle, "inside"), constraint_rows(pallet, "outside")
    width = max(p1.shape[1], p2.shape[1])
    params = np.vstack([np.pad(p, ((0, 0), (0, width - p.shape[1]))) for p in (p1, p2)])
    return np.concatenate([k1, k2]).astype(np.int64), np.ascontiguousarray(params)


def test_the_rows_are_held_no_further_ahead_than_the_default_look_ahead() -> None:
    assert rows_ahead(0.3, 0.01, 1.2) == 0.05  # max(0.05, 1.2 * 0.01)
    assert rows_ahead(0.3, 0.1, 2.0) == 0.2  # limits.v * dt
    assert rows_ahead(0.03, 0.01, 1.2) == 0.03  # a shorter look-ahead: the output
    assert rows_ahead(0.0, 0.01, 1.2) == 0.0  # the axle law


def test_beside_the_pallet_the_aisle_leaves_a_place_for_the_robot() -> None:
    """The output straight below the pallet's lowest corner (3.61, -0.334),
    heading along the aisle, halfway between the corner and the aisle's
    wall (y = -1.5): 0.583 m from each, where the body and the estimate's
    margin ask 0.35 m. Held at the output 0.3 m ahead and shrunk by it, both
    rows are broken by 0.067 m (they meet nowhere) and the filter changes
    the input; held 0.05 m ahead, neither acts."""
    kinds, params = _pinch_rows()
    plant = Plant(0.01, np.array([1.2, 2.0, np.inf, np.inf]), constraint_margin=0.35, body=0.3)
    state = np.array([3.61 - 0.3, -0.917, 0.0])
    u_prev = np.array([0.8, 0.0])
    held, u = {}, {}
    for name, ahead in (("output", np.inf), ("near", rows_ahead(0.3, 0.01, 1.2))):
        u[name] = u_prev.copy()
        held[name] = keep_constraints(
            state, u_prev, kinds, params, 0.3, plant, scratch(), u[name], 0.1, ahead
        )
    assert held == {"output": True, "near": False}
    assert u["near"].tolist() == [0.8, 0.0]
    assert abs(u["output"][0] - 0.8) + abs(u["output"][1]) > 0.1


def test_a_robot_with_a_long_look_ahead_passes_the_pallet_in_its_aisle() -> None:
    run = run_mission(mission_from_text(AISLE))
    assert run.outcome.value == "success"  # was: timeout at 20 s, 5.1 m from (8, 0)
    phase = judge(run, run.mission)["phases"][0]
    assert phase["end"] < 11.0  # 8 m at 0.8 m/s and the detour: 9.88 s
    assert phase["inputs"]["speed_reversals"] <= 1  # was 72
    assert phase["inputs"]["speed_jump_max"] < 0.1  # was 1.42 m/s
    assert phase["constraint"]["clearance_min"] > 0.15  # the body clear of aisle and pallet
    assert phase["constraint"]["max_violation"] == 0.0
    assert phase["tracking"]["detour_offset_max"] > 0.9  # by the pallet's south side
