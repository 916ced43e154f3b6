"""A spiral, eq. (30): radius r0 exp(growth t) at angle w t + phi0 about the centre."""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from wmr_mission.fields import Model, NonzeroScalar, Point, PositiveScalar, Scalar, StartAngle
from wmr_mission.geometry.paths.ellipse import start_phase
from wmr_mission.geometry.paths.registry import Context, PathType, Pose, Sample, times
from wmr_mission.kernels import scalar_math


class SpiralPath(Model):
    """Eq. (30): r = r0 exp(growth_rate t), angle w t + phi0."""

    type: Literal["spiral"] = Field(description="Path kind.")
    center: Point = Field(default=(0.0, 0.0), description="Centre [x, y] [m].")
    initial_radius: PositiveScalar = Field(description="r0 [m], > 0.")
    growth_rate: Scalar = Field(description="Radial growth rate [1/s]; < 0 spirals in.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero.")
    start: StartAngle = Field(default=0.0, description="'current' or phi0 [rad].")


class SpiralTrajectory(NamedTuple):
    """eq. (30): radius r0 exp(growth t) at angle w t + phi0 about the centre."""

    cx: float
    cy: float
    initial_radius: float
    growth_rate: float
    angular_rate: float
    phase: float

    def sample(self, t: ArrayLike) -> Sample:
        time = times(t)
        angle = self.angular_rate * time + self.phase
        cos, sin = scalar_math.cos(angle), scalar_math.sin(angle)
        g, w = self.growth_rate, self.angular_rate
        # a spiral grown past float64 gives inf or nan, the caller's to judge
        with np.errstate(over="ignore", invalid="ignore"):
            radius = self.initial_radius * scalar_math.exp(g * time)
            return (
                self.cx + radius * cos,
                self.cy + radius * sin,
                radius * (g * cos - w * sin),
                radius * (g * sin + w * cos),
            )


def trajectory(path: SpiralPath, context: Context, pose: Pose) -> SpiralTrajectory:
    cx, cy = path.center
    phase = start_phase(path.start, math.atan2(pose[1] - cy, pose[0] - cx))
    return SpiralTrajectory(cx, cy, path.initial_radius, path.growth_rate, path.angular_rate, phase)


# Registered by wmr_mission.geometry.paths.
PATH = PathType(SpiralPath, trajectory)
