"""x(t), y(t) as restricted expressions of phase-local time t (wmr_mission.expressions)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import BeforeValidator, Field, ValidationInfo, WithJsonSchema, field_validator
from pydantic_core import PydanticCustomError

from wmr_mission.basics import FloatArray
from wmr_mission.expressions import Expression, ExpressionError, parse
from wmr_mission.fields import Model, parameters_of
from wmr_mission.geometry.paths.registry import Context, PathType, Pose, Sample, times


def _number_as_text(value: Any) -> Any:
    """`y: 0` is a constant expression too."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return repr(value)
    return value


ExpressionText = Annotated[
    str,
    BeforeValidator(_number_as_text),
    WithJsonSchema({"type": ["number", "string"]}, mode="validation"),
]


class ExpressionPath(Model):
    """x(t), y(t) as restricted expressions of phase-local time t [s]."""

    type: Literal["expression"] = Field(description="Path kind.")
    x: ExpressionText = Field(description="x(t) [m], e.g. '2*exp(0.5*t)*cos(0.4*pi*t)'.")
    y: ExpressionText = Field(description="y(t) [m].")
    start: Literal["as-written", "current"] = Field(
        default="as-written",
        description="as-written: as the text says; current: translated so p(0) is the robot.",
    )

    @field_validator("x", "y")
    @classmethod
    def _parses(cls, text: str, info: ValidationInfo) -> str:
        try:
            parse(text, parameters_of(info), allow_t=True)
        except ExpressionError as error:
            raise PydanticCustomError(
                "expression",
                "invalid expression: {message}",
                {"message": error.message, "column": error.column},
            ) from None
        return text


@dataclass(frozen=True)
class ExpressionTrajectory:
    """x(t), y(t) from expressions, moved by ``offset``; velocity by a central difference."""

    x: Expression
    y: Expression
    parameters: dict[str, float]
    offset_x: float = 0.0
    offset_y: float = 0.0

    def positions(self, t: FloatArray) -> tuple[FloatArray, FloatArray]:
        return (
            self.x.evaluate(t, self.parameters) + self.offset_x,
            self.y.evaluate(t, self.parameters) + self.offset_y,
        )

    def sample(self, t: ArrayLike) -> Sample:
        time = times(t)
        # a step suited to float64: about the cube root of the machine epsilon, relative
        step = 1e-5 * np.maximum(1.0, np.abs(time))
        stacked = np.concatenate([time.ravel(), (time + step).ravel(), (time - step).ravel()])
        xs, ys = self.positions(stacked)
        n = time.size
        width = (2.0 * step).ravel()
        vx = (xs[n : 2 * n] - xs[2 * n :]) / width
        vy = (ys[n : 2 * n] - ys[2 * n :]) / width
        shape = time.shape
        return (
            xs[:n].reshape(shape),
            ys[:n].reshape(shape),
            vx.reshape(shape),
            vy.reshape(shape),
        )


def trajectory(path: ExpressionPath, context: Context, pose: Pose) -> ExpressionTrajectory:
    parameters = dict(context.parameters)
    written = ExpressionTrajectory(parse(path.x, parameters), parse(path.y, parameters), parameters)
    if path.start == "as-written":
        return written
    x_start, y_start = written.positions(np.zeros(1))
    return ExpressionTrajectory(
        written.x,
        written.y,
        parameters,
        offset_x=pose[0] - float(x_start[0]),
        offset_y=pose[1] - float(y_start[0]),
    )


# Registered by wmr_mission.geometry.paths.
PATH = PathType(ExpressionPath, trajectory)
