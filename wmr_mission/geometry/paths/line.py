"""A straight line at constant speed: p(t) = p0 + speed * t * (cos h, sin h)."""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from wmr_mission.fields import Model, Point, PositiveScalar, Scalar
from wmr_mission.geometry.paths.registry import Context, PathType, Pose, Sample, times


class LinePath(Model):
    """p(t) = p0 + speed*t*(cos h, sin h)."""

    type: Literal["line"] = Field(description="Path kind.")
    start: Literal["current"] | Point = Field(
        default="current", description="'current' (the robot's position) or [x, y] [m]."
    )
    heading: Scalar | None = Field(
        default=None, description="Direction h [rad]; give heading or towards."
    )
    towards: Point | None = Field(
        default=None, description="A point [x, y] [m] the line heads to; give heading or towards."
    )
    speed: PositiveScalar = Field(description="Speed along the line [m/s], > 0.")

    @model_validator(mode="after")
    def _one_direction(self) -> LinePath:
        if (self.heading is None) == (self.towards is None):
            raise PydanticCustomError(
                "line_direction", "a line path needs exactly one of 'heading' or 'towards'"
            )
        return self


class LineTrajectory(NamedTuple):
    """p(t) = p0 + speed * t * (cos h, sin h)."""

    x0: float
    y0: float
    heading: float
    speed: float

    def sample(self, t: ArrayLike) -> Sample:
        time = times(t)
        vx = self.speed * math.cos(self.heading)
        vy = self.speed * math.sin(self.heading)
        return (
            self.x0 + vx * time,
            self.y0 + vy * time,
            np.full(time.shape, vx),
            np.full(time.shape, vy),
        )


def trajectory(path: LinePath, context: Context, pose: Pose) -> LineTrajectory:
    x, y, theta = pose
    x0, y0 = (x, y) if path.start == "current" else path.start
    if path.towards is not None:
        dx, dy = path.towards[0] - x0, path.towards[1] - y0
        # already there: keep the robot's heading rather than an arbitrary one
        heading = math.atan2(dy, dx) if (dx, dy) != (0.0, 0.0) else theta
    else:
        heading = path.heading if path.heading is not None else theta
    return LineTrajectory(x0, y0, heading, path.speed)


# Registered by wmr_mission.geometry.paths.
PATH = PathType(LinePath, trajectory)
