"""How far points are from the forbidden side of a phase's zones, in metres.

A zone is a region with the side the robot must keep to (``stay_inside`` or
``stay_outside``). :func:`depth` is its signed distance: > 0 on the
forbidden side (that deep into a keep-out zone, that far out of a keep-in
one), < 0 on the allowed side (minus the distance to the edge). The
constraint rows of the kernels (wmr_mission.regions) are not distances for
ellipses; the verdicts need metres.

``within`` bounds the work: points farther than that from the edge on the
allowed side only need to be known as such, and get ``-inf`` where finding
the exact distance would cost an iteration (ellipses).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray
from wmr_mission.geometry.regions import box_corners
from wmr_mission.kernels import jit
from wmr_mission.spec.numbers import MissionNumbers
from wmr_mission.verdicts.passes import ellipse_bounds, ellipse_deepest, ellipse_depth

# [m] depths are known to this: far below any tolerance, and what a robot held on
# a zone's edge by the corrective action rounds to.
RESOLUTION = 1e-6
# Newton steps at most for the distance to an ellipse (a handful are needed:
# each at least halves the distance to the pole the start is near).
_NEWTON_STEPS = 100
# Points at most whose distance to an ellipse is iterated as Python numbers.
_FEW = 8
# A point whose scaled radius is this far from 1 is off an ellipse's edge: its
# distance from it well above the rounding of the radius and of the distance.
_OFF_THE_EDGE = 1e-9


# Of points and an ellipse zone: whether each is beyond it, the largest upper
# bound of their depths, and the points whose depth may be the largest
# (wmr_mission.verdicts.passes.ellipse_bounds).
Bounds = tuple[NDArray[np.bool_], float, NDArray[np.intp]]


class Zone(NamedTuple):
    """A region of a phase and the side the robot keeps to."""

    name: str
    region: Mapping[str, Any]  # the region as written (model_dump): type and its numbers
    keep_inside: bool

    def depth(self, x: FloatArray, y: FloatArray, within: float = math.inf) -> FloatArray:
        """Signed distance [m] of each point from the zone's edge, > 0 on the
        forbidden side; ``-inf`` on the allowed side farther than ``within``
        where the exact distance is not computed."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if self.region["type"] == "ellipse" and jit.judging_compiled() and x.ndim == 1:
            # the same numbers in one compiled pass (verdicts/passes.py)
            return jit.compiled(ellipse_depth)(
                x, y, self._frame(), self._squares(), self.keep_inside, within, _NEWTON_STEPS
            )
        if self.region["type"] == "ellipse":  # the allowed side's far points skipped
            outside = _ellipse(self.region, x, y, self.keep_inside, within)
        else:
            outside = _outside_by(self.region, x, y)
        return outside if self.keep_inside else -outside

    def beyond(
        self, x: FloatArray, y: FloatArray, bounds: Bounds | None = None
    ) -> NDArray[np.bool_]:
        """Whether each point is on the forbidden side (its depth > 0);
        ``bounds``: the points' :meth:`bounds`, if at hand."""
        if self.region["type"] != "ellipse":
            return np.asarray(self.depth(x, y) > 0.0)
        if bounds is not None:
            return bounds[0]
        if jit.judging_compiled():  # the same in one compiled pass (verdicts/passes.py)
            return self._bounds(x, y)[0]
        radius = _scaled_radius(self.region, x, y)[0]
        return np.asarray(radius > 1.0 if self.keep_inside else radius < 1.0)

    def holds_beyond(self, x: float, y: float) -> bool:
        """Whether the point (x, y) is on the forbidden side (its depth > 0).
        An ellipse's point off its edge by more than a rounding is on the side
        its scaled radius says (as the depth's passes compute it), its distance
        not needed; other points' depth is found."""
        if self.region["type"] == "ellipse":
            cx, cy, c, s, a, b = self._frame()
            u, w = c * (x - cx) + s * (y - cy), -s * (x - cx) + c * (y - cy)
            radius = math.sqrt((u / a) * (u / a) + (w / b) * (w / b))
            if abs(radius - 1.0) >= _OFF_THE_EDGE:  # (NaN: its depth)
                return (radius < 1.0) != self.keep_inside
        return bool(self.depth(np.array([x]), np.array([y]))[0] > 0.0)

    def deepest(self, x: FloatArray, y: FloatArray) -> float:
        """The largest :meth:`depth` of the points (-inf for none), to
        RESOLUTION: for an ellipse, found exactly only for the points that its
        distance bounds (see :func:`_ellipse`) leave in the running, and not at
        all where the largest upper bound is within RESOLUTION of 0 (a robot
        held on the edge)."""
        return self.max_depth(x, y, RESOLUTION)

    def max_depth(
        self,
        x: FloatArray,
        y: FloatArray,
        resolution: float | None = None,
        bounds: Bounds | None = None,
    ) -> float:
        """The largest :meth:`depth` of the points (-inf for none), found
        exactly for an ellipse only for the points that its distance bounds
        (see :func:`_ellipse`) leave in the running; where the largest upper
        bound is within ``resolution`` of 0 (if given), that bound.
        ``bounds``: the points' :meth:`bounds`, if at hand."""
        if x.size == 0:
            return -math.inf
        if self.region["type"] != "ellipse":
            return float(np.max(self.depth(x, y)))
        if bounds is None:  # (compiled: the same numbers in one pass, verdicts/passes.py)
            bounds = self._bounds(x, y) if jit.judging_compiled() else self._numpy_bounds(x, y)
        _, highest, contenders = bounds
        if resolution is not None and abs(highest) <= resolution:
            return highest
        if jit.judging_compiled() and contenders.size:  # their depths and the largest, compiled
            deepest = jit.compiled(ellipse_deepest)
            frame, squares, inside = self._frame(), self._squares(), self.keep_inside
            found = float(deepest(x, y, contenders, frame, squares, inside, _NEWTON_STEPS))
            if found != 0.0:  # (which zero numpy's max keeps is its own)
                return found
        return float(np.max(self.depth(x[contenders], y[contenders])))

    def bounds(self, x: FloatArray, y: FloatArray) -> Bounds | None:
        """What :meth:`beyond` and :meth:`max_depth` of the same points read
        first, computed once for both (an ellipse's; else None: nothing to share)."""
        if self.region["type"] != "ellipse" or x.size == 0:
            return None
        return self._bounds(x, y) if jit.judging_compiled() else self._numpy_bounds(x, y)

    def _numpy_bounds(self, x: FloatArray, y: FloatArray) -> Bounds:
        """:meth:`_bounds` by numpy: the depth is at most ``most`` and at least
        ``least`` (see :func:`_ellipse`)."""
        radius, a, b = _scaled_radius(self.region, x, y)
        out = radius - 1.0 if self.keep_inside else 1.0 - radius
        most = out * np.where(out > 0, max(a, b), min(a, b))
        least = out * np.where(out > 0, min(a, b), max(a, b))
        beyond = radius > 1.0 if self.keep_inside else radius < 1.0
        return beyond, float(np.max(most)), np.flatnonzero(most >= np.max(least))

    def _bounds(self, x: FloatArray, y: FloatArray) -> Bounds:
        """An ellipse zone's :func:`wmr_mission.verdicts.passes.ellipse_bounds`."""
        beyond, highest, contenders = jit.compiled(ellipse_bounds)(
            x, y, self._frame(), self.keep_inside
        )
        return beyond, float(highest), contenders

    def _frame(self) -> tuple[float, float, float, float, float, float]:
        """An ellipse zone's centre, the cosine and sine of its rotation, and its
        semi-axes as written (as :func:`_ellipse_frame` reads them)."""
        cx, cy = self.region["center"]
        a, b = (float(v) for v in self.region["semi_axes"])
        rotation = float(self.region.get("rotation", 0.0))
        return (float(cx), float(cy), math.cos(rotation), math.sin(rotation), a, b)

    def _squares(self) -> tuple[float, float]:
        """The major and minor semi-axes squared, as :func:`_to_ellipse` squares them."""
        a, b = sorted((float(v) for v in self.region["semi_axes"]), reverse=True)
        return a**2, b**2

    def __str__(self) -> str:
        return f"{'stay_inside' if self.keep_inside else 'stay_outside'} {self.name}"


