"""The distance to the path of each position in one compiled pass, where the
run's kernels are compiled (:func:`wmr_mission.verdicts.metrics.distance_to_path`
says which segments are tried; its numpy form serves plain Python).

Each position's distance is the least of its segments' distances, computed
with numpy's arithmetic operation by operation, and min rounds nothing, so
the bits are those of the numpy form (``tests/test_verdict_path_distance.py``).
Five shortcuts change no bit:

* the path's nearest points are found among the points listed for the
  position's cell of a second, finer grid: every point that may be among the
  k nearest of a position anywhere in the cell, listed when a position first
  falls in it (:func:`_list_of_cell` says why no other can be); the k nearest
  are ranked as the numpy form ranks them, by their squared distances as
  numpy computes them, ties to the earlier point;
* where a cell has no list (far from the path: its lists would be long),
  they are found on a grid of cells searched ring by ring round the
  position's cell, until every point outside the rings is farther than the
  k-th nearest found (a position far from the path, not settled within a few
  rings, among every point);
* a segment whose nearest point is one of its ends takes no division: its
  quotient would be clamped to 0 or 1 whatever its rounding;
* a cell's list is kept nearest its centre first, so that a position's k
  nearest come early and the others are turned away at once (the k kept do
  not depend on the order offered); a hypot of the same offsets as the one
  before (a segment tried twice, the two at a corner) is not taken again;
* ``hypot`` (the C library's, as numpy's) is taken only of the segments whose
  squared distance is within a relative 1e-6 of the least: the others'
  distances are farther by far more than their roundings.

One pass, no temporaries per position: the 1-hour mission's 360 001 positions
were 24 segments and 6 candidate points each, as blocks of arrays. The lists
offer it 8 points a position (1 300 cells listed), the rings offered 18.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import jit
from wmr_mission.kernels.jit import inlined, kernel

__all__ = ["compiled_distances", "first_in_cells"]

# A squared distance this much (relative) above the least cannot round to a
# distance as small: each is a few roundings (about 1e-16 each) from its exact value.
_SQUARED_MARGIN = 1e-6
# Squared distances below this may be subnormal: their roundings are not relative.
_TINY = 1e-280
# The grid's cells per point of the path at most (its side grows to keep to it).
_CELLS_PER_POINT = 4
# A position this many cells from the grid's origin is measured against every
# point, and so is one whose nearest points are not settled within _RINGS rings
# (a position far from the path: a sweep of the whole grid would cost more).
_FAR = 1e12
_RINGS = 8
# The thinning's cells per point of the path at most: beyond, numpy's sort thins it.
_THINNING_CELLS_PER_POINT = 2
# The nearest points' lists: cells per thinned point, and in all, about (their
# side grows to keep to both; as many list entries as this at most).
_LIST_CELLS_PER_POINT = 64
_LIST_CELLS_MOST = 1 << 19
# A cell whose centre's k-th nearest point is farther than this many cells
# has no list: its positions, far from the path, search the rings.
_LIST_REACH = 4.0
# Lists where the positions outnumber the thinned points this many times:
# a list costs a few ring searches to make, paid back by the positions that
# fall in its cell (a long run's, lap after lap); a short run's judge would
# pay more for them than they save.
_LIST_POSITIONS_PER_POINT = 16


def compiled_distances(
    px: FloatArray,
    py: FloatArray,
    qx: FloatArray,
    qy: FloatArray,
    own: NDArray[np.intp],
    points: NDArray[np.intp],
    cell: float,
    window: int,
    k: int,
) -> FloatArray:
    """The distance of each position (qx, qy) from the polyline (px, py): the
    least over the segments within ``window`` points of its own reference
    point ``own`` and those next to the ``k`` nearest of the path's thinned
    ``points``; compiled (numba loaded)."""
    tx, ty = px[points], py[points]
    x0, y0 = float(tx.min()), float(ty.min())
    width, height = float(tx.max()) - x0, float(ty.max()) - y0
    budget = _CELLS_PER_POINT * tx.size + 64
    size = max(2.0 * cell, math.sqrt(width * height / budget), (width + height) / budget)
    if not size > 0.0 or not math.isfinite(size):
        size = 1.0
    columns = int(width // size) + 1
    rows = int(height // size) + 1
    column = np.floor((tx - x0) / size).astype(np.int64)
    row = np.floor((ty - y0) / size).astype(np.int64)
    keys = np.minimum(column, columns - 1) * rows + np.minimum(row, rows - 1)
    order = np.argsort(keys, kind="stable")
    starts = np.searchsorted(keys[order], np.arange(columns * rows + 1)).astype(np.int64)
    out = np.empty(qx.size)
    # The kernel's scratch, made here: an array made in compiled code makes
    # loading the kernel from the cache import numba's array module (0.02 s
    # of `run`'s start, docs/performance.md, Start-up).
    k = min(k, tx.size)
    nearest = np.empty((2, k))  # the nearest points found: squared distances, indices
    tried = 2 * window + 2 * k  # the segments tried, at most
    segments, dxs, dys = np.empty(tried, dtype=np.int64), np.empty(tried), np.empty(tried)
    # The lists' grid, on the same origin; a cell's list made when a position
    # first falls in it (_list_of_cell): its entry in `table` (-1: not made
    # yet, -2: none), then in `pool` its length and its points.
    most = min(_LIST_CELLS_PER_POINT * tx.size + 4096, _LIST_CELLS_MOST)
    side = max(cell, math.sqrt(width * height / most), (width + height) / most)
    if not side > 0.0 or not math.isfinite(side):
        side = size
    list_columns, list_rows = int(width // side) + 1, int(height // side) + 1  # 2 most + 1 at most
    if qx.size < _LIST_POSITIONS_PER_POINT * tx.size:
        list_columns = list_rows = most = 0  # no lists: the rings everywhere
    # How far a position's or a centre's coordinates may be from where the
    # grid's arithmetic puts them, at most (a few roundings of the largest).
    slack = 1e-12 * (abs(x0) + abs(y0) + (list_columns + list_rows + 1) * side)
    table = np.full(list_columns * list_rows, -1, dtype=np.int32)
    pool, used = np.empty(most, dtype=np.int32), np.zeros(1, dtype=np.int64)
    # A square beyond the largest float is inf, as in machine code; as plain
    # Python the kernel computes with numpy's scalars, which would warn of it.
    with np.errstate(over="ignore", invalid="ignore"):
        # Without reference counting: loading it needs none of numba's runtime.
        jit.compiled(_distances, counted=False)(
            px, py, qx, qy, own.astype(np.int64, copy=False), tx, ty, points.astype(np.int64),
            order.astype(np.int64), starts, x0, y0, size, columns, rows, window, nearest,
            segments, dxs, dys, out, (side, slack, _LIST_REACH * side), (list_columns, list_rows),
            table, pool, used,
        )  # fmt: skip
    return out


def first_in_cells(px: FloatArray, py: FloatArray, cell: float) -> NDArray[np.intp] | None:
    """The first point of the path (px, py) in each cell of side ``cell`` it
    passes, ordered by the cell's column, then its row: what
    ``metrics.distance_to_path``'s stable sort by cell gives, in one compiled
    pass over a table of the cells; None where the path's extent has more
    cells than _THINNING_CELLS_PER_POINT per point (compiled: numba loaded)."""
    most = _THINNING_CELLS_PER_POINT * px.size + 64
    first: NDArray[np.intp] = jit.compiled(_first_in_cells)(px, py, cell, float(most))
    return first if first.size else None


@kernel
def _first_in_cells(px: FloatArray, py: FloatArray, cell: float, most: float) -> NDArray[np.intp]:
    """:func:`first_in_cells`, an empty array where the cells are too many."""
    c0, r0, c1, r1 = math.inf, math.inf, -math.inf, -math.inf
    for i in range(px.size):  # np.floor(px / cell): the same operations
        c, r = np.floor(px[i] / cell), np.floor(py[i] / cell)
        c0, r0, c1, r1 = min(c0, c), min(r0, r), max(c1, c), max(r1, r)
    rows = r1 - r0 + 1.0
    if not (c1 - c0 + 1.0) * rows <= most:  # also where a cell's number is not finite
        return np.empty(0, dtype=np.intp)
    table = np.full(int((c1 - c0 + 1.0) * rows), -1, dtype=np.intp)
    for i in range(px.size):
        key = int(np.floor(px[i] / cell) - c0) * int(rows) + int(np.floor(py[i] / cell) - r0)
        if table[key] < 0:
            table[key] = i
    found = 0
    for key in range(table.size):
        if table[key] >= 0:
            table[found] = table[key]
            found += 1
    return table[:found].copy()


@inlined
def _segment(px: FloatArray, py: FloatArray, i: int, qx: float, qy: float) -> tuple[float, float]:
    """The offsets (dx, dy) of (qx, qy) from segment i's nearest point, as
    ``metrics._distance_to_segments`` computes them."""
    ax, ay = px[i], py[i]
    sx, sy = px[i + 1] - ax, py[i + 1] - ay
    length2 = sx * sx + sy * sy
    dot = (qx - ax) * sx + (qy - ay) * sy
    # Beyond an end the quotient is clamped to 0 or 1 whatever its rounding:
    # no division, for most of a sample's segments (not where the step
    # overflowed: 0 times an infinite step is NaN, and so may the quotient be).
    if length2 < math.inf:
        if dot <= 0.0:
            return qx - ax, qy - ay
        if dot >= length2:
            return qx - ax - sx, qy - ay - sy
    along = dot / (length2 if length2 > 0.0 else 1.0)
    if along < 0.0:
        along = 0.0
    elif along > 1.0:
        along = 1.0
    return qx - ax - along * sx, qy - ay - along * sy


@inlined
def _ring_search(
    x: float,
    y: float,
    tx: FloatArray,
    ty: FloatArray,
    order: NDArray[np.int64],
    starts: NDArray[np.int64],
    x0: float,
    y0: float,
    size: float,
    columns: int,
    rows: int,
    nearest: FloatArray,
) -> int:
    """The k nearest thinned points of (x, y) into ``nearest`` (squared
    distance, index; ascending), the grid's cells searched ring by ring round
    its own; how many there are (k, or fewer where the path has fewer)."""
    k = nearest.shape[1]
    found = 0
    searched = False  # the k nearest are known
    u, v = (x - x0) / size, (y - y0) / size
    if abs(u) < _FAR and abs(v) < _FAR:
        c0, r0 = math.floor(u), math.floor(v)
        ring = first = max(0, -c0, c0 - (columns - 1), -r0, r0 - (rows - 1))
        while ring - first <= _RINGS:
            for c in range(max(c0 - ring, 0), min(c0 + ring, columns - 1) + 1):
                if c == c0 - ring or c == c0 + ring:  # a side of the ring: every row
                    for r in range(max(r0 - ring, 0), min(r0 + ring, rows - 1) + 1):
                        key = c * rows + r
                        found = _visit(tx, ty, order, starts, key, x, y, nearest, found)
                else:  # inside it: its top and bottom rows
                    if r0 - ring >= 0:
                        key = c * rows + r0 - ring
                        found = _visit(tx, ty, order, starts, key, x, y, nearest, found)
                    if ring > 0 and r0 + ring <= rows - 1:
                        key = c * rows + r0 + ring
                        found = _visit(tx, ty, order, starts, key, x, y, nearest, found)
            whole = c0 - ring <= 0 and c0 + ring >= columns - 1
            searched = whole and r0 - ring <= 0 and r0 + ring >= rows - 1
            reach = min(u - (c0 - ring), c0 + ring + 1 - u, v - (r0 - ring), r0 + ring + 1 - v)
            reach *= size
            kth = nearest[0, k - 1]
            if found == k and kth * (1.0 + _SQUARED_MARGIN) + _TINY < reach * reach:
                searched = True
            if searched:
                break
            ring += 1
    if not searched:  # far from the path, or the rings ran out: every point
        found = 0
        for j in range(tx.size):
            ex, ey = tx[j] - x, ty[j] - y
            found = _keep(nearest, found, ex * ex + ey * ey, j)
    return found


@kernel
def _list_of_cell(
    cell: int,
    column: int,
    row: int,
    tx: FloatArray,
    ty: FloatArray,
    order: NDArray[np.int64],
    starts: NDArray[np.int64],
    x0: float,
    y0: float,
    size: float,
    columns: int,
    rows: int,
    nearest: FloatArray,
    side: float,
    slack: float,
    farthest: float,
    table: NDArray[np.int32],
    pool: NDArray[np.int32],
    used: NDArray[np.int64],
) -> None:
    """The list of the lists' cell ``cell`` (at ``column``, ``row``, of side
    ``side``): every thinned point that may be among the k nearest of a
    position in it. A position q within h (half the cell's diagonal, and the
    slack) of its centre c has k points within d_k(c) + h, so its k nearest
    are all within d_k(c) + 2 h of c; the list is those, with a relative
    margin of 1e-9 for the roundings of the squared distances (about 1e-16
    each). None (-2 in ``table``) where d_k(c) is above ``farthest``
    (_LIST_REACH cells), or the pool is full."""
    k = nearest.shape[1]
    cx, cy = x0 + (column + 0.5) * side, y0 + (row + 0.5) * side
    _ring_search(cx, cy, tx, ty, order, starts, x0, y0, size, columns, rows, nearest)
    kth = math.sqrt(nearest[0, k - 1])
    table[cell] = -2
    if not kth <= farthest:
        return
    reach = (kth * (1.0 + 1e-9) + math.sqrt(2.0) * side + 2.0 * slack) * (1.0 + 1e-9)
    reach2 = reach * reach
    # the grid's cells round the disc, one more each way for the roundings
    c_from = max(math.floor((cx - reach - x0) / size) - 1, 0)
    c_to = min(math.floor((cx + reach - x0) / size) + 1, columns - 1)
    r_from = max(math.floor((cy - reach - y0) / size) - 1, 0)
    r_to = min(math.floor((cy + reach - y0) / size) + 1, rows - 1)
    first = used[0]
    n = 0
    for c in range(c_from, c_to + 1):
        for r in range(r_from, r_to + 1):
            for slot in range(starts[c * rows + r], starts[c * rows + r + 1]):
                j = order[slot]
                ex, ey = tx[j] - cx, ty[j] - cy
                if ex * ex + ey * ey <= reach2:
                    if first + 1 + n >= pool.size:
                        return  # the pool is full: the rings
                    pool[first + 1 + n] = j
                    n += 1
    # Nearest the centre first: a position's k nearest then come early, and the
    # others are turned away by one comparison each (_keep keeps the same k
    # whatever the order: it orders them by squared distance, then index).
    for a in range(first + 2, first + 1 + n):
        j = pool[a]
        ex, ey = tx[j] - cx, ty[j] - cy
        squared = ex * ex + ey * ey
        b = a
        while b > first + 1:
            before = pool[b - 1]
            fx, fy = tx[before] - cx, ty[before] - cy
            if fx * fx + fy * fy <= squared:
                break
            pool[b] = before
            b -= 1
        pool[b] = j
    pool[first] = n
    used[0] = first + 1 + n
    table[cell] = first


@kernel
def _distances(
    px: FloatArray,
    py: FloatArray,
    qx: FloatArray,
    qy: FloatArray,
    own: NDArray[np.int64],
    tx: FloatArray,
    ty: FloatArray,
    points: NDArray[np.int64],
    order: NDArray[np.int64],
    starts: NDArray[np.int64],
    x0: float,
    y0: float,
    size: float,
    columns: int,
    rows: int,
    window: int,
    nearest: FloatArray,
    segments: NDArray[np.int64],
    dxs: FloatArray,
    dys: FloatArray,
    out: FloatArray,
    lists_grid: tuple[float, float, float],
    lists_shape: tuple[int, int],
    table: NDArray[np.int32],
    pool: NDArray[np.int32],
    used: NDArray[np.int64],
) -> None:
    last = px.size - 2  # segment i runs from point i to point i + 1
    side, slack, farthest = lists_grid
    list_columns, list_rows = lists_shape
    for q in range(qx.size):
        x, y = qx[q], qy[q]
        # The k nearest points: (squared distance, index) ascending; from the
        # list of the position's cell where it has one, else the rings.
        found = -1
        u, v = (x - x0) / side, (y - y0) / side
        if 0.0 <= u < list_columns and 0.0 <= v < list_rows:
            column, row = int(u), int(v)
            cell = column * list_rows + row
            if table[cell] == -1:
                _list_of_cell(
                    cell, column, row, tx, ty, order, starts, x0, y0, size, columns, rows,
                    nearest, side, slack, farthest, table, pool, used,
                )  # fmt: skip
            first = table[cell]
            if first >= 0:
                found = 0
                for slot in range(first + 1, first + 1 + pool[first]):
                    j = pool[slot]
                    ex, ey = tx[j] - x, ty[j] - y
                    found = _keep(nearest, found, ex * ex + ey * ey, j)
        if found < 0:
            found = _ring_search(x, y, tx, ty, order, starts, x0, y0, size, columns, rows, nearest)
        # The segments tried: about the sample's own point, and next to the nearest points.
        n = 0
        for d in range(-window, window):
            segments[n] = min(max(own[q] + d, 0), last)
            n += 1
        for j in range(found):
            point = points[int(nearest[1, j])]
            segments[n] = min(max(point - 1, 0), last)
            segments[n + 1] = min(max(point, 0), last)
            n += 2
        least = math.inf
        every = False  # a NaN or an overflow: every segment's hypot, as numpy takes them
        for i in range(n):
            dx, dy = _segment(px, py, segments[i], x, y)
            dxs[i], dys[i] = dx, dy
            squared = dx * dx + dy * dy
            if not squared < math.inf:
                every = True
            elif squared < least:
                least = squared
        distance = math.inf
        taken_x, taken_y, taken = math.nan, math.nan, math.nan  # the last hypot taken
        for i in range(n):
            squared = dxs[i] * dxs[i] + dys[i] * dys[i]
            if every or squared <= least * (1.0 + _SQUARED_MARGIN) + _TINY:
                if dxs[i] == taken_x and dys[i] == taken_y:  # (hypot is even: -0 as 0)
                    found_distance = taken  # a segment tried twice, or its twin at a corner
                else:
                    # the C library's, as numpy's (math.hypot is CPython's own as plain Python)
                    found_distance = np.hypot(dxs[i], dys[i])
                    taken_x, taken_y, taken = dxs[i], dys[i], found_distance
                if found_distance != found_distance:  # numpy's min keeps a NaN
                    distance = math.nan
                    break
                distance = min(distance, found_distance)
        out[q] = distance


@inlined
def _visit(
    tx: FloatArray,
    ty: FloatArray,
    order: NDArray[np.int64],
    starts: NDArray[np.int64],
    key: int,
    x: float,
    y: float,
    nearest: FloatArray,
    found: int,
) -> int:
    """The points of cell ``key`` offered to the nearest found (:func:`_keep`)."""
    for slot in range(starts[key], starts[key + 1]):
        j = order[slot]
        ex, ey = tx[j] - x, ty[j] - y
        found = _keep(nearest, found, ex * ex + ey * ey, j)
    return found


@inlined
def _keep(nearest: FloatArray, found: int, squared: float, j: int) -> int:
    """Point j kept among the nearest found so far (``nearest``: their squared
    distances and indices, nearest first) if it is nearer (ties: the earlier);
    how many are kept now."""
    k = nearest.shape[1]
    if found == k and (
        squared > nearest[0, k - 1] or (squared == nearest[0, k - 1] and j > nearest[1, k - 1])
    ):
        return found
    at = found if found < k else k - 1
    while at > 0 and (
        squared < nearest[0, at - 1] or (squared == nearest[0, at - 1] and j < nearest[1, at - 1])
    ):
        nearest[0, at], nearest[1, at] = nearest[0, at - 1], nearest[1, at - 1]
        at -= 1
    nearest[0, at], nearest[1, at] = squared, j
    return found + 1 if found < k else k
