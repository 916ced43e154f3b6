"""The points of a path nearest given positions, exactly, by numpy alone."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray

__all__ = ["PointGrid"]

_CANDIDATES = 1 << 16  # candidate distances per block of the nearest-points search


class PointGrid:
    """The k points nearest a position, exactly, by numpy alone.

    The points are bucketed in square cells of side ``cell``, then 2, 4, ...
    times that. At each size, the points of the 3 x 3 cells round a position's
    cell are its candidates: the k nearest of them are the k nearest of all
    when the k-th is no farther than the edge of those 9 cells (or when they
    hold every point). A position not settled at one size is tried at the
    next, up to the size where 2 x 2 cells hold the whole path; those left
    (far off the path) are measured against every point.
    """

    def __init__(self, px: FloatArray, py: FloatArray, cell: float) -> None:
        self.px, self.py = px, py
        self.origin = (float(px.min()), float(py.min()))
        self.cell = cell
        self._levels: dict[float, Any] = {}  # cell size -> buckets, made once

    def nearest(
        self, qx: FloatArray, qy: FloatArray, k: int, reach: FloatArray
    ) -> NDArray[np.intp]:
        """Indices (len(qx), min(k, points)) of the points nearest each position;
        ``reach`` guesses how far they are (it only sets where the search starts)."""
        k = min(k, self.px.size)
        found = np.zeros((qx.size, k), dtype=np.intp)
        # The first size whose cells' reach (at least one side) covers the guess.
        doublings = np.log2(np.maximum(reach + 2 * self.cell, self.cell) / self.cell)
        level = np.ceil(np.nan_to_num(doublings, nan=0.0, posinf=64.0)).astype(np.int64)
        unsettled = np.ones(qx.size, dtype=bool)
        size = self.cell
        while unsettled.any():
            if size not in self._levels:
                self._levels[size] = self._buckets(size)
            buckets = self._levels[size]
            if buckets is None:  # 2 x 2 cells hold the whole path
                pending = np.flatnonzero(unsettled)
                found[pending] = self._every_point(qx[pending], qy[pending], k)
                break
            pending = np.flatnonzero(unsettled & (level <= 0))
            level -= 1
            settled = np.zeros(pending.size, dtype=bool)
            rows = max(1, _CANDIDATES // (9 * buckets[3]))
            for start in range(0, pending.size, rows):
                part = pending[start : start + rows]
                chosen, ok = self._search(buckets, size, qx[part], qy[part], k)
                found[part[ok]] = chosen[ok]
                settled[start : start + rows] = ok
            unsettled[pending[settled]] = False
            size *= 2
        return found

    def _buckets(
        self, size: float
    ) -> tuple[NDArray[np.int64], NDArray[np.intp], NDArray[np.int64], int, int, int] | None:
        """Sorted cell keys of the points and where each cell's points start in
        ``order``, the order, the most points in a cell, the grid's columns and rows."""
        column = np.floor((self.px - self.origin[0]) / size).astype(np.int64)
        row = np.floor((self.py - self.origin[1]) / size).astype(np.int64)
        columns, rows = int(column.max()) + 1, int(row.max()) + 1
        if columns <= 2 and rows <= 2:
            return None
        keys = column * rows + row
        order = np.argsort(keys, kind="stable")
        cells, starts, counts = np.unique(keys[order], return_index=True, return_counts=True)
        return cells, order, np.column_stack((starts, counts)), int(counts.max()), columns, rows

    def _search(
        self,
        buckets: tuple[NDArray[np.int64], NDArray[np.intp], NDArray[np.int64], int, int, int],
        size: float,
        qx: FloatArray,
        qy: FloatArray,
        k: int,
    ) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        """The k nearest candidates of each position in its 3 x 3 cells, and
        whether they are its k nearest of all."""
        cells, order, spans, most, columns, rows = buckets
        # Cell of each position, clipped: a position far outside is never settled here.
        u = (qx - self.origin[0]) / size
        v = (qy - self.origin[1]) / size
        column = np.clip(np.floor(u), -2, columns + 1).astype(np.int64)
        row = np.clip(np.floor(v), -2, rows + 1).astype(np.int64)
        shift = np.arange(-1, 2)
        near_column = (column[:, None] + shift)[:, :, None]  # (n, 3, 1)
        near_row = (row[:, None] + shift)[:, None, :]  # (n, 1, 3)
        inside = (near_column >= 0) & (near_column < columns) & (near_row >= 0) & (near_row < rows)
        keys = (near_column * rows + near_row).reshape(qx.size, 9)
        at = np.minimum(np.searchsorted(cells, keys), cells.size - 1)
        held = inside.reshape(qx.size, 9) & (cells[at] == keys)
        slot = np.arange(most)
        taken = held[:, :, None] & (slot < spans[at, 1][:, :, None])  # (n, 9, most)
        where = np.minimum(spans[at, 0][:, :, None] + slot, order.size - 1)
        candidate = order[where].reshape(qx.size, -1)
        taken = taken.reshape(qx.size, -1)
        squared = np.where(
            taken,
            (self.px[candidate] - qx[:, None]) ** 2 + (self.py[candidate] - qy[:, None]) ** 2,
            np.inf,
        )
        best = np.argpartition(squared, k - 1, axis=1)[:, :k]
        chosen = np.take_along_axis(candidate, best, axis=1)
        kth = np.take_along_axis(squared, best, axis=1).max(axis=1)
        # Distance to the edge of the 3 x 3 cells: every point outside is farther.
        edge = (
            np.minimum.reduce((u - (column - 1), column + 2 - u, v - (row - 1), row + 2 - v)) * size
        )
        whole = (column <= 1) & (column >= columns - 2) & (row <= 1) & (row >= rows - 2)
        ok = np.isfinite(kth) & ((kth <= np.maximum(edge, 0.0) ** 2) | whole)
        return chosen, ok

    def _every_point(self, qx: FloatArray, qy: FloatArray, k: int) -> NDArray[np.intp]:
        found = np.empty((qx.size, k), dtype=np.intp)
        rows = max(1, _CANDIDATES // self.px.size)
        for start in range(0, qx.size, rows):
            part = slice(start, start + rows)
            squared = (self.px - qx[part, None]) ** 2 + (self.py - qy[part, None]) ** 2
            found[part] = np.argpartition(squared, k - 1, axis=1)[:, :k]
        return found
