"""Clearance: how far the robot's body stayed from the forbidden side of its
zones, in metres.

A point robot's clearance is minus its depth (wmr_mission.verdicts.zones): the
distance to a zone's edge on the allowed side, negative beyond it. A round
body takes its radius off that, exactly. A polygon body is placed at each
recorded pose and measured with shapely against the zone (an ellipse as a
polygon of ELLIPSE_CORNERS corners inscribed in it, so the distance to it is
slightly above the true one, by at most ``a (1 - cos(pi / 720))``, 5e-6 times
the semi-major axis: far below what a clearance is judged at); where the body
overlaps a zone, the clearance is minus the deepest corner of either inside the
other, and never above ``-RESOLUTION``: touching is not clear.

Values are rounded to RESOLUTION, to which depths are known: a robot held on
a zone's edge by the corrective action has a clearance of 0, not of -1e-12.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.geometry.regions import box_corners
from wmr_mission.verdicts.zones import RESOLUTION, Bounds, Zone

# Decimals of a metre a clearance is given to: RESOLUTION's.
_DIGITS = round(-math.log10(RESOLUTION))
# Corners of the polygon an ellipse or circle zone is measured as, for a polygon body.
ELLIPSE_CORNERS = 720
# [m] how far round a half-plane zone is drawn as a polygon: beyond any mission.
_HALF_PLANE_SIZE = 1e7


def clearance_min(
    x: FloatArray,
    y: FloatArray,
    theta: FloatArray,
    zones: Sequence[Zone],
    footprint: Mapping[str, Any] | None,
    bounds: Sequence[Bounds | None] | None = None,
    finite: bool | None = None,
) -> float | None:
    """[m] the least clearance of the body over the poses, to any of the zones
    (None without zones or poses, or where a pose is not finite). ``bounds``:
    each zone's :meth:`Zone.bounds` of the positions, and ``finite``: whether
    every pose is finite, if at hand."""
    if not zones or x.size == 0:
        return None
    if finite is None:
        finite = bool(np.isfinite(x).all() and np.isfinite(y).all() and np.isfinite(theta).all())
    if not finite:
        return None
    if footprint is None or "radius" in footprint:
        radius = 0.0 if footprint is None else float(footprint["radius"])
        # the deepest point measured alone: an ellipse's exact distance costs an iteration
        least = (
            min(
                -zone.max_depth(x, y, bounds=None if bounds is None else bounds[i])
                for i, zone in enumerate(zones)
            )
            - radius
        )
    else:
        corners = np.asarray(footprint["polygon"], dtype=np.float64)
        least = min(float(np.min(_polygon_clearances(x, y, theta, corners, z))) for z in zones)
    return round(least, _DIGITS) + 0.0  # + 0.0: no -0.0


def body_clearances(
    x: FloatArray,
    y: FloatArray,
    theta: FloatArray,
    zones: Sequence[Zone],
    footprint: Mapping[str, Any] | None,
) -> FloatArray:
    """[m] the body's clearance at each pose (finite), to the nearest of the
    zones (at least one), rounded as :func:`clearance_min` rounds its least:
    where a failed ``clearance_min`` check went below its bound, sample by
    sample (verdicts.png, ``first_violation``)."""
    if footprint is None or "radius" in footprint:
        radius = 0.0 if footprint is None else float(footprint["radius"])
        depth = np.max([zone.depth(x, y) for zone in zones], axis=0)
        found = -depth - radius
    else:
        corners = np.asarray(footprint["polygon"], dtype=np.float64)
        found = np.min([_polygon_clearances(x, y, theta, corners, z) for z in zones], axis=0)
    # rounded as clearance_min rounds its least (Python's round, not numpy's:
    # they differ at a tie of the decimal), + 0.0: no -0.0
    return np.array([round(value, _DIGITS) + 0.0 for value in found.tolist()])


def _polygon_clearances(
    x: FloatArray, y: FloatArray, theta: FloatArray, corners: FloatArray, zone: Zone
) -> FloatArray:
    """The polygon body's clearance to ``zone`` at each pose."""
    import shapely

    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    world_x = x[:, None] + c * corners[:, 0] - s * corners[:, 1]
    world_y = y[:, None] + s * corners[:, 0] + c * corners[:, 1]
    bodies = shapely.polygons(np.stack([world_x, world_y], axis=-1))
    region = _allowed_complement(zone)
    found: FloatArray = shapely.distance(bodies, region)
    touching = np.flatnonzero(found <= 0.0)
    if touching.size == 0:
        return found
    # overlapping: the deepest corner of the body in the zone, or of the zone in the body
    shape = (touching.size, corners.shape[0])
    deepest = np.max(
        zone.depth(world_x[touching].ravel(), world_y[touching].ravel()).reshape(shape), axis=1
    )
    outline = np.asarray(region.exterior.coords) if zone.region["type"] != "half-plane" else None
    if outline is not None and not zone.keep_inside:
        for i, k in enumerate(touching):
            body = bodies[k]
            inside = shapely.contains_xy(body, outline[:, 0], outline[:, 1])
            if inside.any():
                points = shapely.points(outline[inside])
                depth = float(np.max(shapely.distance(body.exterior, points)))
                deepest[i] = max(deepest[i], depth)
    found[touching] = np.minimum(-deepest, -RESOLUTION)
    return found