def zones_of(constraints: tuple[tuple[str, str], ...], regions: Mapping[str, Any]) -> list[Zone]:
    """A phase's zones from its constraints ((region, "inside" | "outside"), as
    :class:`wmr_mission.record.PhaseRecord` has them)."""
    return [Zone(name, regions[name], side == "inside") for name, side in constraints]


def intrusion_max(
    x: FloatArray,
    y: FloatArray,
    zones: Sequence[Zone],
    numbers: MissionNumbers,
    bounds: Sequence[Bounds | None] | None = None,
) -> float | None:
    """[m] the deepest a phase's positions go beyond the edge of any of its zones
    (0 when they never do; None without zones or after a divergence). A phase
    that starts beyond a zone is given the time the limits need to leave it by
    the shortest way (:meth:`MissionNumbers.recovery_time`); if it takes longer,
    its start counts too. ``bounds``: each zone's :meth:`Zone.bounds` of the
    positions, if at hand."""
    if not zones:
        return None
    deepest = 0.0
    for i, zone in enumerate(zones):
        beyond = zone.beyond(x, y, None if bounds is None else bounds[i])
        if not beyond.any():
            continue
        first = 0
        if beyond[0]:
            left = int(beyond.argmin()) or x.size  # the first sample not beyond (0: none)
            if _left_in_time(zone, x, y, left * numbers.dt, numbers):
                first = left
        if first == 0 or beyond[first:].any():
            counted = np.flatnonzero(beyond[first:]) + first
            deepest = max(deepest, zone.deepest(x[counted], y[counted]))
    return deepest if math.isfinite(deepest) else None


