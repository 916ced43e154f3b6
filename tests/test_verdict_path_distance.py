"""The distance to the path in one compiled pass (wmr_mission/verdicts/path_distance.py)
gives the numpy form's bits (metrics.distance_to_path), compiled and as plain Python."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from wmr_mission.kernels import jit
from wmr_mission.verdicts import metrics, path_distance

Case = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _laps(rng: np.random.Generator, samples: int = 3000) -> Case:
    """A random smooth path flown twice (the second lap between the first's
    points), the robot up to ten steps off, the last samples far behind."""
    t = np.linspace(0.0, 4 * math.pi, samples)
    px = sum(rng.normal() * np.sin(m * t / 2 + rng.uniform(0, 6)) for m in range(1, 5))
    py = sum(rng.normal() * np.cos(m * t / 2 + rng.uniform(0, 6)) for m in range(1, 5))
    px, py = np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64)
    off = 10 * np.median(np.hypot(np.diff(px), np.diff(py)))
    x, y = px + rng.uniform(-off, off, samples), py + rng.uniform(-off, off, samples)
    behind = np.arange(samples - 200, samples) - samples // 10
    x[-200:], y[-200:] = px[behind], py[behind] + off
    return x, y, px, py


def _grid_path(rng: np.random.Generator) -> Case:
    """A path on a lattice, each point held a few samples (segments of length
    0), the robot on and between the lattice's points: ties everywhere."""
    steps = rng.integers(-1, 2, size=(2, 400)) * 0.25
    px, py = np.repeat(np.cumsum(steps, axis=1), 3, axis=1)
    x = np.round((px + rng.normal(0, 0.3, px.size)) * 8) / 8
    y = np.round((py + rng.normal(0, 0.3, py.size)) * 8) / 8
    return x, y, px, py


def _gaps(rng: np.random.Generator) -> Case:
    """References and positions missing here and there, some positions far
    outside the path's extent, some beyond the grid's reach, one huge."""
    x, y, px, py = _laps(rng, 1200)
    px[rng.integers(0, px.size, 40)] = np.nan
    x[rng.integers(0, x.size, 40)] = np.nan
    x[100:110] += 500.0
    y[200:205] = -3e13
    x[300], y[300] = 1e200, -1e200  # squares overflow: every segment's hypot
    return x, y, px, py


def _two_points(rng: np.random.Generator) -> Case:
    x, y = rng.normal(0, 2, (2, 50))
    return x, y, np.r_[0.0, np.full(49, 1.0)], np.r_[0.0, np.full(49, 2.0)]


CASES: dict[str, Callable[[np.random.Generator], Case]] = {
    "laps": _laps,
    "grid": _grid_path,
    "gaps": _gaps,
    "two points": _two_points,
}


def _bits(values: np.ndarray) -> list[object]:
    return ["nan" if math.isnan(v) else np.float64(v).tobytes() for v in values.tolist()]


def _numpy_form(case: Case, monkeypatch: pytest.MonkeyPatch) -> np.ndarray:
    with monkeypatch.context() as patch, np.errstate(over="ignore", invalid="ignore"):
        patch.setattr(jit, "distances_compiled", lambda: False)
        return metrics.distance_to_path(*case)


