"""What a path type is, and the registry of them.

A path type is one module: its settings (the model of ``track: {path: {type:
NAME, ...}}``, with ``type: Literal[NAME]``), a function turning them into a
:class:`Trajectory` for a phase entered at a pose, and optionally the points
its figure marks; then one registration, ``PATHS.register(PathType(...))``.
The mission's schema gains the type once it is regenerated
(``python -m wmr_mission.commands.schema``).

A trajectory is sampled vectorised, in phase-local time: numpy's arithmetic,
and wmr_mission.kernels.scalar_math's sin, cos and exp, which give the same
bits on every CPU.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike

from wmr_mission.basics import FloatArray
from wmr_mission.fields import Model, Registry
from wmr_mission.geometry.regions import RegionSpec

Sample = tuple[FloatArray, FloatArray, FloatArray, FloatArray]
Pose = tuple[float, float, float]


class Trajectory(Protocol):
    """A reference path in phase-local time."""

    def sample(self, t: ArrayLike) -> Sample:
        """x, y, dx/dt, dy/dt at phase-local times ``t`` (vectorised)."""
        ...


@dataclass(frozen=True)
class Context:
    """What a path may refer to besides its own settings: the mission's
    regions (by name) and its named parameters (for expressions)."""

    regions: Mapping[str, RegionSpec] = field(default_factory=dict)
    parameters: Mapping[str, float] = field(default_factory=dict)
    # [m/s^2] the share of the robot's speed acceleration a route's stops are
    # planned with (inf: the robot has no such limit)
    acceleration: float = math.inf


class PathSettings(Protocol):
    """What every path's settings (a model with ``type: Literal[NAME]``) hold."""

    @property
    def type(self) -> str: ...


def no_points(settings: Any, context: Context) -> FloatArray | None:
    return None


class PathType(NamedTuple):
    """One type of path a mission may follow."""

    settings: type[Model]
    # The trajectory of a phase entered at the (estimated) pose.
    trajectory: Callable[[Any, Context, Pose], Trajectory]
    # The points the path is drawn through ((m, 2), for figures), or None.
    points: Callable[[Any, Context], FloatArray | None] = no_points


PATHS: Registry[PathType] = Registry("path")


def times(t: ArrayLike) -> FloatArray:
    return np.asarray(t, dtype=np.float64)