def _left_in_time(
    zone: Zone, x: FloatArray, y: FloatArray, taken: float, numbers: MissionNumbers
) -> bool:
    """Whether a phase that starts beyond ``zone`` left it within the time the
    limits need to leave it from its first position (``taken`` [s]: the time it
    took). The time needed grows with the depth, which is at least 0 beyond
    the zone: where no depth is needed to allow it, the depth is not found."""
    finite = math.isfinite(float(x[0])) and math.isfinite(float(y[0]))  # a depth at least 0
    if finite and taken <= numbers.recovery_time(0.0, 0.0):
        return True
    return taken <= numbers.recovery_time(zone.deepest(x[:1], y[:1]), 0.0)


def reach_across(zone: Zone, x: FloatArray, y: FloatArray) -> FloatArray:
    """[m] how far a keep-out box or polygon reaches into a path at its points
    (x, y): at a point inside it, the shorter way out across the path (square
    to the path's direction there); elsewhere, and for other zones, the
    point's :meth:`Zone.depth`. Through a circle's centre the two agree (its
    radius); through a box's middle the way out across is half its width, not
    the distance to its nearest edge."""
    depth = zone.depth(x, y)
    if zone.keep_inside or zone.region["type"] not in ("box", "polygon") or x.size < 2:
        return depth
    dx, dy = np.gradient(x), np.gradient(y)
    length = np.hypot(dx, dy)
    moving = length > 0.0
    nx = np.divide(-dy, length, out=np.zeros_like(dx), where=moving)
    ny = np.divide(dx, length, out=np.zeros_like(dx), where=moving)
    corners = _corners(zone.region)
    across = (corners[:, 0] - x[:, None]) * nx[:, None] + (corners[:, 1] - y[:, None]) * ny[:, None]
    way_out = np.minimum(across.max(axis=1), (-across).max(axis=1))
    return np.where((depth > 0.0) & moving, way_out, depth)


def _corners(region: Mapping[str, Any]) -> FloatArray:
    if region["type"] == "box":
        return box_corners(region)
    return np.asarray(region["vertices"], dtype=float)


def _outside_by(region: Mapping[str, Any], x: FloatArray, y: FloatArray) -> Any:
    """Signed distance from the region: > 0 outside, < 0 inside."""
    kind = region["type"]
    if kind == "circle":
        cx, cy = region["center"]
        return np.hypot(x - cx, y - cy) - float(region["radius"])
    if kind == "half-plane":
        nx, ny = region["normal"]
        norm = math.hypot(nx, ny)
        return (nx * x + ny * y - float(region["offset"])) / norm
    if kind == "box" and region.get("min") is None:  # turned by its heading
        return _polygon_outside_by(box_corners(region), x, y)
    if kind == "box":
        (x0, y0), (x1, y1) = region["min"], region["max"]
        qx = np.abs(x - (x0 + x1) / 2) - (x1 - x0) / 2
        qy = np.abs(y - (y0 + y1) / 2) - (y1 - y0) / 2
        return np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0)) + np.minimum(
            np.maximum(qx, qy), 0.0
        )
    if kind == "polygon":
        return _polygon_outside_by(np.asarray(region["vertices"], float), x, y)
    raise ValueError(f"unknown region type {kind!r}")


