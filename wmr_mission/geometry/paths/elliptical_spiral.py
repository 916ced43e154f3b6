"""An elliptical spiral, eq. (32): the ellipse of eq. (31) scaled by exp(-decay t)."""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from wmr_mission.fields import NonzeroScalar, PositiveScalar, StartAngle
from wmr_mission.geometry.paths.ellipse import (
    EllipseGeometry,
    ellipse_angle,
    ellipse_of,
    placed,
    start_phase,
)
from wmr_mission.geometry.paths.registry import Context, PathType, Pose, Sample, times
from wmr_mission.kernels import scalar_math


class EllipticalSpiralPath(EllipseGeometry):
    """Eq. (32): the ellipse of eq. (31) scaled by exp(-decay_rate t)."""

    type: Literal["elliptical-spiral"] = Field(description="Path kind.")
    decay_rate: PositiveScalar = Field(description="Decay rate [1/s], > 0.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero.")
    start: StartAngle = Field(
        default="current",
        description=(
            "'current' (phi0 = atan2(w/b, u/a) of the robot in the ellipse frame) or phi0 [rad]."
        ),
    )


class EllipticalSpiralTrajectory(NamedTuple):
    """eq. (32): the ellipse of eq. (31) scaled by exp(-decay t)."""

    cx: float
    cy: float
    a: float
    b: float
    rotation: float
    decay_rate: float
    angular_rate: float
    phase: float

    def sample(self, t: ArrayLike) -> Sample:
        time = times(t)
        angle = self.angular_rate * time + self.phase
        cos, sin = scalar_math.cos(angle), scalar_math.sin(angle)
        with np.errstate(over="ignore", invalid="ignore"):  # far negative times overflow
            scale = scalar_math.exp(-self.decay_rate * time)
            u, w = self.a * scale * cos, self.b * scale * sin
            du = -self.decay_rate * u - self.angular_rate * self.a * scale * sin
            dw = -self.decay_rate * w + self.angular_rate * self.b * scale * cos
            return placed(self.cx, self.cy, self.rotation, u, w, du, dw)


def trajectory(
    path: EllipticalSpiralPath, context: Context, pose: Pose
) -> EllipticalSpiralTrajectory:
    geometry = ellipse_of(path, context)
    phase = start_phase(path.start, ellipse_angle(geometry, pose[0], pose[1]))
    return EllipticalSpiralTrajectory(
        *geometry, decay_rate=path.decay_rate, angular_rate=path.angular_rate, phase=phase
    )


# Registered by wmr_mission.geometry.paths.
PATH = PathType(EllipticalSpiralPath, trajectory)
