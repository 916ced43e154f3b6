"""Signed distance to a convex polygon, per sample: the keep-out row of a box or
polygon zone.

The outside of a convex polygon is not convex, so no set of half-plane rows
keeps a robot out of it; its signed distance ``d`` is one row. Outside the
polygon ``d`` is the distance to the nearest point of its boundary, smooth
(its gradient, the unit vector from that point, is continuous), so a barrier
on ``margin - d <= 0`` works as it does on a half-plane's row. Inside, ``d``
is minus the distance to the nearest edge's line (a robot held outside never
needs more than its sign and a way out).

A polygon row's parameters are ``n, x0, y0, x1, y1, ...``: the vertex count
and the vertices counter-clockwise (wmr_mission.geometry.regions builds them).
"""

from __future__ import annotations

import math

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import kernel


@kernel
def polygon_distance(p: FloatArray, x: float, y: float) -> tuple[float, float, float]:
    """Signed distance of (x, y) from the convex polygon of row ``p`` (> 0
    outside) and its gradient."""
    n = int(p[0])
    line = -math.inf  # the largest distance beyond an edge's line, and that edge's normal
    line_x = 0.0
    line_y = 0.0
    nearest = math.inf  # the least squared distance to an edge, and the offset from it
    off_x = 0.0
    off_y = 0.0
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        ax = p[1 + 2 * i]
        ay = p[2 + 2 * i]
        ex = p[1 + 2 * j] - ax
        ey = p[2 + 2 * j] - ay
        length = math.sqrt(ex * ex + ey * ey)
        nx = ey / length  # outward: the polygon is counter-clockwise
        ny = -ex / length
        rx = x - ax
        ry = y - ay
        beyond = rx * nx + ry * ny
        if beyond > line:
            line = beyond
            line_x = nx
            line_y = ny
        along = (rx * ex + ry * ey) / (length * length)
        along = min(max(along, 0.0), 1.0)
        dx = rx - along * ex
        dy = ry - along * ey
        squared = dx * dx + dy * dy
        if squared < nearest:
            nearest = squared
            off_x = dx
            off_y = dy
    if line <= 0.0:
        return line, line_x, line_y
    distance = math.sqrt(nearest)
    return distance, off_x / distance, off_y / distance
