"""How many runs pass through each pixel of a campaign's trajectory figure.

Stroking thousands of paths one by one costs the figure about a millisecond
per run, most of it spent on the pixels of the four laps every case-2 run
makes; counting, per pixel, the runs whose path crosses it costs a few
nanoseconds per pixel crossed and draws every run as one image.
"""

from __future__ import annotations

import math

import numpy as np

from wmr_mission._jit import kernel

__all__ = ["runs_per_pixel"]


@kernel
def _count_runs(
    xs: np.ndarray,
    ys: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    last_run: np.ndarray,
    longest: int,
) -> None:
    """Walk each run's polyline (in pixel units) one pixel at a time and count
    the run once in every pixel it reaches. ``last_run[pixel]`` remembers the
    last run counted there, so that a run lapping a pixel counts once."""
    rows, columns = counts.shape
    for run in range(starts.size - 1):
        first, end = starts[run], starts[run + 1]
        for i in range(first, end):
            u0, v0 = xs[i], ys[i]
            if not (math.isfinite(u0) and math.isfinite(v0)):
                continue  # a diverged run's last samples: nothing to draw
            du, dv = 0.0, 0.0  # the last point, or one before a non-finite one
            if i + 1 < end and math.isfinite(xs[i + 1]) and math.isfinite(ys[i + 1]):
                du, dv = xs[i + 1] - u0, ys[i + 1] - v0
            steps = int(max(1.0, min(math.ceil(max(abs(du), abs(dv))), longest)))
            for k in range(steps):
                u = u0 + du * (k / steps)
                v = v0 + dv * (k / steps)
                if 0.0 <= u < columns and 0.0 <= v < rows:
                    row, column = int(v), int(u)
                    if last_run[row, column] != run:
                        last_run[row, column] = run
                        counts[row, column] += 1


def runs_per_pixel(
    paths: list[np.ndarray], view: tuple[float, float, float, float], shape: tuple[int, int]
) -> np.ndarray:
    """``counts[row, column]``: how many of ``paths`` (each ``(2, n)`` x, y)
    cross the pixel; row 0 is the bottom of ``view`` = (x0, x1, y0, y1)."""
    rows, columns = shape
    counts = np.zeros(shape, dtype=np.int32)
    if not paths or rows < 1 or columns < 1:
        return counts
    x0, x1, y0, y1 = view
    points = np.concatenate([np.asarray(p, dtype=np.float64) for p in paths], axis=1)
    xs = (points[0] - x0) * (columns / (x1 - x0))
    ys = (points[1] - y0) * (rows / (y1 - y0))
    starts = np.concatenate([[0], np.cumsum([p.shape[1] for p in paths])]).astype(np.int64)
    last_run = np.full(shape, -1, dtype=np.int64)
    # A segment longer than the canvas twice over mostly lies off it: walked
    # in that many steps at most, a runaway costs no more than a crossing.
    _count_runs(xs, ys, starts, counts, last_run, 2 * (rows + columns))
    return counts
