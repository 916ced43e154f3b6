"""Regions: what a mission writes of them, constraint rows for the kernels, and a
signed value for phase conditions.

A region reaches the corrective control of eqs. (22)-(28) as rows of a ``(q, 6)``
float array plus a ``(q,)`` integer kind (wmr_mission.kernels.corrective,
docs/architecture.md "Constraint rows"); a row is satisfied when its value
``c(x, y) <= 0``:

- kind ``ELLIPSE_ROW``, ellipse ``cx, cy, a, b, phi, sign``:
  ``sign * ((u/a)^2 + (w/b)^2 - 1)`` with ``[u, w] = Rot(-phi) [x - cx, y - cy]``;
  with ``sign = +1`` this is eq. (33) written as ``G - 1 <= 0``.
- kind ``HALF_PLANE_ROW``, half-plane ``nx, ny, offset, 0, 0, 0``:
  ``nx*x + ny*y - offset``, with a unit normal so the value is a signed distance.
- kind ``POLYGON_ROW``, keep out of a convex polygon: minus the signed
  distance to it; a row as wide as its vertices need (its columns:
  wmr_mission.kernels.convex).

A circle is an ellipse with equal semi-axes; kept inside, a box and a convex
polygon are one half-plane row per edge, kept outside one polygon row. The
functions here are the readable numpy reference; the runner's compiled kernel
implements the same formulas.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import (
    Field,
    SerializerFunctionWrapHandler,
    field_validator,
    model_serializer,
    model_validator,
)
from pydantic_core import PydanticCustomError

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.fields import (
    SMALLEST_POSITIVE,
    SMALLEST_SIZE,
    Model,
    Point,
    PositiveScalar,
    Scalar,
)
from wmr_mission.kernels.convex import HEADER, PER_VERTEX, polygon_distance
from wmr_mission.kernels.corrective import ELLIPSE_ROW, HALF_PLANE_ROW, POLYGON_ROW

__all__ = [
    "BoxRegion",
    "CircleRegion",
    "EllipseRegion",
    "HalfPlaneRegion",
    "PolygonRegion",
    "RegionSpec",
    "box_corners",
    "constraint_rows",
    "ellipse_geometry",
    "is_convex",
    "polygon_row",
    "region_outline",
    "region_value",
    "region_vertices",
    "row_gradients",
    "row_values",
]

Side = Literal["inside", "outside"]


class EllipseRegion(Model):
    """Inside: ((u/a)^2 + (w/b)^2 <= 1), [u, w] = Rot(-rotation)(p - center); eq. (33)."""

    type: Literal["ellipse"] = Field(description="Region kind.")
    center: Point = Field(default=(0.0, 0.0), description="Centre [x, y] [m].")
    semi_axes: tuple[PositiveScalar, PositiveScalar] = Field(
        description="Semi-axes [a, b] along the rotated x and y axes [m], > 0."
    )
    rotation: Scalar = Field(default=0.0, description="Rotation of the a axis from +x [rad].")


class CircleRegion(Model):
    """Inside: |p - center| <= radius."""

    type: Literal["circle"] = Field(description="Region kind.")
    center: Point = Field(default=(0.0, 0.0), description="Centre [x, y] [m].")
    radius: PositiveScalar = Field(description="Radius [m], > 0.")


class BoxRegion(Model):
    """A rectangle: {min, max} (axis-aligned, min <= p <= max componentwise), or
    {center, size, heading} (a shelf or pallet turned by heading)."""

    type: Literal["box"] = Field(description="Region kind.")
    min: Point | None = Field(default=None, description="Lower-left corner [x, y] [m].")
    max: Point | None = Field(
        default=None, description="Upper-right corner [x, y] [m], greater than min."
    )
    center: Point | None = Field(default=None, description="Centre [x, y] [m] (with size).")
    size: tuple[PositiveScalar, PositiveScalar] | None = Field(
        default=None,
        description="Length along its heading and width across it [m], > 0 (with center).",
    )
    heading: Scalar = Field(
        default=0.0, description="Rotation of its length from +x [rad] (with center and size)."
    )

    @model_validator(mode="after")
    def _one_form(self) -> BoxRegion:
        corners = self.min is not None or self.max is not None
        centred = self.center is not None or self.size is not None
        if corners == centred or (corners and "heading" in self.model_fields_set):
            raise PydanticCustomError(
                "box_form", "a box is {min, max} or {center, size, heading}, one of the two"
            )
        if centred and (self.center is None or self.size is None):
            raise PydanticCustomError(
                "box_form", "a box with a center needs its size [length, width]"
            )
        if corners:
            if self.min is None or self.max is None:
                raise PydanticCustomError("box_form", "a box with min needs max, and max min")
            if not (self.min[0] < self.max[0] and self.min[1] < self.max[1]):
                raise PydanticCustomError(
                    "box_order",
                    "a box needs min < max in both x and y (min is the lower-left corner)",
                )
            width, height = self.max[0] - self.min[0], self.max[1] - self.min[1]
            if min(width, height) < SMALLEST_SIZE:  # as a size [length, width] is bounded
                raise PydanticCustomError(
                    "box_size",
                    f"a box {{min, max}} of {width:g} x {height:g} m is implausibly small: "
                    f"expected max - min at least {SMALLEST_SIZE:g} in both x and y",
                )
        return self

    @model_serializer(mode="wrap")
    def _as_written(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The keys of the form written only: a {min, max} box dumps as before."""
        dumped: dict[str, Any] = handler(self)
        unused = ("center", "size", "heading") if self.min is not None else ("min", "max")
        return {key: value for key, value in dumped.items() if key not in unused}


