"""The compiled exact sum of squares (wmr_mission/verdicts/passes.py) gives
the float ``math.fsum`` gives, compiled and as plain Python, on sums that a sum
in order, a compensated (Neumaier) sum or a pairwise one rounds differently;
``reference_error`` gives the same bits through it as through ``math.fsum``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission.kernels import jit
from wmr_mission.verdicts import metrics
from wmr_mission.verdicts.passes import PARTIALS, finite_squares_sum


def _forms() -> list[object]:
    """The pass as plain Python, then compiled."""
    jit.load()
    return [jit.plain(finite_squares_sum), jit.compiled(finite_squares_sum)]


def _fsum(values: np.ndarray) -> tuple[float, int]:
    finite = values[np.isfinite(values)]
    return math.fsum(finite * finite), finite.size


def _neumaier(squares: list[float]) -> float:
    total, carried = 0.0, 0.0
    for x in squares:
        t = total + x
        carried += (total - t) + x if abs(total) >= abs(x) else (x - t) + total
        total = t
    return total + carried


def _same(values: np.ndarray) -> None:
    expected = _fsum(values)
    for form in _forms():
        total, count = form(values, np.empty(PARTIALS))  # type: ignore[operator]
        assert count == expected[1]
        assert np.float64(total).tobytes() == np.float64(expected[0]).tobytes()


def test_the_half_way_point_across_partials_rounds_as_fsum_rounds_it() -> None:
    # 9 + 2^-50 + 2^-104: half an ulp of 9 and a little more, so the exact sum
    # rounds up; added in order, or with a compensation that rounds the two
    # small squares together (to 2^-50, half to even), it stays at 9
    values = np.array([3.0, 2.0**-25, 2.0**-52])
    squares = [float(v) * float(v) for v in values]
    assert math.fsum(squares) == 9.0 + 2.0**-49
    assert sum(squares) == 9.0
    assert _neumaier(squares) == 9.0
    for order in ([0, 1, 2], [2, 1, 0], [1, 0, 2], [2, 0, 1]):
        _same(values[order])


@pytest.mark.parametrize("seed", range(8))
def test_random_spreads_of_magnitude_sum_as_fsum_sums_them(seed: int) -> None:
    # squares from subnormal to 1e300, many partials at once, in random order,
    # with NaN and infinite values (left out) among them
    rng = np.random.default_rng(seed)
    size = int(rng.integers(1, 4000))
    exponents = rng.integers(-540, 496, size)
    values = rng.uniform(1.0, 2.0, size) * np.exp2(exponents.astype(float))
    values *= rng.choice([-1.0, 1.0], size)
    values[rng.random(size) < 0.01] = np.nan
    values[rng.random(size) < 0.005] = -np.inf
    _same(values)
    squares = [float(v) * float(v) for v in values if math.isfinite(v)]
    if seed == 0:  # the inputs are ones an inexact sum gets wrong
        assert sum(squares) != math.fsum(squares)


def test_near_equal_squares_of_a_long_run_sum_as_fsum_sums_them() -> None:
    # a tracking error's samples: 360 001 distances of a few millimetres
    rng = np.random.default_rng(7)
    values = 0.003 + rng.normal(0.0, 1e-4, 360_001)
    squares = values * values
    assert sum(squares.tolist()) != math.fsum(squares.tolist())  # in order: rounded
    _same(values)


def test_no_finite_value_counts_none() -> None:
    for values in (np.array([]), np.array([np.nan, np.inf, -np.inf])):
        for form in _forms():
            assert form(values, np.empty(PARTIALS)) == (0.0, 0)  # type: ignore[operator]


@pytest.mark.parametrize(
    "values",
    [
        [1e200, 1.0],  # a square beyond the largest float: fsum's infinite sum
        [1e154, 1e154, 1e154],  # a sum beyond it: fsum's overflow
    ],
)
def test_what_overflows_is_left_to_fsum(values: list[float]) -> None:
    for form in _forms():
        with np.errstate(over="ignore"):  # as plain Python: numpy's scalars warn of it
            total, count = form(np.array(values), np.empty(PARTIALS))  # type: ignore[operator]
        assert math.isnan(total)
        assert count > 0


def test_too_few_partials_are_left_to_fsum() -> None:
    values = np.exp2(np.arange(-500.0, 500.0, 27.0))  # squares 2^54 apart: a partial each
    for form in _forms():
        total, _ = form(values, np.empty(4))  # type: ignore[operator]
        assert math.isnan(total)
    _same(values)


@pytest.mark.parametrize("values", [[0.003, 0.004, np.nan], [1e200, 0.1], [], [np.nan]])
def test_reference_error_is_the_same_through_the_pass(
    monkeypatch: pytest.MonkeyPatch, values: list[float]
) -> None:
    distance = np.array(values, dtype=float)
    with monkeypatch.context() as patch, np.errstate(over="ignore"):
        patch.setattr(jit, "judging_compiled", lambda: False)
        expected = metrics.reference_error(distance)
    jit.load()
    called = []

    def counting(fn: object, **options: object) -> object:
        called.append(getattr(fn, "__name__", ""))
        return jit.plain(fn)  # type: ignore[arg-type]

    with monkeypatch.context() as patch, np.errstate(over="ignore"):
        patch.setattr(jit, "judging_compiled", lambda: True)
        patch.setattr(jit, "compiled", counting)
        assert metrics.reference_error(distance) == expected
    assert called == ["finite_squares_sum"]
