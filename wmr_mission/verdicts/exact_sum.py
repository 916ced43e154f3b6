"""The exact sum of squares behind ``reference_error_rms``, one compiled pass
where the judge's passes run compiled: the float ``math.fsum`` gives.

``math.fsum`` keeps the running sum as non-overlapping partials (Shewchuk's
algorithm) and rounds their total once, half to even; this is CPython's own
loop (``Modules/mathmodule.c``, ``math_fsum``), step by step, so the float is
the same on every CPU (``tests/test_verdict_exact_sum.py`` compares it with
``math.fsum`` on sums built to round wrongly when added in order). Where
``math.fsum`` would see an infinite square or overflow on the way (it raises
then), the pass gives NaN and its caller asks ``math.fsum`` itself.
"""

from __future__ import annotations

import math

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import kernel

__all__ = ["PARTIALS", "finite_squares_sum"]

# Partials kept at most: non-overlapping doubles, each with a bit of its own
# among the 2 098 places from 2^-1074 to 2^1023 (math.fsum grows its list).
PARTIALS = 2100


@kernel
def finite_squares_sum(values: FloatArray, partials: FloatArray) -> tuple[float, int]:
    """``math.fsum`` of ``value * value`` over the finite ``values``, and how
    many they are; NaN for the sum where ``math.fsum`` must decide (a square or
    the sum beyond the largest float, or more than ``partials.size`` partials).
    ``partials``: scratch, made by the caller (an array made in compiled code
    makes loading the kernel import numba's array module)."""
    n = 0  # partials in use, smallest first
    count = 0
    for k in range(values.size):
        value = values[k]
        if not abs(value) < math.inf:  # NaN or infinite: left out, as np.isfinite leaves it
            continue
        count += 1
        x = value * value
        i = 0
        for j in range(n):  # x added to each partial, the round-off kept
            y = partials[j]
            if abs(x) < abs(y):
                x, y = y, x
            hi = x + y
            lo = y - (hi - x)
            if lo != 0.0:
                partials[i] = lo
                i += 1
            x = hi
        n = i
        if x != 0.0:
            if not abs(x) < math.inf or n == partials.size:
                return math.nan, count
            partials[n] = x
            n += 1
    total = 0.0
    if n > 0:  # the partials added from the largest until the sum is inexact
        n -= 1
        total = partials[n]
        lo = 0.0
        while n > 0:
            x = total
            n -= 1
            y = partials[n]
            total = x + y
            lo = y - (total - x)
            if lo != 0.0:
                break
        # half to even across the partials: the round-off and the partial below it
        # agree in sign, so the exact sum lies beyond the half-way point
        if n > 0 and ((lo < 0.0 and partials[n - 1] < 0.0) or (lo > 0.0 and partials[n - 1] > 0.0)):
            y = lo * 2.0
            x = total + y
            if y == x - total:
                total = x
    return total, count
