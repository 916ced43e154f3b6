"""What every layer shares: the robot's state, the array types, time in samples.

The state is the pose ``x, y, theta`` [m, m, rad] in this order everywhere.
The sensors measure any subset of it: the paper measures ``xi = [x, theta]``
(eq. (1)); the output of eq. (2) here is the full pose masked by which states
are measured, so the kernels keep fixed 3-vectors and a 0/1 mask instead of
changing shapes.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Final, Literal

import numpy as np
from numpy.typing import NDArray

STATES: Final = ("x", "y", "theta")
StateName = Literal["x", "y", "theta"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def measurement_mask(measured: Iterable[str]) -> FloatArray:
    """1.0 for each measured state, in the order x, y, theta."""
    names = set(measured)
    unknown = names - set(STATES)
    if unknown:
        raise ValueError(f"unknown state(s) {sorted(unknown)}; expected a subset of x, y, theta")
    return np.array([1.0 if name in names else 0.0 for name in STATES])


def samples(seconds: float, dt: float) -> int:
    """A duration as the nearest whole number of samples of period ``dt``: the
    one conversion of seconds to samples (validation warns, or refuses where
    the setting counts samples, when a duration is not a whole multiple)."""
    return round(seconds / dt)


def whole_samples(seconds: float, dt: float) -> bool:
    """Whether ``seconds`` is a whole multiple of ``dt``, to rounding."""
    count = seconds / dt
    return abs(count - round(count)) <= 1e-6 * max(1.0, count)
