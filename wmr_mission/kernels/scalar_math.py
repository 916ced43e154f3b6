"""Transcendental functions of float64 arrays that give the same bits on every CPU.

numpy evaluates sin, cos, exp, log, power, arctan2 ... of float64 arrays with
code it picks at run time for the CPU's SIMD level (X86_V4 with AVX-512,
X86_V3, or the baseline; ``numpy.lib.introspect.opt_func_info()`` lists
them). The levels' results differ in the last bit now and then (``exp`` on
4.6 % of arguments, ``power`` 5.3 %, ``arctan2`` 8.1 %, ``tanh`` 25 %:
scripts/libm_variants.py), and a closed loop carries such a bit into every
later sample. So every value of a path reaches the simulation through here
instead: one element at a time, through the C library's scalar functions,
which are what numba's ``math`` calls in compiled code and what Python's
``math`` calls. Compiled once the simulation's kernels are loaded; otherwise
(validating a mission, which loads no numba; the plain-Python build) element
by element in Python: the same functions, the same bits.

Arithmetic, ``sqrt``, ``abs``, ``floor``, ``ceil``, ``sign``, ``minimum`` and
``maximum`` are exact in IEEE arithmetic at every SIMD level, and numpy's
``hypot`` is the C library's, not dispatched: numpy's own serve for those.
What still differs between machines is the C library itself: its version,
and which variant of it the CPU selects (docs/reliability.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import jit

__all__ = ["ARITY", "CODES", "cos", "exp", "function_of", "sin"]


SIN, COS, TAN, ASIN, ACOS, ATAN, SINH, COSH, TANH, EXP, LOG, LOG10, ATAN2, POWER = range(14)

CODES: Final = {
    "sin": SIN,
    "cos": COS,
    "tan": TAN,
    "asin": ASIN,
    "acos": ACOS,
    "atan": ATAN,
    "sinh": SINH,
    "cosh": COSH,
    "tanh": TANH,
    "exp": EXP,
    "log": LOG,
    "log10": LOG10,
    "atan2": ATAN2,
    "power": POWER,
}
ARITY: Final = {code: 2 if code in (ATAN2, POWER) else 1 for code in CODES.values()}

_MATH: Final[tuple[Callable[..., float], ...]] = (
    math.sin,
    math.cos,
    math.tan,
    math.asin,
    math.acos,
    math.atan,
    math.sinh,
    math.cosh,
    math.tanh,
    math.exp,
    math.log,
    math.log10,
    math.atan2,
    math.pow,
)
# Only for the special values Python's math refuses to return (below).
_NUMPY: Final[tuple[Callable[..., Any], ...]] = (
    np.sin,
    np.cos,
    np.tan,
    np.arcsin,
    np.arccos,
    np.arctan,
    np.sinh,
    np.cosh,
    np.tanh,
    np.exp,
    np.log,
    np.log10,
    np.arctan2,
    np.power,
)


def _scalar(code: int, x: float, y: float) -> float:
    """The C library's value; where Python's ``math`` raises instead (a
    domain error, a pole, an overflow), the IEEE special value the C library
    returns, which is the same from any implementation: nan or an infinity."""
    try:
        return _MATH[code](x, y) if ARITY[code] == 2 else _MATH[code](x)
    except (ValueError, OverflowError):
        with np.errstate(all="ignore"):
            return float(_NUMPY[code](x, y) if ARITY[code] == 2 else _NUMPY[code](x))


def _each(code: int, x: FloatArray, y: FloatArray, out: FloatArray) -> None:
    """``out[i] = f(x[i], y[i])`` for the function ``code``, compiled (numba's
    ``math`` calls the C library and never raises). One loop per function."""
    n = out.shape[0]
    if code == SIN:
        for i in range(n):
            out[i] = math.sin(x[i])
    elif code == COS:
        for i in range(n):
            out[i] = math.cos(x[i])
    elif code == TAN:
        for i in range(n):
            out[i] = math.tan(x[i])
    elif code == ASIN:
        for i in range(n):
            out[i] = math.asin(x[i])
    elif code == ACOS:
        for i in range(n):
            out[i] = math.acos(x[i])
    elif code == ATAN:
        for i in range(n):
            out[i] = math.atan(x[i])
    elif code == SINH:
        for i in range(n):
            out[i] = math.sinh(x[i])
    elif code == COSH:
        for i in range(n):
            out[i] = math.cosh(x[i])
    elif code == TANH:
        for i in range(n):
            out[i] = math.tanh(x[i])
    elif code == EXP:
        for i in range(n):
            out[i] = math.exp(x[i])
    elif code == LOG:
        for i in range(n):
            out[i] = math.log(x[i])
    elif code == LOG10:
        for i in range(n):
            out[i] = math.log10(x[i])
    elif code == ATAN2:
        for i in range(n):
            out[i] = math.atan2(x[i], y[i])
    else:
        for i in range(n):
            out[i] = math.pow(x[i], y[i])


_compiled: Callable[[int, FloatArray, FloatArray, FloatArray], None] | None = None


def _compiled_each() -> Callable[[int, FloatArray, FloatArray, FloatArray], None] | None:
    """:func:`_each` compiled, once the simulation's kernels are loaded (numba
    loaded by wmr_mission.kernels.jit); None before, or without numba.
    Validating a mission samples its paths too, and must not pay for numba."""
    global _compiled
    if not jit.loaded():
        return None
    if _compiled is None:
        # Without reference counting: it writes into arrays its caller holds
        # and makes none, so loading it needs no reference-counting runtime.
        _compiled = jit.compiled(_each, counted=False)
    return _compiled


def load() -> None:
    """Load :func:`_each` compiled now (from the cache, or compiling it), so
    the first path sampled inside the run's clock does not pay for it."""
    compiled = _compiled_each()
    if compiled is not None:
        empty = np.zeros(0)
        compiled(SIN, empty, empty, empty)


