"""wmr_mission.kernels.scalar_math: the C library's functions element by element, the
same bits compiled and as plain Python, the special values numpy gives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission.kernels import jit, scalar_math
from wmr_mission.kernels.scalar_math import ARITY, CODES

SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, 710.0, -710.0, 1e308, -1e308, 5e-324]
SPECIAL += [math.inf, -math.inf, math.nan]


def _arguments(code: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Ordinary arguments, the edges of each domain, overflow and non-finite ones."""
    ordinary = np.concatenate(
        [rng.uniform(-10.0, 10.0, 3000), rng.uniform(-1.5, 1.5, 1000), rng.normal(0, 1e3, 500)]
    )
    x = np.concatenate([ordinary, SPECIAL * len(SPECIAL)])
    y = np.concatenate([rng.uniform(-4.0, 4.0, ordinary.size), np.repeat(SPECIAL, len(SPECIAL))])
    if ARITY[code] == 1:
        y = x
    return x, y


def _bits(values: np.ndarray) -> list[object]:
    """Each value's bits, any NaN as one: a NaN's sign and payload are not data."""
    return ["nan" if math.isnan(v) else np.float64(v).tobytes() for v in values.tolist()]


@pytest.mark.parametrize("name", sorted(CODES))
def test_compiled_and_plain_python_give_the_same_bits(
    name: str, rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    code = CODES[name]
    x, y = _arguments(code, rng)
    jit.load()  # as the simulation does: compiled from here on
    compiled = scalar_math.apply(code, x, y)
    monkeypatch.setattr(scalar_math, "_compiled_each", lambda: None)
    plain = scalar_math.apply(code, x, y)
    one_by_one = [scalar_math.apply(code, a, b) for a, b in zip(x[:300], y[:300], strict=True)]
    if jit.compiling():
        assert scalar_math._compiled is not None  # the compiled loop ran above
    assert _bits(np.asarray(compiled)) == _bits(np.asarray(plain)), name
    assert _bits(np.asarray(one_by_one)) == _bits(np.asarray(plain)[:300]), name


@pytest.mark.parametrize("name", sorted(CODES))
def test_values_are_numpys_within_an_ulp_and_its_special_values(
    name: str, rng: np.random.Generator
) -> None:
    code = CODES[name]
    x, y = _arguments(code, rng)
    ufunc = {"asin": np.arcsin, "acos": np.arccos, "atan": np.arctan, "atan2": np.arctan2}
    reference = ufunc.get(name) or getattr(np, name)
    with np.errstate(all="ignore"):
        expected = reference(x, y) if ARITY[code] == 2 else reference(x)
    got = np.asarray(scalar_math.apply(code, x, y))
    assert np.array_equal(np.isnan(got), np.isnan(expected)), name
    finite = np.isfinite(expected)
    assert np.array_equal(got[~finite & ~np.isnan(got)], expected[~finite & ~np.isnan(expected)])
    spacing = np.spacing(np.abs(expected[finite]))
    assert np.all(np.abs(got[finite] - expected[finite]) <= 2.0 * spacing), name


def test_shapes_broadcast_and_scalars_stay_scalars() -> None:
    times = np.linspace(0.0, 1.0, 12).reshape(3, 4)
    assert scalar_math.sin(times).shape == (3, 4)
    assert np.asarray(scalar_math.apply(scalar_math.POWER, times, 2.0)).shape == (3, 4)
    assert np.asarray(scalar_math.apply(scalar_math.ATAN2, 1.0, times[0])).shape == (4,)
    assert isinstance(scalar_math.apply(scalar_math.EXP, 1.0), float)
    strided = np.arange(20.0)[::3]
    assert np.array_equal(scalar_math.cos(strided), scalar_math.cos(strided.copy()))