def _polygon_outside_by(vertices: FloatArray, x: FloatArray, y: FloatArray) -> Any:
    """A convex polygon (validate refuses others): inside, the distance to the
    nearest edge's line; outside, to the nearest edge."""
    ax, ay = vertices[:, 0], vertices[:, 1]
    bx, by = np.roll(ax, -1), np.roll(ay, -1)
    ex, ey = bx - ax, by - ay
    length = np.hypot(ex, ey)
    # outward normals: the polygon's orientation decides which side is out
    area = float(np.sum(ax * by - bx * ay))
    sign = 1.0 if area > 0 else -1.0
    nx, ny = sign * ey / length, -sign * ex / length
    rows = (x[:, None] - ax) * nx + (y[:, None] - ay) * ny  # signed distance to each edge's line
    outside = rows.max(axis=1)
    along = np.clip(((x[:, None] - ax) * ex + (y[:, None] - ay) * ey) / length**2, 0.0, 1.0)
    to_edges = np.hypot(x[:, None] - ax - along * ex, y[:, None] - ay - along * ey).min(axis=1)
    return np.where(outside > 0, to_edges, outside)


def _ellipse(
    region: Mapping[str, Any], x: FloatArray, y: FloatArray, inside_allowed: bool, within: float
) -> FloatArray:
    """Signed distance from an ellipse region, > 0 outside; ``+-inf`` for points
    on the allowed side (inside when ``inside_allowed``) surely farther than
    ``within`` from the edge.

    With ``r`` a point's scaled radius, ``((u/a)^2 + (w/b)^2)^0.5``, its distance
    from the edge is at least ``|1 - r| min(a, b)``: the ellipse ``E`` holds the
    disk ``B`` of radius ``min(a, b)``, and ``r E + |1 - r| B`` lies within ``E``
    (r < 1) or within ``r E`` (r > 1). That bound picks the points whose
    distance is found (the foot of the ellipse's normal through them)."""
    u, w, a, b = _ellipse_frame(region, x, y)
    radius = np.sqrt((u / a) ** 2 + (w / b) ** 2)
    if a == b:
        return np.asarray((radius - 1.0) * a, dtype=float)
    inside = radius < 1.0
    found = np.where(inside, -np.inf, np.inf)
    wanted = (np.abs(1.0 - radius) * b <= within) | (inside != inside_allowed)
    distance = _to_ellipse(np.abs(u[wanted]), np.abs(w[wanted]), a, b)
    found[wanted] = np.where(inside[wanted], -distance, distance)
    return found


def _ellipse_frame(
    region: Mapping[str, Any], x: FloatArray, y: FloatArray
) -> tuple[FloatArray, FloatArray, float, float]:
    """Points in the ellipse's own axes, the major axis first, and its semi-axes."""
    cx, cy = region["center"]
    a, b = (float(v) for v in region["semi_axes"])
    rotation = float(region.get("rotation", 0.0))
    c, s = math.cos(rotation), math.sin(rotation)
    u, w = c * (x - cx) + s * (y - cy), -s * (x - cx) + c * (y - cy)
    if a < b:
        return w, u, b, a
    return u, w, a, b


def _scaled_radius(
    region: Mapping[str, Any], x: FloatArray, y: FloatArray
) -> tuple[FloatArray, float, float]:
    u, w, a, b = _ellipse_frame(region, x, y)
    return np.sqrt((u / a) ** 2 + (w / b) ** 2), a, b


