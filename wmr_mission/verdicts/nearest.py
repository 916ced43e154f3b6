"""The points of a path nearest given positions, exactly: the nearer first and,
of equally near points, the earlier."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray

__all__ = ["NearestPoints"]

_CANDIDATES = 1 << 16  # candidate distances per block of the nearest-points search
# Positions from which scipy's k-d tree pays for importing scipy.spatial (0.06-0.27 s
# of CPU, docs/performance.md) against the grid (about 1.6 us a position more).
TREE_POSITIONS = 100_000
_SPARE = 2  # points asked of the tree beyond k: room to see that the k-th is not tied
# The tree's distances and numpy's squared ones differ by a few roundings (about
# 1e-16 each): a point the tree puts this much farther is farther by numpy's too.
_MARGIN = 1e-9
_TINY = 1e-290  # squared distances below this may be subnormal: their roundings are not small


class NearestPoints:
    """The k points nearest a position, exactly: the k smallest squared
    distances ``(px - x)**2 + (py - y)**2`` as numpy computes them, nearest
    first, ties to the earlier point.

    For ``positions`` (how many will be asked, all told) of TREE_POSITIONS or
    more, scipy's k-d tree names k + 2 candidates; else a grid does (below).
    The candidates are ranked by numpy's arithmetic, so neither search's
    rounding or order of ties chooses anything; a position whose k-th nearest
    may be tied with a point not named (as on a grid) is measured against
    every point. Both give the same points, so the choice is one of cost.

    The grid buckets the points in square cells of side ``cell``, then 2, 4,
    ... times that. At each size, the points of the 3 x 3 cells round a
    position's cell are its candidates: the k nearest of them are the k
    nearest of all when the k-th is nearer than the edge of those 9 cells
    (or when they hold every point) and no other candidate is as near. A
    position not settled at one size is tried at the next, up to the size
    where 2 x 2 cells hold the whole path; those left are measured against
    every point.
    """

    def __init__(self, px: FloatArray, py: FloatArray, cell: float, positions: int) -> None:
        self.px, self.py = px, py
        self.origin = (float(px.min()), float(py.min()))
        self.cell = cell
        self._levels: dict[float, Any] = {}  # cell size -> buckets, made once
        self._tree: Any = None
        if positions >= TREE_POSITIONS:
            from scipy.spatial import cKDTree

            self._tree = cKDTree(np.column_stack((px, py)))

    def nearest(
        self, qx: FloatArray, qy: FloatArray, k: int, reach: FloatArray
    ) -> NDArray[np.intp]:
        """Indices (len(qx), min(k, points)) of the points nearest each position,
        nearest first; ``reach`` guesses how far they are (where the grid starts)."""
        k = min(k, self.px.size)
        if self._tree is not None:
            named, unsure = self._by_tree(qx, qy, k)
        else:
            named, unsure = self._by_grid(qx, qy, k, reach)
        named = np.sort(named, axis=1)  # ties: the earlier first
        squared = (self.px[named] - qx[:, None]) ** 2 + (self.py[named] - qy[:, None]) ** 2
        rank = np.argsort(squared, axis=1, kind="stable")[:, :k]
        found: NDArray[np.intp] = np.take_along_axis(named, rank, axis=1)
        if unsure.size:
            found[unsure] = self._every_point(qx[unsure], qy[unsure], k)
        return found

    def _by_tree(
        self, qx: FloatArray, qy: FloatArray, k: int
    ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """k + 2 points named by the tree, and the positions where the k nearest
        of those may not be the k nearest of all."""
        asked = min(k + _SPARE, self.px.size)
        bound, named = self._tree.query(np.column_stack((qx, qy)), k=asked)
        named = named.reshape(qx.size, asked).astype(np.intp)
        if asked == self.px.size:  # the tree named every point
            return named, np.zeros(0, dtype=np.intp)
        squared = (self.px[named] - qx[:, None]) ** 2 + (self.py[named] - qy[:, None]) ** 2
        kth = np.partition(squared, k - 1, axis=1)[:, k - 1]
        beyond = bound.reshape(qx.size, asked)[:, -1]
        return named, np.flatnonzero(~(beyond**2 > kth * (1 + _MARGIN) + _TINY))

    def _by_grid(
        self, qx: FloatArray, qy: FloatArray, k: int, reach: FloatArray
    ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """The k nearest points by the grid, and the positions it left."""
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
        return found, np.flatnonzero(unsettled)

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
        # Settled: the k-th nearer than every point outside, and than every other candidate.
        alone = np.count_nonzero(squared <= kth[:, None], axis=1) == k
        ok = np.isfinite(kth) & alone & ((kth < np.maximum(edge, 0.0) ** 2) | whole)
        return chosen, ok

    def _every_point(self, qx: FloatArray, qy: FloatArray, k: int) -> NDArray[np.intp]:
        found = np.empty((qx.size, k), dtype=np.intp)
        rows = max(1, _CANDIDATES // self.px.size)
        for start in range(0, qx.size, rows):
            part = slice(start, start + rows)
            squared = (self.px - qx[part, None]) ** 2 + (self.py - qy[part, None]) ** 2
            found[part] = np.argsort(squared, axis=1, kind="stable")[:, :k]
        return found
