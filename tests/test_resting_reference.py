"""Eq. (27)'s bound on the error closed per sample (controllers/paper.py,
``track_input``; docs/paper-notes.md, "Eq. (27) far from the path: the error
closed per sample is bounded"): along the robot's heading, where closing
turns nothing, the bound lets the robot use what its speed limit leaves over
the path's own speed, so that it catches a reference resting ahead of it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from wmr_mission import load_mission, run_mission

GENERATED = Path(__file__).resolve().parent / "data" / "generated"


def test_behind_a_resting_reference_the_robot_closes_at_its_speed_limit() -> None:
    """gen-188-polyline: its reference rests at the polyline's first corner
    from 1.2 s to 1.65 s while the robot, entered facing away, is 1.1 m
    behind. It crawled there at 1.06 m/s, 0.3 of its 3.54 m/s limit, was
    0.6 m short when the path moved on, cut the corner and failed 0.172 m
    off the path (0.111 allowed). Now it reaches the corner at its limit and
    follows the next leg."""
    mission = load_mission(GENERATED / "gen-188-polyline.yaml")
    result = run_mission(mission)
    route = result.phase == 0
    ref_x, ref_y = result.x_ref[route], result.y_ref[route]
    resting = np.flatnonzero((np.diff(ref_x) == 0.0) & (np.diff(ref_y) == 0.0))
    assert resting.size >= 5  # the corner's rest, in samples
    gap = np.hypot(ref_x - result.x[route], ref_y - result.y[route])[resting]
    far = resting[gap > 0.5]
    assert far.size >= 2
    assert np.min(result.v[route][far]) >= 0.9 * mission.robot.limits.v
    assert result.outcome == "success", result.message
