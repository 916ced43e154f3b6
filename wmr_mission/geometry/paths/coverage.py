"""A boustrophedon (lawnmower) over a box or convex polygon region."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from wmr_mission.basics import FloatArray
from wmr_mission.fields import Model, NonNegativeScalar, PositiveScalar, RegionName, Scalar
from wmr_mission.geometry.paths.polyline import joined
from wmr_mission.geometry.paths.registry import Context, PathType, Pose
from wmr_mission.geometry.regions import constraint_rows, region_vertices
from wmr_mission.geometry.routes import RouteTrajectory, coverage_points


class CoveragePath(Model):
    """A boustrophedon (lawnmower) over a box or convex polygon region: parallel
    lanes, run alternately back and forth, joined by arcs of the turn radius."""

    type: Literal["coverage"] = Field(description="Path kind.")
    region: RegionName = Field(description="Name of the box or polygon region to cover.")
    spacing: PositiveScalar = Field(
        description=(
            "Largest distance between neighbouring lanes [m], > 0; lanes are spread evenly, "
            "the outer ones half a spacing inside the field."
        )
    )
    direction: Scalar = Field(default=0.0, description="Direction of the lanes [rad] from +x.")
    turn_radius: NonNegativeScalar | None = Field(
        default=None,
        description=(
            "Radius of the turns at the lane ends [m], >= 0; default half the spacing "
            "(a semicircle); 0 = turn in place."
        ),
    )
    turn_rate: PositiveScalar = Field(
        default=1.0, description="Turn rate of a turn in place [rad/s], > 0."
    )
    speed: PositiveScalar = Field(description="Speed along lanes and turns [m/s], > 0.")
    start: Literal["current", "first"] = Field(
        default="current",
        description="current: drive from the robot's position to the first lane; first: start "
        "on the first lane.",
    )


def points(path: CoveragePath, context: Context) -> FloatArray:
    """The lane ends, in the order they are driven."""
    region = context.regions[path.region]
    _, rows = constraint_rows(region, "inside")
    return coverage_points(region_vertices(region), rows[:, :3], path.spacing, path.direction)


def trajectory(path: CoveragePath, context: Context, pose: Pose) -> RouteTrajectory:
    radius = 0.5 * path.spacing if path.turn_radius is None else path.turn_radius
    # a turn sharper than a right angle cuts no more than its radius off a lane
    return joined(
        points(path, context), pose[:2], path.start, False, path.speed, radius, path.turn_rate,
        longest_cut=radius, acceleration=context.acceleration,
    )  # fmt: skip


# Registered by wmr_mission.geometry.paths.
PATH = PathType(CoveragePath, trajectory, points)
