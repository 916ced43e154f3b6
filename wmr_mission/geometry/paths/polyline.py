"""Straight legs through points at constant speed, corners rounded by arcs or
turned in place (wmr_mission.geometry.routes)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Literal

import numpy as np
from pydantic import Field

from wmr_mission.basics import FloatArray
from wmr_mission.fields import Model, NonNegativeScalar, Point, PositiveScalar
from wmr_mission.geometry.paths.registry import Context, PathType, Pose
from wmr_mission.geometry.routes import RouteTrajectory, polyline_route


class PolylinePath(Model):
    """Straight legs through the points at constant speed, corners rounded by arcs
    (or turned in place); never leaves the points' convex hull."""

    type: Literal["polyline"] = Field(description="Path kind.")
    points: list[Point] = Field(
        min_length=1,
        max_length=10000,
        description="At least 1 point [[x, y], ...] [m] (with start: current, the robot's "
        "position comes first).",
    )
    speed: PositiveScalar = Field(description="Speed along legs and arcs [m/s], > 0.")
    corner_radius: NonNegativeScalar = Field(
        default=0.0,
        description=(
            "Radius of the arc joining two legs [m], >= 0, shrunk where it does not fit in "
            "half of either leg; 0 = stop and turn in place."
        ),
    )
    turn_rate: PositiveScalar = Field(
        default=1.0, description="Turn rate of a turn in place [rad/s], > 0."
    )
    start: Literal["current", "first"] = Field(
        default="current",
        description=(
            "current: an open route starts at the robot's position, a closed one where it "
            "passes nearest the robot; first: at the first point."
        ),
    )
    closed: bool = Field(default=False, description="Return to the first point and loop.")


def joined(
    points: FloatArray,
    robot: tuple[float, float],
    start: str,
    closed: bool,
    speed: float,
    corner_radius: float,
    turn_rate: float,
    longest_cut: float = math.inf,
    acceleration: float = math.inf,
) -> RouteTrajectory:
    """The route through ``points``; with ``start: current`` an open route begins
    at the robot and a closed one at its point nearest the robot. Its stops are
    planned at ``acceleration`` (routes.polyline_route)."""
    if start == "current" and not closed:
        points = np.vstack([robot, points])
    route = polyline_route(
        points, speed, closed, corner_radius, turn_rate, longest_cut, acceleration
    )
    if start == "current" and route.closed:
        return replace(route, start_time=route.nearest_time(*robot))
    return route


def trajectory(path: PolylinePath, context: Context, pose: Pose) -> RouteTrajectory:
    points = np.asarray(path.points, dtype=np.float64)
    return joined(
        points, pose[:2], path.start, path.closed, path.speed, path.corner_radius, path.turn_rate,
        acceleration=context.acceleration,
    )  # fmt: skip


def points(path: PolylinePath, context: Context) -> FloatArray:
    return np.asarray(path.points, dtype=np.float64).reshape(-1, 2)


# Registered by wmr_mission.geometry.paths.
PATH = PathType(PolylinePath, trajectory, points)
