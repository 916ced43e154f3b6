"""A circle at a constant turn rate: p = c + r (cos(w t + phi0), sin(w t + phi0))."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field

from wmr_mission.fields import Model, NonzeroScalar, Point, PositiveScalar, StartAngle
from wmr_mission.geometry.paths.ellipse import EllipseTrajectory, start_phase
from wmr_mission.geometry.paths.registry import Context, PathType, Pose


class CirclePath(Model):
    """p = c + r(cos(wt + phi0), sin(wt + phi0))."""

    type: Literal["circle"] = Field(description="Path kind.")
    center: Point = Field(description="Centre [x, y] [m].")
    radius: PositiveScalar = Field(description="Radius [m], > 0.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero; > 0 counter-clockwise.")
    start: StartAngle = Field(
        default="current",
        description="'current' (phi0 = polar angle of the robot about the centre) or phi0 [rad].",
    )


def trajectory(path: CirclePath, context: Context, pose: Pose) -> EllipseTrajectory:
    cx, cy = path.center
    phase = start_phase(path.start, math.atan2(pose[1] - cy, pose[0] - cx))
    radius = path.radius
    return EllipseTrajectory(cx, cy, radius, radius, 0.0, path.angular_rate, phase)


# Registered by wmr_mission.geometry.paths.
PATH = PathType(CirclePath, trajectory)
