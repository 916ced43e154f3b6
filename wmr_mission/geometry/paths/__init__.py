"""The paths a track phase follows: one module per type (wmr_mission.geometry.paths.registry).

:func:`trajectory` turns a path of the mission (plus the robot's pose at phase
entry, for ``start: current``) into a trajectory whose ``sample`` returns
positions and velocities for a whole array of phase-local times. Primitives
have analytic velocities; expression paths use a central difference.
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.geometry.paths import (
    circle,
    coverage,
    ellipse,
    elliptical_spiral,
    expression,
    line,
    polyline,
    spiral,
    waypoints,
)
from wmr_mission.geometry.paths.registry import (
    PATHS,
    Context,
    PathSettings,
    PathType,
    Pose,
    Trajectory,
)

__all__ = [
    "PATHS",
    "Context",
    "PathSettings",
    "PathSpec",
    "PathType",
    "Trajectory",
    "drawn_points",
    "trajectory",
]

# The built-in types, in the order the schema lists them.
for _builtin in (
    line.PATH,
    circle.PATH,
    ellipse.PATH,
    spiral.PATH,
    elliptical_spiral.PATH,
    waypoints.PATH,
    expression.PATH,
    polyline.PATH,
    coverage.PATH,
):
    PATHS.register(_builtin)


# A path as a mission writes it: the settings of any registered type.
PathSpec = Annotated[PathSettings, PATHS]


def trajectory(path: PathSettings, context: Context, pose: Pose) -> Trajectory:
    """The trajectory of ``path`` for a phase entered at the (estimated) ``pose``."""
    x, y, theta = (float(value) for value in pose)
    return PATHS[path.type].trajectory(path, context, (x, y, theta))


def drawn_points(path: PathSettings, context: Context) -> FloatArray | None:
    """The points a path is drawn through, ``(m, 2)``, for figures: a waypoint or
    polyline path's points, a coverage path's lane ends; None for other paths.
    (With ``start: current`` the route also passes the robot's position.)"""
    return PATHS[path.type].points(path, context)


def sample_positions(
    trajectory: Trajectory, t_end: float, dt: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Times ``0, dt, ..., <= t_end`` and the positions there: ``(t, x, y)``."""
    count = math.floor(t_end / dt + 1e-9) + 1
    time = np.arange(count, dtype=np.float64) * dt
    x, y, _, _ = trajectory.sample(time)
    return time, x, y
