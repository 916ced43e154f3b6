"""Exact geometry for checking runs: distance from a point to an ellipse."""

from __future__ import annotations

import numpy as np


def distance_to_ellipse(x: np.ndarray, y: np.ndarray, a: float = 5.5, b: float = 3.0) -> np.ndarray:
    """Euclidean distance from each point to the ellipse (x/a)^2 + (y/b)^2 = 1.

    The nearest point's parameter s is found on a coarse grid, then refined by
    Newton steps on d/ds |p(s) - q|^2 / 2 = 0; accurate to rounding (a grid
    alone is only as fine as its spacing, about 1e-3 m here).
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    grid = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    coarse = np.hypot(
        a * np.cos(grid)[None, :] - x[:, None], b * np.sin(grid)[None, :] - y[:, None]
    )
    s = grid[np.argmin(coarse, axis=1)]
    for _ in range(30):
        c, n = np.cos(s), np.sin(s)
        dx, dy = a * c - x, b * n - y
        g = -a * n * dx + b * c * dy
        h = a * a * n * n - a * c * dx + b * b * c * c - b * n * dy
        s = s - g / np.where(np.abs(h) > 1e-300, h, 1e-300)
    return np.hypot(a * np.cos(s) - x, b * np.sin(s) - y)


def outside_hull(points: np.ndarray, x: np.ndarray, y: np.ndarray) -> float:
    """Largest distance [m] of the points (x, y) outside the convex hull of
    ``points`` (0 when all are inside): the largest outward edge distance, an
    exact distance for points beyond one edge and a lower bound near a corner."""
    from scipy.spatial import ConvexHull

    equations = ConvexHull(np.asarray(points, dtype=float)).equations  # unit outward normals
    values = np.column_stack([x, y]) @ equations[:, :2].T + equations[:, 2]
    return max(0.0, float(values.max()))