class PolygonRegion(Model):
    """Convex polygon; inside is the interior."""

    type: Literal["polygon"] = Field(description="Region kind.")
    vertices: list[Point] = Field(
        min_length=3,
        max_length=1000,
        description="At least 3 vertices [[x, y], ...] [m], convex, either orientation.",
    )

    @field_validator("vertices")
    @classmethod
    def _distinct(cls, vertices: list[tuple[float, float]]) -> list[tuple[float, float]]:
        if len(set(vertices)) != len(vertices):
            raise PydanticCustomError("repeated_vertex", "a polygon vertex is repeated")
        return vertices


class HalfPlaneRegion(Model):
    """Inside: normal . p <= offset."""

    type: Literal["half-plane"] = Field(description="Region kind.")
    normal: Point = Field(description="Outward normal [nx, ny], not zero.")
    offset: Scalar = Field(description="Offset c of nx*x + ny*y <= c [m times |normal|].")

    @field_validator("normal")
    @classmethod
    def _nonzero_normal(cls, normal: tuple[float, float]) -> tuple[float, float]:
        if normal == (0.0, 0.0):
            raise PydanticCustomError("zero_normal", "a half-plane normal must not be [0, 0]")
        length = math.hypot(*normal)
        if length < SMALLEST_POSITIVE:  # its square, which scales the offset, would underflow
            raise PydanticCustomError(
                "implausibly_small",
                "a half-plane normal of length {length} is implausibly short: "
                "expected at least {floor}",
                {"length": f"{length:g}", "floor": f"{SMALLEST_POSITIVE:g}"},
            )
        return normal


RegionSpec = Annotated[
    EllipseRegion | CircleRegion | BoxRegion | PolygonRegion | HalfPlaneRegion,
    Field(discriminator="type"),
]


def ellipse_geometry(region: RegionSpec) -> tuple[float, float, float, float, float]:
    """``cx, cy, a, b, rotation`` of an ellipse or circle region."""
    if isinstance(region, EllipseRegion):
        cx, cy = region.center
        a, b = region.semi_axes
        return float(cx), float(cy), float(a), float(b), float(region.rotation)
    if isinstance(region, CircleRegion):
        cx, cy = region.center
        radius = float(region.radius)
        return float(cx), float(cy), radius, radius, 0.0
    raise ValueError(f"a {region.type} region has no ellipse geometry (expected ellipse or circle)")