def _allowed_complement(zone: Zone) -> Any:
    """The forbidden side of a zone as a shapely geometry: the region itself
    for a keep-out zone, the ring round it (to far away) for a keep-in one."""
    import shapely

    region = region_geometry(zone.region)
    if not zone.keep_inside:
        return region
    far = shapely.box(-_HALF_PLANE_SIZE, -_HALF_PLANE_SIZE, _HALF_PLANE_SIZE, _HALF_PLANE_SIZE)
    return far.difference(region)


def region_geometry(region: Mapping[str, Any], corners: int = ELLIPSE_CORNERS) -> Any:
    """A region as a shapely polygon (an ellipse inscribed with ``corners``; a
    half-plane as a square reaching far beyond any mission): for the judge, the
    IR-SIM world and figures."""
    import shapely

    kind = region["type"]
    if kind in ("circle", "ellipse"):
        cx, cy = region["center"]
        if kind == "circle":
            a = b = float(region["radius"])
            rotation = 0.0
        else:
            a, b = (float(v) for v in region["semi_axes"])
            rotation = float(region.get("rotation", 0.0))
        angle = np.linspace(0.0, 2.0 * math.pi, corners, endpoint=False)
        u, w = a * np.cos(angle), b * np.sin(angle)
        c, s = math.cos(rotation), math.sin(rotation)
        return shapely.Polygon(np.column_stack([cx + c * u - s * w, cy + s * u + c * w]))
    if kind == "box":
        return shapely.Polygon(box_corners(region))
    if kind == "polygon":
        return shapely.Polygon(region["vertices"])
    if kind == "half-plane":
        nx, ny = (float(v) for v in region["normal"])
        norm = math.hypot(nx, ny)
        nx, ny, offset = nx / norm, ny / norm, float(region["offset"]) / norm
        # the side n . p <= offset, as a square of side 2 * _HALF_PLANE_SIZE
        size = _HALF_PLANE_SIZE
        ox, oy = nx * offset, ny * offset
        tx, ty = -ny, nx
        return shapely.Polygon(
            [
                (ox + size * tx, oy + size * ty),
                (ox - size * tx, oy - size * ty),
                (ox - size * tx - 2 * size * nx, oy - size * ty - 2 * size * ny),
                (ox + size * tx - 2 * size * nx, oy + size * ty - 2 * size * ny),
            ]
        )
    raise ValueError(f"unknown region type {kind!r}")
