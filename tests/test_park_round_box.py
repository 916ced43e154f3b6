"""A park whose straight way crosses a keep-out box or polygon goes round it
along the tangent, as it goes round an ellipse (controllers/paper.py,
_polygon_tangent; docs/paper-notes.md, eq. (28), "A park round a box or a
polygon")."""

from __future__ import annotations

import numpy as np
import pytest

from wmr_mission import mission_from_text, run_mission
from wmr_mission.geometry.regions import constraint_rows
from wmr_mission.kernels.convex import polygon_distance

# A user's mission: the robot at the origin, its target 3 m behind a wall
# across the straight way.
PARK_BEHIND = """\
version: 1
name: park-behind-a-wall
robot:
  dt: 0.01
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: 0.7, omega: 1.5{acceleration}}}
regions:
  wall: {wall}
phases:
  - name: park
    regulate: {{target: {{x: -3, y: 0, theta: 1.5708}}}}
    constraints: [{{stay_outside: wall}}]
    until: {{settled: {{position: 0.03, heading: 0.03}}}}
    timeout: 40
"""

WALLS = {
    "box": "{type: box, min: [-1.6, -0.8], max: [-1.3, 0.6]}",
    "polygon": "{type: polygon, vertices: [[-1.2, -0.5], [-1.8, -0.7], [-2.0, 0.2], [-1.4, 0.6]]}",
}


@pytest.mark.parametrize("acceleration", ["", ", acceleration: {v: 1.0, omega: 3.0}"])
@pytest.mark.parametrize("wall", sorted(WALLS))
def test_a_park_behind_a_wall_goes_round_it(wall: str, acceleration: str) -> None:
    """Before: the robot drove straight at the wall and stood at its face
    (or at its corner) until the timeout, 1.75 m from its target."""
    mission = mission_from_text(PARK_BEHIND.format(wall=WALLS[wall], acceleration=acceleration))
    run = run_mission(mission)
    assert run.outcome.value == "success"
    assert np.hypot(run.x[-1] + 3.0, run.y[-1]) < 0.03
    _, params = constraint_rows(mission.regions["wall"], "outside")
    clearance = [polygon_distance(params[0], x, y)[0] for x, y in zip(run.x, run.y, strict=True)]
    assert min(clearance) > 0.0