def _edge_rows(vertices: ArrayLike) -> FloatArray:
    """``(n, 3)`` rows ``nx, ny, offset`` of a convex polygon, unit outward normals."""
    points = np.asarray(vertices, dtype=np.float64)
    following = np.roll(points, -1, axis=0)
    edges = following - points
    if _signed_area(points) < 0:  # clockwise: the outward normal is on the left
        normals = np.column_stack([-edges[:, 1], edges[:, 0]])
    else:
        normals = np.column_stack([edges[:, 1], -edges[:, 0]])
    normals /= np.hypot(normals[:, 0], normals[:, 1])[:, None]
    offsets = normals[:, 0] * points[:, 0] + normals[:, 1] * points[:, 1]
    return np.column_stack([normals, offsets])


def box_corners(region: Mapping[str, Any]) -> FloatArray:
    """``(4, 2)`` corners of a box (as written, or dumped), counter-clockwise
    from the lower-left one before turning by its heading."""
    if region.get("min") is not None:
        (x_min, y_min), (x_max, y_max) = region["min"], region["max"]
        return np.array(
            [[x_min, y_min], [x_max, y_min], [x_max, y_max], [x_min, y_max]], dtype=np.float64
        )
    cx, cy = (float(v) for v in region["center"])
    half_length, half_width = (0.5 * float(v) for v in region["size"])
    heading = float(region.get("heading") or 0.0)
    c, s = math.cos(heading), math.sin(heading)
    local = np.array(
        [
            [-half_length, -half_width],
            [half_length, -half_width],
            [half_length, half_width],
            [-half_length, half_width],
        ]
    )
    return np.column_stack(
        [cx + c * local[:, 0] - s * local[:, 1], cy + s * local[:, 0] + c * local[:, 1]]
    )


def _half_plane_rows(region: RegionSpec) -> FloatArray:
    """Outward half-plane rows ``nx, ny, offset`` of a box, polygon or half-plane."""
    if isinstance(region, BoxRegion) and region.min is not None and region.max is not None:
        (x_min, y_min), (x_max, y_max) = region.min, region.max
        return np.array(
            [
                [1.0, 0.0, x_max],
                [-1.0, 0.0, -x_min],
                [0.0, 1.0, y_max],
                [0.0, -1.0, -y_min],
            ]
        )
    if isinstance(region, BoxRegion):  # turned by its heading
        return _edge_rows(box_corners(region.model_dump()))
    if isinstance(region, PolygonRegion):
        return _edge_rows(region.vertices)
    if isinstance(region, HalfPlaneRegion):
        nx, ny = region.normal
        norm = math.hypot(nx, ny)
        return np.array([[nx / norm, ny / norm, region.offset / norm]])
    raise ValueError(f"unknown region type {region.type!r}")


def constraint_rows(region: RegionSpec, side: Side) -> tuple[IntArray, FloatArray]:
    """Constraint rows keeping the robot on ``side`` of ``region``: ``(kind (q,), params (q, w))``,
    ``w`` 6, or more for a polygon row.

    The outside of a box or polygon is not convex: no set of half-plane rows
    describes it, one polygon row (its signed distance) does.
    """
    if side not in ("inside", "outside"):
        raise ValueError(f"side must be 'inside' or 'outside', got {side!r}")
    if isinstance(region, EllipseRegion | CircleRegion):
        cx, cy, a, b, rotation = ellipse_geometry(region)
        sign = 1.0 if side == "inside" else -1.0
        kinds = np.array([ELLIPSE_ROW], dtype=np.int64)
        return kinds, np.array([[cx, cy, a, b, rotation, sign]])
    if side == "outside" and not isinstance(region, HalfPlaneRegion):
        return np.array([POLYGON_ROW], dtype=np.int64), polygon_row(region_vertices(region))
    rows = _half_plane_rows(region)
    if side == "outside":
        rows = -rows
    params = np.zeros((len(rows), 6))
    params[:, :3] = rows
    return np.full(len(rows), HALF_PLANE_ROW, dtype=np.int64), params


