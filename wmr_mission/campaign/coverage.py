"""How many runs pass through each pixel of a campaign's trajectory figure.

Stroking thousands of paths one by one costs the figure about a millisecond
per run, most of it spent on the pixels of the four laps every case-2 run
makes; counting, per pixel, the runs whose path crosses it costs a few
nanoseconds per pixel crossed and draws every run as one image.
"""

from __future__ import annotations

import math

import numpy as np

from wmr_mission.kernels import jit
from wmr_mission.kernels.jit import kernel

__all__ = ["runs_per_pixel"]


@kernel
def _clip(p: float, q: float, t0: float, t1: float) -> tuple[float, float]:
    """One edge of Liang and Barsky's clipping: the part of [t0, t1] where p t <= q."""
    if p == 0.0:
        return (t0, t1) if q >= 0.0 else (1.0, 0.0)
    if p < 0.0:
        return max(t0, q / p), t1
    return t0, min(t1, q / p)


@kernel
def _count_runs(
    xs: np.ndarray, ys: np.ndarray, starts: np.ndarray, counts: np.ndarray, last_run: np.ndarray
) -> None:
    """Walk each run's polyline (in pixel units), clipped to the canvas, one
    pixel at a time, and count the run once in every pixel it reaches.
    ``last_run[pixel]`` remembers the last run counted there, so that a run
    lapping a pixel counts once."""
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
            # The part of the segment on the canvas: a runaway's exit still
            # shows, and the walk is never longer than the canvas is wide.
            t0, t1 = _clip(-du, u0, 0.0, 1.0)
            t0, t1 = _clip(du, columns - u0, t0, t1)
            t0, t1 = _clip(-dv, v0, t0, t1)
            t0, t1 = _clip(dv, rows - v0, t0, t1)
            if t0 > t1:
                continue
            steps = math.ceil(max(abs(du), abs(dv)) * (t1 - t0))
            for k in range(steps + 1):
                t = t0 + (t1 - t0) * (k / steps) if steps else t0
                u, v = u0 + du * t, v0 + dv * t
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
    jit.compiled(_count_runs)(xs, ys, starts, counts, last_run)
    return counts
