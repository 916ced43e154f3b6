"""An ellipse, eq. (31): p = c + Rot(rotation) (a cos(w t + phi0), b sin(w t + phi0)),
its geometry given or taken from an ellipse or circle region."""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

from numpy.typing import ArrayLike
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from wmr_mission.basics import FloatArray
from wmr_mission.fields import (
    Model,
    NonzeroScalar,
    Point,
    PositiveScalar,
    RegionName,
    Scalar,
    StartAngle,
)
from wmr_mission.geometry.paths.registry import Context, PathType, Pose, Sample, times
from wmr_mission.geometry.regions import ellipse_geometry
from wmr_mission.kernels import scalar_math


class EllipseGeometry(Model):
    region: RegionName | None = Field(
        default=None, description="Name of an ellipse or circle region giving the geometry."
    )
    center: Point | None = Field(default=None, description="Centre [x, y] [m], without region.")
    semi_axes: tuple[PositiveScalar, PositiveScalar] | None = Field(
        default=None, description="Semi-axes [a, b] [m], without region."
    )
    rotation: Scalar | None = Field(
        default=None, description="Rotation [rad] (default 0), without region."
    )

    @model_validator(mode="after")
    def _one_geometry(self) -> EllipseGeometry:
        explicit = self.center is not None or self.semi_axes is not None
        if self.region is not None and (explicit or self.rotation is not None):
            raise PydanticCustomError(
                "ellipse_geometry",
                "give either 'region' or 'center' + 'semi_axes' (+ 'rotation'), not both",
            )
        if self.region is None and (self.center is None or self.semi_axes is None):
            raise PydanticCustomError(
                "ellipse_geometry", "give either 'region' or both 'center' and 'semi_axes'"
            )
        return self


class EllipsePath(EllipseGeometry):
    """Eq. (31): p = c + Rot(rotation)(a cos(wt + phi0), b sin(wt + phi0))."""

    type: Literal["ellipse"] = Field(description="Path kind.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero.")
    start: StartAngle = Field(
        default="current",
        description=(
            "'current' (phi0 = atan2(w/b, u/a) of the robot in the ellipse frame) or phi0 [rad]."
        ),
    )


class EllipseTrajectory(NamedTuple):
    """eq. (31): p = c + Rot(rotation) (a cos(w t + phi0), b sin(w t + phi0)).

    A circle is the case a = b.
    """

    cx: float
    cy: float
    a: float
    b: float
    rotation: float
    angular_rate: float
    phase: float

    def sample(self, t: ArrayLike) -> Sample:
        angle = self.angular_rate * times(t) + self.phase
        cos, sin = scalar_math.cos(angle), scalar_math.sin(angle)
        u, w = self.a * cos, self.b * sin
        du, dw = -self.a * self.angular_rate * sin, self.b * self.angular_rate * cos
        return placed(self.cx, self.cy, self.rotation, u, w, du, dw)


def placed(
    cx: float,
    cy: float,
    rotation: float,
    u: FloatArray,
    w: FloatArray,
    du: FloatArray,
    dw: FloatArray,
) -> Sample:
    """Rotate ellipse-frame position and velocity by ``rotation`` and move them to the centre."""
    c, s = math.cos(rotation), math.sin(rotation)
    return cx + c * u - s * w, cy + s * u + c * w, c * du - s * dw, s * du + c * dw


def ellipse_of(path: EllipseGeometry, context: Context) -> tuple[float, float, float, float, float]:
    """``cx, cy, a, b, rotation`` from the path's region or its own fields."""
    if path.region is not None:
        if path.region not in context.regions:
            raise ValueError(f"undefined region {path.region!r}")
        return ellipse_geometry(context.regions[path.region])
    if path.center is None or path.semi_axes is None:
        raise ValueError("an ellipse path needs 'region' or 'center' and 'semi_axes'")
    (cx, cy), (a, b) = path.center, path.semi_axes
    return cx, cy, a, b, path.rotation or 0.0


def ellipse_angle(geometry: tuple[float, float, float, float, float], x: float, y: float) -> float:
    """The angle phi0 of eq. (31) at which the ray from the centre meets the point (x, y)."""
    cx, cy, a, b, rotation = geometry
    c, s = math.cos(rotation), math.sin(rotation)
    dx, dy = x - cx, y - cy
    u, w = c * dx + s * dy, -s * dx + c * dy
    return math.atan2(w / b, u / a)


def start_phase(start: float | str, current: float) -> float:
    return current if start == "current" else float(start)


def trajectory(path: EllipsePath, context: Context, pose: Pose) -> EllipseTrajectory:
    geometry = ellipse_of(path, context)
    phase = start_phase(path.start, ellipse_angle(geometry, pose[0], pose[1]))
    return EllipseTrajectory(*geometry, angular_rate=path.angular_rate, phase=phase)


# Registered by wmr_mission.geometry.paths.
PATH = PathType(EllipsePath, trajectory)