def polygon_row(vertices: ArrayLike) -> FloatArray:
    """The ``(1, w)`` parameters of a POLYGON_ROW (wmr_mission.kernels.convex):
    the vertex count, the disc about the vertices' mean that holds them, then
    per vertex, counter-clockwise, the vertex, its edge's unit outward normal
    and length."""
    points = np.asarray(vertices, dtype=np.float64)
    if _signed_area(points) < 0:
        points = points[::-1]
    edges = np.roll(points, -1, axis=0) - points
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    normals = np.column_stack([edges[:, 1], -edges[:, 0]]) / lengths[:, None]
    center = points.mean(axis=0)
    radius = float(np.max(np.hypot(points[:, 0] - center[0], points[:, 1] - center[1])))
    row = np.zeros((1, HEADER + PER_VERTEX * len(points)))
    row[0, :HEADER] = len(points), center[0], center[1], radius
    row[0, HEADER:] = np.column_stack([points, normals, lengths]).ravel()
    return row


def row_values(kind: IntArray, params: FloatArray, x: float, y: float) -> FloatArray:
    """Value ``c`` of each row at the point ``(x, y)``; ``c <= 0`` is satisfied."""
    values = np.empty(len(kind))
    for i, (row_kind, p) in enumerate(zip(kind, params, strict=True)):
        if row_kind == POLYGON_ROW:
            values[i] = -polygon_distance(p, x, y)[0]
        elif row_kind == ELLIPSE_ROW:
            u, w = _ellipse_frame(p, x, y)
            values[i] = p[5] * ((u / p[2]) ** 2 + (w / p[3]) ** 2 - 1.0)
        else:
            values[i] = p[0] * x + p[1] * y - p[2]
    return values


def row_gradients(kind: IntArray, params: FloatArray, x: float, y: float) -> FloatArray:
    """Gradient ``[dc/dx, dc/dy]`` of each row at ``(x, y)``, shape ``(q, 2)``."""
    gradients = np.empty((len(kind), 2))
    for i, (row_kind, p) in enumerate(zip(kind, params, strict=True)):
        if row_kind == POLYGON_ROW:
            _, gx, gy = polygon_distance(p, x, y)
            gradients[i] = -gx, -gy
        elif row_kind == ELLIPSE_ROW:
            u, w = _ellipse_frame(p, x, y)
            c, s = math.cos(p[4]), math.sin(p[4])
            du, dw = 2.0 * u / p[2] ** 2, 2.0 * w / p[3] ** 2
            # chain rule through [u, w] = Rot(-phi) [x - cx, y - cy]
            gradients[i, 0] = p[5] * (du * c - dw * s)
            gradients[i, 1] = p[5] * (du * s + dw * c)
        else:
            gradients[i] = p[0], p[1]
    return gradients


def _ellipse_frame(p: FloatArray, x: float, y: float) -> tuple[float, float]:
    c, s = math.cos(p[4]), math.sin(p[4])
    dx, dy = x - p[0], y - p[1]
    return c * dx + s * dy, -s * dx + c * dy


def region_value(region: RegionSpec, x: ArrayLike, y: ArrayLike) -> FloatArray:
    """Signed value: < 0 inside, > 0 outside, 0 on the boundary (vectorised).

    Ellipse and circle: ``(u/a)^2 + (w/b)^2 - 1`` as in eq. (33). Box, polygon and
    half-plane: the largest edge row, a signed distance outside.
    """
    px = np.asarray(x, dtype=np.float64)
    py = np.asarray(y, dtype=np.float64)
    if isinstance(region, EllipseRegion | CircleRegion):
        cx, cy, a, b, rotation = ellipse_geometry(region)
        c, s = math.cos(rotation), math.sin(rotation)
        dx, dy = px - cx, py - cy
        u, w = c * dx + s * dy, -s * dx + c * dy
        return np.asarray((u / a) ** 2 + (w / b) ** 2 - 1.0, dtype=np.float64)
    rows = _half_plane_rows(region)
    value = rows[0, 0] * px + rows[0, 1] * py - rows[0, 2]
    for nx, ny, offset in rows[1:]:
        value = np.maximum(value, nx * px + ny * py - offset)
    return np.asarray(value, dtype=np.float64)