def _to_ellipse(u: FloatArray, w: FloatArray, a: float, b: float) -> FloatArray:
    """Distance of points (u, w) >= 0 from the ellipse (u/a)^2 + (w/b)^2 = 1, a > b.

    Off the axes the nearest point is ``(a^2 u / (t + a^2), b^2 w / (t + b^2))``
    for the root ``t > -b^2`` of ``(a u / (t + a^2))^2 + (b w / (t + b^2))^2 = 1``,
    decreasing and convex in ``t``, at least 1 at ``t = b w - b^2``. On the
    minor axis it is the axis' end; on the major axis, the end, or nearer the
    centre than ``(a^2 - b^2) / a``, the point where the ellipse's normal passes
    through it."""
    # A point nearer the major axis than b^2's rounding (b w + b^2 == b^2) is on
    # it: Newton's start t = b w - b^2 would make t + b^2 zero, and its root NaN.
    w = np.where((b * w - b**2) + b**2 == 0.0, 0.0, w)
    distance = np.empty(u.shape)
    off_axes = (u > 0.0) & (w > 0.0)
    if off_axes.any():
        pu, pw = u[off_axes], w[off_axes]
        t = _roots(pu, pw, a, b)
        # t + a^2 >= a^2 - b^2 > 0; t + b^2 may vanish near the major axis, so
        # the foot's second coordinate comes from the ellipse's equation.
        foot = a**2 * pu / (t + a**2)
        height = b * np.sqrt(np.clip(1.0 - (foot / a) ** 2, 0.0, 1.0))
        distance[off_axes] = np.hypot(foot - pu, height - pw)
    minor = (u == 0.0) & (w > 0.0)
    distance[minor] = np.abs(w[minor] - b)
    major = w == 0.0
    if major.any():
        pu = u[major]
        inner = pu * a < a**2 - b**2
        foot = np.where(inner, a**2 * pu / np.where(inner, a**2 - b**2, 1.0), a)
        height = b * np.sqrt(np.clip(1.0 - (foot / a) ** 2, 0.0, 1.0))
        distance[major] = np.where(inner, np.hypot(foot - pu, height), np.abs(pu - a))
    return distance


def _roots(pu: FloatArray, pw: FloatArray, a: float, b: float) -> FloatArray:
    """The root ``t`` of :func:`_to_ellipse` of each point off the axes."""
    au, bw = a * pu, b * pw
    if pu.size <= _FEW:
        try:
            return np.array(_few_roots(au.tolist(), bw.tolist(), pu.tolist(), pw.tolist(), a, b))
        except ZeroDivisionError:  # where numpy gives inf and nan
            pass
    # Newton's method from the left of the root: the function is convex and
    # decreasing, so each step lands nearer the root and never beyond it.
    # Outside the ellipse t = 0 is left of it (the function is r^2 > 1 there).
    t = np.where((pu / a) ** 2 + (pw / b) ** 2 > 1.0, 0.0, bw - b**2)
    for _ in range(_NEWTON_STEPS):
        first, second = au / (t + a**2), bw / (t + b**2)
        slope = -2.0 * (first**2 / (t + a**2) + second**2 / (t + b**2))
        step = (first**2 + second**2 - 1.0) / slope
        t = t - step
        if not np.any(np.abs(step) > 1e-15 * (np.abs(t) + a**2)):
            break
    return t


def _few_roots(
    au: list[float], bw: list[float], pu: list[float], pw: list[float], a: float, b: float
) -> list[float]:
    """:func:`_roots` of a few points as Python numbers (numpy's calls cost more
    than its sums on so few): the same operations in the same order, the points
    stepped together until the last has converged, as the arrays are, so the
    same bits. Raises ZeroDivisionError where numpy would give inf or nan."""
    a2, b2 = a**2, b**2
    t = []
    for u, w, bwk in zip(pu, pw, bw, strict=True):
        su, sw = u / a, w / b
        t.append(0.0 if su * su + sw * sw > 1.0 else bwk - b2)
    for _ in range(_NEWTON_STEPS):
        moving = False
        for k, tk in enumerate(t):
            first, second = au[k] / (tk + a2), bw[k] / (tk + b2)
            slope = -2.0 * (first * first / (tk + a2) + second * second / (tk + b2))
            step = (first * first + second * second - 1.0) / slope
            t[k] = tk - step
            moving = moving or abs(step) > 1e-15 * (abs(t[k]) + a2)
        if not moving:
            break
    return t
