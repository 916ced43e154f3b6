"""Each position's place on the path in one compiled pass, where the run's
kernels are compiled: :meth:`wmr_mission.verdicts.tracking.Placement.on_path`'s
local search and the columns it gives (its numpy form, in blocks of
positions, serves plain Python), and the path's lengths before it.

The search is each position's own, so a position at a time gives the same
numbers: the same operations in the same order, and numpy's ``searchsorted``
(the first point beyond) and ``argmin`` (the first least, a NaN first) as
loops (``tests/test_verdict_placing.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import inlined, kernel

__all__ = ["path_lengths", "place_samples"]


@kernel
def path_lengths(
    position: tuple[FloatArray, FloatArray],
    reference: tuple[FloatArray, FloatArray],
    steps: tuple[FloatArray, FloatArray, FloatArray],
    arc: FloatArray,
) -> tuple[int, float, bool, bool]:
    """Each segment's step (x, y) and length into ``steps``, and the arc length
    at each point into ``arc``, as ``tracking.path_steps`` and numpy's
    ``cumsum`` (a sum in order) compute them, without their temporaries; the
    segments that move (of length > 0), the longest (numpy's ``max``: NaN if
    any is; -inf where there is none), and whether every position and every
    reference point is finite.
    The lengths first, side by side, then their sum: a sum kept in the array
    waits on its own store at each point."""
    px, py = position
    rx, ry = reference
    sx, sy, length = steps
    for i in range(rx.size - 1):
        x, y = rx[i + 1] - rx[i], ry[i + 1] - ry[i]
        sx[i], sy[i] = x, y
        length[i] = math.sqrt(x * x + y * y)
    total, longest, moving, unordered = 0.0, -math.inf, 0, False
    if arc.size:
        arc[0] = total
    for i in range(rx.size - 1):  # (no branch: the loop waits on each sum alone)
        step = length[i]
        total += step
        arc[i + 1] = total
        moving += step > 0.0
        unordered |= step != step
        longest = step if step > longest else longest
    unfinite = False
    for k in range(px.size):
        unfinite |= (not abs(px[k]) < math.inf) | (not abs(py[k]) < math.inf)
    unknown = False
    for k in range(rx.size):
        unknown |= (not abs(rx[k]) < math.inf) | (not abs(ry[k]) < math.inf)
    return moving, math.nan if unordered else longest, not unfinite, not unknown


@kernel
def place_samples(
    px: FloatArray,
    py: FloatArray,
    path: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    held: NDArray[np.intp],
    samples: tuple[int, int],
    search: int,
    steps: int,
    places: tuple[FloatArray, FloatArray],
    columns: tuple[int, int, float],
    found: tuple[FloatArray, FloatArray],
) -> tuple[int, float, float]:
    """Cross-track error and arc length of the place of positions ``samples``
    (begin .. end - 1, into ``places``): on the segment the guess from the
    sample's own reference point falls on if the foot of the perpendicular is
    on it; else the nearest of the ``search`` segments either side of the
    guess, and from there a Newton step along the path while it lies at their
    outer end, ``steps`` times at most. ``held``: the direction each segment
    takes (one that stands still, the one before); empty: its own.

    Then, unless ``found`` is empty, ``Placement.on_path``'s columns from the
    places found into ``found``: the cross-track error and the lag, the arc
    length from the place to the sample's own reference point, NaN before
    sample ``columns[0]``; how many are farther than ``columns[2]`` from their
    place, and the largest cross-track error and |lag| from sample
    ``columns[1]`` on, as numpy's ``max`` finds them (NaN if any is; -inf
    where there is none)."""
    arc, rx, ry, sx, sy, length = path
    begin, end = samples
    cross, place = places
    n = rx.size
    last = n - 2  # segment i runs from point i to point i + 1
    for k in range(begin, end):
        qx, qy = px[k], py[k]
        ux, uy = _direction(sx, sy, length, held, min(k, last))
        guess = arc[k] - ((rx[k] - qx) * ux + (ry[k] - qy) * uy)
        segment = max(min(_first_beyond(arc, guess, k) - 1, last), 0)
        ax, ay, ex, ey = rx[segment], ry[segment], sx[segment], sy[segment]
        step = length[segment]
        along = ((qx - ax) * ex + (qy - ay) * ey) / (step * step if step > 0.0 else 1.0)
        if along > 0.0 and along < 1.0:
            dx, dy = qx - ax - along * ex, qy - ay - along * ey
            cross[k] = math.sqrt(dx * dx + dy * dy)
            place[k] = arc[segment] + along * step
            continue
        for attempt in range(steps):
            centre = _first_beyond(arc, guess, k) - 1
            lowest = max(min(centre - search, last), 0)
            highest = max(min(centre + search, last), 0)
            best, chosen, fraction = math.inf, -1, 0.0
            for j in range(-search, search + 1):
                s = max(min(centre + j, last), 0)
                ax, ay, ex, ey = rx[s], ry[s], sx[s], sy[s]
                squared = length[s] * length[s]
                along = ((qx - ax) * ex + (qy - ay) * ey) / (squared if squared > 0.0 else 1.0)
                if along > 1.0:
                    along = 1.0
                if along < 0.0:
                    along = 0.0
                dx, dy = qx - ax - along * ex, qy - ay - along * ey
                distance = math.sqrt(dx * dx + dy * dy)
                # numpy's argmin: the first least, or the first NaN
                if chosen < 0 or (best == best and (distance < best or distance != distance)):
                    best, chosen, fraction = distance, s, along
            at = arc[chosen] + fraction * length[chosen]
            beyond = (chosen == lowest and fraction <= 0.0 and chosen > 0) or (
                chosen == highest and fraction >= 1.0 and chosen < last
            )
            if not beyond or attempt == steps - 1:
                cross[k], place[k] = best, at
                break
            # Beyond the segments searched: a Newton step along the path from there.
            ux, uy = _direction(sx, sy, length, held, chosen)
            foot_x = rx[chosen] + (at - arc[chosen]) * ux
            foot_y = ry[chosen] + (at - arc[chosen]) * uy
            guess = at + (qx - foot_x) * ux + (qy - foot_y) * uy
    if found[0].size == 0:
        return 0, math.nan, math.nan
    return _columns(arc, places, columns, found)


@inlined
def _direction(
    sx: FloatArray, sy: FloatArray, length: FloatArray, held: NDArray[np.intp], segment: int
) -> tuple[float, float]:
    along = segment if held.size == 0 else held[segment]
    return sx[along] / length[along], sy[along] / length[along]


@inlined
def _first_beyond(arc: FloatArray, value: float, near: int) -> int:
    """``np.searchsorted(arc, value, side="right")``: the first point whose arc
    length is above ``value`` (past the end for a NaN, as numpy). Looked for
    in steps doubling from point ``near`` (where the sample's own reference
    point is, and its place most often), then halved: the arc lengths never
    decrease, so the point is the one a search of the whole finds."""
    size = arc.size
    near = max(min(near, size - 1), 0)
    if value < arc[near]:  # at or before near: between a point at or below value and near
        high, step = near, 1
        low = near - step
        while low >= 0 and value < arc[low]:
            high = low
            step *= 2
            low = near - step
        low = max(low + 1, 0)
    else:  # beyond near: between near and a point above value
        low, step = near + 1, 1
        high = near + step
        while high < size and not value < arc[high]:
            low = high + 1
            step *= 2
            high = near + step
        high = min(high, size)
    while low < high:
        middle = (low + high) // 2
        if value < arc[middle]:
            high = middle
        else:
            low = middle + 1
    return low


@inlined
def _columns(
    arc: FloatArray,
    places: tuple[FloatArray, FloatArray],
    columns: tuple[int, int, float],
    found: tuple[FloatArray, FloatArray],
) -> tuple[int, float, float]:
    """:func:`place_samples`'s columns, as ``Placement.on_path`` makes them."""
    cross, place = places
    first, judged, near = columns
    out_cross, out_lag = found
    far = 0
    most_cross, most_lag = -math.inf, -math.inf
    for k in range(arc.size):
        if k < first:
            out_cross[k], out_lag[k] = math.nan, math.nan
        else:
            out_cross[k], out_lag[k] = cross[k], arc[k] - place[k]
            far += 1 if cross[k] > near else 0
        if k >= judged:
            most_cross = _nan_max(most_cross, out_cross[k])
            most_lag = _nan_max(most_lag, abs(out_lag[k]))
    return far, most_cross, most_lag


@inlined
def _nan_max(found: float, value: float) -> float:
    """numpy's ``max`` a value at a time: NaN once any is."""
    if found != found or value != value:
        return math.nan
    return max(found, value)