def apply(code: int, x: ArrayLike, y: ArrayLike = 0.0) -> FloatArray | float:
    """The function ``code`` of ``x`` (and ``y``), element by element, broadcast
    as numpy would; a float when both are scalars."""
    if np.ndim(x) == 0 and np.ndim(y) == 0:
        return _scalar(code, float(x), float(y))  # type: ignore[arg-type]
    if ARITY[code] == 1:
        first = np.asarray(x, np.float64)
        flat_x = flat_y = np.ascontiguousarray(first).ravel()
    else:
        first, second = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
        flat_x = np.ascontiguousarray(first).ravel()
        flat_y = np.ascontiguousarray(second).ravel()
    out = np.empty(flat_x.shape[0])
    compiled = _compiled_each()
    if compiled is not None:
        compiled(code, flat_x, flat_y, out)
    else:
        out[:] = _each_in_python(code, flat_x.tolist(), flat_y.tolist())
    return out.reshape(first.shape)


def _each_in_python(code: int, x: list[float], y: list[float]) -> list[float]:
    """:func:`_each` in Python: Python's ``math`` mapped over the values (a
    tenth of :func:`_scalar`'s cost each: a mission's check samples its paths
    so, thousands of values), or :func:`_scalar` value by value where it
    refuses one."""
    function = _MATH[code]
    try:
        return list(map(function, x, y) if ARITY[code] == 2 else map(function, x))
    except (ValueError, OverflowError):
        return [_scalar(code, a, b) for a, b in zip(x, y, strict=True)]


def function_of(code: int) -> Callable[..., FloatArray | float]:
    """``apply`` bound to one function, for a table of functions by name."""

    def function(*operands: ArrayLike) -> FloatArray | float:
        return apply(code, *operands)

    function.__name__ = next(name for name, value in CODES.items() if value == code)
    return function


def sin(x: ArrayLike) -> FloatArray:
    return np.asarray(apply(SIN, x))


def cos(x: ArrayLike) -> FloatArray:
    return np.asarray(apply(COS, x))


def exp(x: ArrayLike) -> FloatArray:
    return np.asarray(apply(EXP, x))
