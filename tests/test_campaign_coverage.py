"""The runs-per-pixel count behind a campaign's trajectory figure."""

from __future__ import annotations

import numpy as np
import pytest

from wmr_mission.campaign.coverage import runs_per_pixel
from wmr_mission.kernels import jit

VIEW = (0.0, 10.0, 0.0, 5.0)  # 1 m per pixel on a 10 x 5 canvas
SHAPE = (5, 10)


def _path(*points: tuple[float, float]) -> np.ndarray:
    return np.asarray(points, dtype=np.float32).T


def test_a_straight_run_counts_once_in_each_pixel_it_crosses() -> None:
    counts = runs_per_pixel([_path((0.5, 2.5), (9.5, 2.5))], VIEW, SHAPE)
    expected = np.zeros(SHAPE, dtype=np.int32)
    expected[2, :] = 1  # row 0 is the bottom: y = 2.5 is row 2
    np.testing.assert_array_equal(counts, expected)


def test_a_run_lapping_a_loop_counts_once_two_runs_count_twice() -> None:
    square = [(1.5, 1.5), (8.5, 1.5), (8.5, 3.5), (1.5, 3.5), (1.5, 1.5)]
    one_lap = _path(*square)
    three_laps = _path(*(square * 3))
    counts = runs_per_pixel([three_laps], VIEW, SHAPE)
    np.testing.assert_array_equal(counts, runs_per_pixel([one_lap], VIEW, SHAPE))
    assert counts.max() == 1
    assert counts.sum() == 2 * 8 + 2 * 1  # rows 1 and 3, and the sides in row 2
    np.testing.assert_array_equal(runs_per_pixel([three_laps, one_lap], VIEW, SHAPE), 2 * counts)


def test_the_walk_leaves_no_gap_and_strays_no_further_than_a_neighbour() -> None:
    """Against a dense reference (a thousand samples per segment): every
    pixel the walk counts is one the path reaches or its neighbour, and
    every pixel the path reaches is counted or has a counted neighbour."""
    rng = np.random.default_rng(3)
    view, shape = (-2.0, 2.0, -1.0, 1.0), (90, 170)
    for _ in range(20):
        path = rng.uniform([[-2.5], [-1.5]], [[2.5], [1.5]], size=(2, 12)).astype(np.float32)
        walked = runs_per_pixel([path], view, shape) > 0
        fine = np.linspace(0.0, 1.0, 1000)
        xs = np.concatenate(
            [a + (b - a) * fine for a, b in zip(path[0][:-1], path[0][1:], strict=True)]
        )
        ys = np.concatenate(
            [a + (b - a) * fine for a, b in zip(path[1][:-1], path[1][1:], strict=True)]
        )
        columns = np.floor((xs - view[0]) / (view[1] - view[0]) * shape[1]).astype(int)
        rows = np.floor((ys - view[2]) / (view[3] - view[2]) * shape[0]).astype(int)
        inside = (columns >= 0) & (columns < shape[1]) & (rows >= 0) & (rows < shape[0])
        reached = np.zeros(shape, dtype=bool)
        reached[rows[inside], columns[inside]] = True

        def grown(mask: np.ndarray) -> np.ndarray:
            padded = np.pad(mask, 1)
            return np.any(
                [
                    padded[1 + i : 1 + i + shape[0], 1 + j : 1 + j + shape[1]]
                    for i in (-1, 0, 1)
                    for j in (-1, 0, 1)
                ],
                axis=0,
            )

        assert not (walked & ~grown(reached)).any()
        assert not (reached & ~grown(walked)).any()


def test_non_finite_points_and_runaways_draw_what_is_finite() -> None:
    diverged = _path((0.5, 0.5), (9.5, 0.5), (np.nan, np.nan), (0.5, 4.5), (9.5, 4.5))
    counts = runs_per_pixel([diverged], VIEW, SHAPE)
    assert counts[0].sum() == 10
    assert counts[4].sum() == 10
    assert counts[1:4].sum() == 0
    # A runaway: its way off the canvas is drawn to the edge, and costs no more
    for far in (300.0, 1e5, 1e30):
        runaway = runs_per_pixel([_path((0.5, 2.5), (far, 2.5))], VIEW, SHAPE)
        assert runaway[2].sum() == 10
        assert runaway.sum() == 10
    entering = runs_per_pixel([_path((-1e6, -1e6), (1e6, 1e6))], VIEW, SHAPE)
    assert entering.sum() >= 5  # the diagonal's part on the canvas
    assert all(entering[row].sum() >= 1 for row in range(SHAPE[0]))
    assert runs_per_pixel([], VIEW, SHAPE).sum() == 0
    single = runs_per_pixel([_path((3.5, 3.5))], VIEW, SHAPE)
    assert single[3, 3] == 1
    assert single.sum() == 1


def test_compiled_and_plain_python_count_the_same(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(11)
    paths = [np.cumsum(rng.normal(0, 0.3, (2, 200)), axis=1).astype(np.float32) for _ in range(8)]
    view, shape = (-4.0, 4.0, -3.0, 3.0), (60, 80)
    counts = runs_per_pixel(paths, view, shape)
    monkeypatch.setattr(jit, "compiled", lambda function, **options: jit.plain(function))
    np.testing.assert_array_equal(runs_per_pixel(paths, view, shape), counts)
    assert counts.max() >= 2  # random walks from the origin share pixels there