def _signed_area(points: FloatArray) -> float:
    # Products written out, not np.dot: BLAS's kernels, chosen by CPU, round
    # differently, and the sign orients the rows the simulation uses.
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def is_convex(vertices: ArrayLike) -> bool:
    """Whether ``vertices`` (either orientation) form a convex polygon.

    At least three distinct points, a non-zero area, every turn in the same
    direction (straight-through vertices allowed) and one loop only: a star's
    turns all agree too, but it winds around twice.
    """
    points = np.asarray(vertices, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3:
        return False
    if not np.all(np.isfinite(points)):
        return False
    edges = np.roll(points, -1, axis=0) - points
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    scale = float(np.max(lengths))
    if scale == 0.0 or np.any(lengths <= 1e-12 * scale):
        return False
    following = np.roll(edges, -1, axis=0)
    turns = edges[:, 0] * following[:, 1] - edges[:, 1] * following[:, 0]
    tolerance = 1e-12 * scale * scale
    if np.all(turns >= -tolerance):
        direction = 1.0
    elif np.all(turns <= tolerance):
        direction = -1.0
    else:
        return False
    if abs(_signed_area(points)) <= tolerance:
        return False
    dots = np.einsum("ij,ij->i", edges, following)
    winding = float(np.sum(np.arctan2(turns, dots)))
    return abs(winding - direction * 2.0 * math.pi) < 1e-6


def region_vertices(region: RegionSpec) -> FloatArray:
    """``(n, 2)`` corners of a box or convex polygon region."""
    if isinstance(region, BoxRegion):
        return box_corners(region.model_dump())
    if isinstance(region, PolygonRegion):
        return np.asarray(region.vertices, dtype=np.float64)
    raise ValueError(f"a {region.type} region has no corners (expected box or polygon)")


def region_outline(
    region: RegionSpec,
    n: int = 400,
    extent: tuple[float, float, float, float] = (-10.0, 10.0, -10.0, 10.0),
) -> tuple[FloatArray, FloatArray]:
    """Boundary points ``(x, y)`` for plots, closed where the boundary is.

    A half-plane has an unbounded boundary: its line is clipped to ``extent``
    ``(x_min, x_max, y_min, y_max)``, and empty arrays come back when the line
    misses it.
    """
    if isinstance(region, EllipseRegion | CircleRegion):
        cx, cy, a, b, rotation = ellipse_geometry(region)
        angle = np.linspace(0.0, 2.0 * math.pi, n)
        u, w = a * np.cos(angle), b * np.sin(angle)
        c, s = math.cos(rotation), math.sin(rotation)
        return cx + c * u - s * w, cy + s * u + c * w
    if isinstance(region, BoxRegion):
        corners = box_corners(region.model_dump())
        closed = np.vstack([corners, corners[:1]])
        return closed[:, 0].copy(), closed[:, 1].copy()
    if isinstance(region, PolygonRegion):
        points = np.asarray(region.vertices, dtype=np.float64)
        closed = np.vstack([points, points[:1]])
        return closed[:, 0].copy(), closed[:, 1].copy()
    if isinstance(region, HalfPlaneRegion):
        return _clipped_line(_half_plane_rows(region)[0], extent)
    raise ValueError(f"unknown region type {region.type!r}")


def _clipped_line(
    row: FloatArray, extent: tuple[float, float, float, float]
) -> tuple[FloatArray, FloatArray]:
    """The line ``nx*x + ny*y = offset`` (unit normal) inside a box, Liang-Barsky style."""
    nx, ny, offset = row
    origin = np.array([nx * offset, ny * offset])
    direction = np.array([-ny, nx])
    x_min, x_max, y_min, y_max = extent
    low, high = -math.inf, math.inf
    for axis, lower, upper in ((0, x_min, x_max), (1, y_min, y_max)):
        if abs(direction[axis]) < 1e-15:
            if not lower <= origin[axis] <= upper:
                return np.empty(0), np.empty(0)
            continue
        s1 = (lower - origin[axis]) / direction[axis]
        s2 = (upper - origin[axis]) / direction[axis]
        low, high = max(low, min(s1, s2)), min(high, max(s1, s2))
    if low > high:
        return np.empty(0), np.empty(0)
    ends = origin + np.outer([low, high], direction)
    return ends[:, 0].copy(), ends[:, 1].copy()
