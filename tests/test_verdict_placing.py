"""Each position's place on the path in one compiled pass (wmr_mission/verdicts/placing.py)
gives the numpy form's bits (tracking.Placement), compiled and as plain Python."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission.kernels import jit
from wmr_mission.verdicts import placing
from wmr_mission.verdicts.tracking import Placement, placed_known

Case = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _path(rng: np.random.Generator, samples: int) -> Case:
    """A random smooth reference that stands still now and then (segments of
    length 0), the robot near it, then far behind it and cutting across (the
    guess lands off the segments searched: Newton steps along the path)."""
    t = np.linspace(0.0, 4 * math.pi, samples)
    rx = sum(rng.normal() * np.sin(m * t / 2 + rng.uniform(0, 6)) for m in range(1, 5))
    ry = sum(rng.normal() * np.cos(m * t / 2 + rng.uniform(0, 6)) for m in range(1, 5))
    rx, ry = np.asarray(rx, dtype=np.float64), np.asarray(ry, dtype=np.float64)
    for start in rng.integers(1, samples - 20, 6):  # the reference waits
        rx[start : start + 15], ry[start : start + 15] = rx[start], ry[start]
    step = np.median(np.hypot(np.diff(rx), np.diff(ry)))
    px = rx + rng.normal(0.0, 3 * step, samples)
    py = ry + rng.normal(0.0, 3 * step, samples)
    behind = rng.integers(0, samples, samples // 5)
    px[behind] = rx[np.maximum(behind - rng.integers(5, 200, behind.size), 0)]
    py[behind] = ry[np.maximum(behind - rng.integers(5, 200, behind.size), 0)] + step
    return px, py, rx, ry


def _places(case: Case, near: float, first: int) -> tuple[np.ndarray, np.ndarray]:
    return Placement(*case).on_path(near, first)


def _bits(values: np.ndarray) -> list[object]:
    return ["nan" if math.isnan(v) else np.float64(v).tobytes() for v in values.tolist()]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_places_have_the_numpy_forms_bits(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(seed)
    case = _path(rng, 3000)
    for near, first in ((math.inf, 0), (0.05, 0), (0.05, 700)):
        with monkeypatch.context() as patch:
            patch.setattr(jit, "judging_compiled", lambda: False)
            expected = _places(case, near, first)
        jit.load()  # as a compiled run does: the places compiled from here on
        with monkeypatch.context() as patch:
            patch.setattr(jit, "judging_compiled", lambda: True)  # also where numba is turned off
            found = _places(case, near, first)
        for ours, theirs in zip(found, expected, strict=True):
            assert _bits(ours) == _bits(theirs)


def test_the_kernel_as_plain_python_has_the_numpy_forms_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    case = _path(np.random.default_rng(5), 400)
    with monkeypatch.context() as patch:
        patch.setattr(jit, "judging_compiled", lambda: False)
        expected = _places(case, math.inf, 0)
    monkeypatch.setattr(jit, "judging_compiled", lambda: True)
    monkeypatch.setattr(jit, "compiled", jit.plain)
    found = _places(case, math.inf, 0)
    for ours, theirs in zip(found, expected, strict=True):
        assert _bits(ours) == _bits(theirs)


def test_the_search_from_a_point_finds_what_numpys_searchsorted_finds() -> None:
    """Arc lengths that stand still (equal values), values on them, before the
    first, past the last and NaN, searched from every kind of starting point:
    the first point beyond, as ``np.searchsorted(..., side="right")``."""
    rng = np.random.default_rng(11)
    for _ in range(300):
        size = int(rng.integers(1, 60))
        steps = rng.choice([0.0, 0.5, 1.0, rng.uniform(0, 3)], size=size - 1)
        arc = np.concatenate(([0.0], np.cumsum(steps)))
        values = np.concatenate((arc, rng.uniform(-1, arc[-1] + 1, 8), [np.nan, np.inf, -np.inf]))
        for value in values.tolist():
            expected = int(np.searchsorted(arc, value, side="right"))
            for near in (0, size - 1, int(rng.integers(-3, size + 3)), expected, expected - 1):
                assert placing._first_beyond(arc, value, near) == expected


def _judged(case: Case) -> list[object]:
    """A phase's places as its metrics and formulas read them: the samples
    known and their placement, and the columns and their largest values from
    a few samples on (none, some, all)."""
    known, placement = placed_known(*case)
    found: list[object] = [known[0].tolist(), None if known[1] is None else str(known[1])]
    if placement is None:
        return [*found, None]
    n = placement.px.size
    longest = placement.longest if n > 1 else None  # (a point has no segment)
    found += [placement.finite, placement.known, placement.standing, longest]
    for near, first, judged in ((math.inf, n // 2, n), (0.05, n // 3, n // 2), (0.05, 0, 0)):
        cross, lag, most_cross, most_lag = placement.judged_on_path(near, first, judged)
        found += [_bits(cross), _bits(lag), most_cross, most_lag]
    return [_bits(np.array([v])) if isinstance(v, float) else v for v in found]


def _cases() -> list[Case]:
    """A reference of a few points, or of one, that stands still, that ends
    unknown (a run's last sample), and positions not finite."""
    rng = np.random.default_rng(7)
    px, py, rx, ry = _path(rng, 600)
    ended = rx.copy()
    ended[-1] = math.nan
    diverged = px.copy()
    diverged[300] = math.inf
    still = np.full(50, 1.5)
    return [
        (px, py, rx, ry),
        (px, py, ended, ry),
        (diverged, py, rx, ry),
        (px[:50], py[:50], still, still),
        (px[:1], py[:1], rx[:1], ry[:1]),
        (px[:3], py[:3], rx[:3], ry[:3]),
        (px[:3], py[:3], np.full(3, math.nan), ry[:3]),
    ]


def test_placing_known_samples_in_one_pass_has_the_numpy_forms_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The samples known, the path's lengths, the columns and their largest
    values: numpy's, compiled and as plain Python."""
    for case in _cases():
        with monkeypatch.context() as patch:
            patch.setattr(jit, "judging_compiled", lambda: False)
            expected = _judged(case)
        jit.load()
        for compiled in (jit.compiled, jit.plain):
            with monkeypatch.context() as patch:
                patch.setattr(jit, "judging_compiled", lambda: True)
                patch.setattr(jit, "compiled", compiled)
                assert _judged(case) == expected
