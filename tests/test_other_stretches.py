"""A keep-out zone's way round applies to the pass, the stretch of path that
goes by the zone, not to every stretch heading the same way
(controllers/constrained_tracking.on_another_stretch, docs/paper-notes.md,
eq. (28), "Another stretch of the path past a zone")."""

from __future__ import annotations

import numpy as np
from aims import moved_across, spiral_past

from wmr_mission import mission_from_text, run_mission
from wmr_mission.geometry.regions import CircleRegion, constraint_rows


def test_a_lane_heading_the_same_way_past_a_pond_is_left_alone() -> None:
    """Two lanes of a coverage path heading west, 1.6 m apart: a pond of
    radius 0.3 m 0.4 m above the lower one. The lower lane goes round it;
    the upper lane, 1.2 m above the pond, made the same detour (0.1 m)
    when the way round was measured on the lower lane's line alone."""
    lane = np.linspace(6.0, 0.0, 601)
    west = np.column_stack([lane, np.zeros(601), np.full(601, -1.0), np.zeros(601)])
    # the lower lane, then round by the north, far from the pond, and the upper one
    round_by = np.array([[-1.0, 1.2, 0.0, 1.0], [-1.0, 4.0, 1.0, 0.0], [7.0, 4.0, 0.0, -1.0]])
    lower, upper = west.copy(), west.copy()
    lower[:, 1], upper[:, 1] = 1.2, 2.8
    path = np.vstack([lower, round_by, upper])
    pond = CircleRegion(type="circle", center=(3.0, 1.6), radius=0.3)
    kinds, params = constraint_rows(pond, "outside")
    moved = moved_across(path, kinds, params)
    assert moved[:601].max() > 0.02  # the lower lane goes round below the pond (its left)
    assert np.abs(moved[-601:]).max() == 0.0  # the upper lane runs straight on


SPIRAL = spiral_past("{type: circle, center: [-1.2, 1.1], radius: 0.4}")


def test_a_spirals_first_loop_does_not_go_round_a_rock_its_second_loop_passes() -> None:
    """A user's spiral, its second loop through a rock 0.73 m outside its
    first: the first loop cut 0.33 m inside itself at the rock's bearing,
    1 m from the rock, and the run failed on its cross-track error. The
    first loop now stays on the spiral, the second goes round the rock."""
    run = run_mission(mission_from_text(SPIRAL))
    assert run.outcome.value == "success"
    first_loop = run.t < 12.0
    off = np.hypot(run.x - run.x_ref, run.y - run.y_ref)[:-1]  # the last sample has no reference
    assert off[first_loop[:-1]].max() < 0.01
    assert off.max() > 0.2  # the second loop's detour
    clearance = np.hypot(run.x + 1.2, run.y - 1.1) - 0.4
    assert clearance.min() > 0.05