@pytest.mark.parametrize("lists", [False, True])
@pytest.mark.parametrize("name", sorted(CASES))
def test_compiled_distance_to_path_has_the_numpy_forms_bits(
    name: str, lists: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """By the rings, and by the cells' lists (made however few the positions)."""
    case = CASES[name](np.random.default_rng(len(name)))
    expected = _numpy_form(case, monkeypatch)
    if lists:
        monkeypatch.setattr(path_distance, "_LIST_POSITIONS_PER_POINT", 0)
    jit.load()  # as a compiled run does: the distance compiled from here on
    monkeypatch.setattr(jit, "distances_compiled", lambda: True)  # also where numba is turned off
    found = metrics.distance_to_path(*case)
    assert _bits(found) == _bits(expected)
    assert np.isfinite(expected).sum() > 0.9 * expected.size


@pytest.mark.parametrize("lists", [False, True])
def test_the_kernel_as_plain_python_has_the_numpy_forms_bits(
    lists: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    case = tuple(a[:400] for a in _gaps(np.random.default_rng(3)))
    expected = _numpy_form(case, monkeypatch)
    if lists:
        monkeypatch.setattr(path_distance, "_LIST_POSITIONS_PER_POINT", 0)
    monkeypatch.setattr(jit, "distances_compiled", lambda: True)
    monkeypatch.setattr(jit, "compiled", lambda fn, **options: jit.plain(fn))
    with np.errstate(over="ignore", invalid="ignore"):  # the huge position, as numpy
        assert _bits(metrics.distance_to_path(*case)) == _bits(expected)


def _first_by_sorting(px: np.ndarray, py: np.ndarray, cell: float) -> np.ndarray:
    """The first point in each cell as numpy's stable sort by cell finds it."""
    column, row = np.floor(px / cell), np.floor(py / cell)
    order = np.lexsort((row, column))
    column, row = column[order], row[order]
    return order[np.r_[True, (column[1:] != column[:-1]) | (row[1:] != row[:-1])]]


@pytest.mark.parametrize("compiled", [True, False])
def test_the_compiled_thinning_keeps_the_first_point_in_each_cell_in_the_sorts_order(
    compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A circle run round ten times, below the origin too (cells of negative
    numbers, -0 among them): the same points, in the same order, as the sort;
    a long diagonal has more cells than points, and is left to the sort."""
    if compiled:
        jit.load()
    else:
        monkeypatch.setattr(jit, "compiled", lambda fn, **options: jit.plain(fn))
    t = np.linspace(0.0, 20 * math.pi, 20000)
    px, py = np.cos(t) - 0.5, np.sin(t)
    px[::97] = -0.0
    cell = 0.015  # 134 cells a side: fewer than two per point
    found = path_distance.first_in_cells(px, py, cell)
    assert found is not None
    expected = _first_by_sorting(px, py, cell)
    assert found.tolist() == expected.tolist()
    assert expected.size < px.size / 3  # the later laps' points thinned out
    diagonal = np.linspace(0.0, 100.0, 2000)
    assert path_distance.first_in_cells(diagonal, diagonal, 0.01) is None


def _doubling_back(rng: np.random.Generator) -> Case:
    """A path out and back over itself, then across itself (a figure of
    eight), on a lattice of quarter steps, held now and then: the robot on its
    points, midway between passes (equally near two or more segments), far
    off, and jumping about, so that one position's nearest points say little
    of the next's."""
    samples = int(rng.integers(150, 500))
    t = np.linspace(0.0, 1.0, samples)
    out_and_back = np.where(t < 0.5, t, 1.0 - t) * rng.integers(4, 40)
    turns = rng.integers(1, 4)
    px = np.round(np.where(t < 0.7, out_and_back, np.sin(2 * np.pi * turns * t)) * 4) / 4
    py = np.round(np.where(t < 0.7, 0.0, np.sin(4 * np.pi * turns * t) / 2) * 4) / 4
    held = rng.integers(0, samples, samples // 10)
    px[held], py[held] = px[np.maximum(held - 1, 0)], py[np.maximum(held - 1, 0)]
    pick = rng.integers(0, samples, samples)
    x, y = px[pick].copy(), py[pick].copy()  # on the path's points, in any order
    midway = rng.random(samples) < 0.3
    y[midway] += rng.choice([-0.125, 0.125, 0.25], midway.sum())
    jittered = rng.random(samples) < 0.3
    x[jittered] += rng.normal(0.0, rng.choice([1e-3, 0.1, 3.0]), jittered.sum())
    far = rng.random(samples) < 0.05
    x[far] += rng.choice([-1.0, 1.0], far.sum()) * 10.0 ** rng.uniform(1, 6, far.sum())
    return x, y, px, py


@pytest.mark.parametrize("lists", [False, True])
def test_the_compiled_distance_on_paths_that_double_back_and_cross_has_the_full_searchs_bits(
    lists: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The compiled pass's search for the nearest points, by the rings and by
    the cells' lists (made however few the positions), and its hypot taken
    only near the least: on 40 random paths that double back and cross
    themselves, with ties everywhere, the full search's bits (the numpy form:
    the nearest points of the grid's cells or the k-d tree, every segment's
    hypot)."""
    rng = np.random.default_rng(34)
    jit.load()
    if lists:
        monkeypatch.setattr(path_distance, "_LIST_POSITIONS_PER_POINT", 0)
    for _ in range(40):
        case = _doubling_back(rng)
        expected = _numpy_form(case, monkeypatch)
        with monkeypatch.context() as patch:
            patch.setattr(jit, "distances_compiled", lambda: True)
            found = metrics.distance_to_path(*case)
        assert _bits(found) == _bits(expected)


def test_a_segment_beyond_its_ends_takes_no_division_and_gives_the_numpy_forms_bits() -> None:
    """The division skipped where the quotient would be clamped to 0 or 1:
    the same distance as numpy's form for positions before, along and beyond
    random segments, on their ends, on zero-length segments, and on segments
    whose step's square overflows (0 times an infinite step is NaN there)."""
    rng = np.random.default_rng(7)
    px, py = rng.normal(0.0, 1.0, (2, 400))
    px[50:60], py[50:60] = 2.0, 3.0  # held: zero-length segments
    px[100:110:2], py[100:110:2] = 1.6e155, -1.5e155  # steps whose squares overflow
    px[200:210:3] = -1.7e155
    segments = np.arange(px.size - 1)
    qx, qy = rng.normal(0.0, 2.0, (2, segments.size))
    near_ends = segments[segments % 4 != 0]  # just past the start or short of the end, aside
    along = 10.0 ** rng.uniform(-16, -3, near_ends.size)
    along[near_ends % 2 == 1] = 1.0 - along[near_ends % 2 == 1]
    sx, sy = np.diff(px)[near_ends], np.diff(py)[near_ends]
    qx[near_ends] = px[near_ends] + along * sx - sy / 10
    qy[near_ends] = py[near_ends] + along * sy + sx / 10
    qx[:10], qy[:10] = px[:10], py[:10]  # on the ends
    qx[-10:], qy[-10:] = 1e154 * rng.normal(size=(2, 10))
    with np.errstate(over="ignore", invalid="ignore"):
        expected = metrics._distance_to_segments(px, py, segments[:, None], qx, qy)
        found = np.array(
            [
                np.hypot(*path_distance._segment(px, py, int(i), float(x), float(y)))
                for i, x, y in zip(segments, qx, qy, strict=True)
            ]
        )
    assert _bits(found) == _bits(expected)
    assert np.isnan(expected).sum() >= 5  # the overflows reached


def test_positions_whose_cell_has_no_list_search_the_rings_for_the_same_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Lists only where the centre's fourth nearest point is within two
    cells, and a pool of 2 000 entries that the laps fill up: many positions
    search the rings instead (on the doubling paths, all), those with a list
    read it, and every distance has the full search's bits."""
    rng = np.random.default_rng(35)
    jit.load()
    monkeypatch.setattr(path_distance, "_LIST_POSITIONS_PER_POINT", 0)
    monkeypatch.setattr(path_distance, "_LIST_REACH", 2.0)
    monkeypatch.setattr(path_distance, "_LIST_CELLS_MOST", 2000)
    for case in (_laps(rng, 1500), *(_doubling_back(rng) for _ in range(8))):
        expected = _numpy_form(case, monkeypatch)
        with monkeypatch.context() as patch:
            patch.setattr(jit, "distances_compiled", lambda: True)
            found = metrics.distance_to_path(*case)
        assert _bits(found) == _bits(expected)
