"""Signed distance to a convex polygon, per sample: the keep-out row of a box or
polygon zone.

The outside of a convex polygon is not convex, so no set of half-plane rows
keeps a robot out of it; its signed distance ``d`` is one row. Outside the
polygon ``d`` is the distance to the nearest point of its boundary, smooth
(its gradient, the unit vector from that point, is continuous), so a barrier
on ``margin - d <= 0`` works as it does on a half-plane's row. Inside, ``d``
is minus the distance to the nearest edge's line (a robot held outside never
needs more than its sign and a way out).

A polygon row's parameters (wmr_mission.geometry.regions.polygon_row builds
them) are ``n, cx, cy, radius``, the vertex count and the disc about the
vertices' mean that holds them, then per vertex, counter-clockwise, ``x, y,
nx, ny, length``: the vertex, the unit outward normal of the edge that starts
there and its length. Read, not recomputed, per sample: no square root per
edge.
"""

from __future__ import annotations

import math

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import kernel

# Columns of a polygon row before its vertices, and per vertex.
HEADER = 4
PER_VERTEX = 5


@kernel
def polygon_distance(p: FloatArray, x: float, y: float) -> tuple[float, float, float]:
    """Signed distance of (x, y) from the convex polygon of row ``p`` (> 0
    outside) and its gradient."""
    line = -math.inf  # the largest distance beyond an edge's line, and that edge's normal
    line_x = 0.0
    line_y = 0.0
    nearest = math.inf  # the least squared distance to an edge, and the offset from it
    off_x = 0.0
    off_y = 0.0
    for i in range(int(p[0])):
        k = HEADER + PER_VERTEX * i
        nx = p[k + 2]
        ny = p[k + 3]
        rx = x - p[k]
        ry = y - p[k + 1]
        beyond = rx * nx + ry * ny
        if beyond > line:
            line = beyond
            line_x = nx
            line_y = ny
        # along the edge: its unit direction is the normal turned by +90 degrees
        along = min(max(ry * nx - rx * ny, 0.0), p[k + 4])
        dx = rx + along * ny
        dy = ry - along * nx
        squared = dx * dx + dy * dy
        if squared < nearest:
            nearest = squared
            off_x = dx
            off_y = dy
    if line <= 0.0:
        return line, line_x, line_y
    distance = math.sqrt(nearest)
    return distance, off_x / distance, off_y / distance
