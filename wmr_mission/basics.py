"""What every layer shares: the robot's state, the array types, time in samples.

The state is the pose ``x, y, theta`` [m, m, rad] in this order everywhere.
The sensors measure any subset of it: the paper measures ``xi = [x, theta]``
(eq. (1)); the output of eq. (2) here is the full pose masked by which states
are measured, so the kernels keep fixed 3-vectors and a 0/1 mask instead of
changing shapes.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Final, Generic, Literal, TypeVar, overload

import numpy as np
from numpy.typing import NDArray

Owner = TypeVar("Owner")
Value = TypeVar("Value")

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


class cached_value(Generic[Owner, Value]):
    """``functools.cached_property`` without its lock.

    Before Python 3.12 that decorator holds one lock per attribute for every
    instance of the class. A process forked while another thread is inside it
    (a campaign's worker processes, forked from a process where a Dask worker
    thread judges a run) inherits the lock held and waits for ever."""

    def __init__(self, compute: Callable[[Owner], Value]) -> None:
        self.compute = compute
        self.name = compute.__name__
        self.__doc__ = compute.__doc__

    def __set_name__(self, owner: type[Owner], name: str) -> None:
        self.name = name

    @overload
    def __get__(self, instance: None, owner: type[Owner]) -> cached_value[Owner, Value]: ...
    @overload
    def __get__(self, instance: Owner, owner: type[Owner]) -> Value: ...
    def __get__(
        self, instance: Owner | None, owner: type[Owner]
    ) -> Value | cached_value[Owner, Value]:
        if instance is None:
            return self
        value = self.compute(instance)
        instance.__dict__[self.name] = value  # found before this descriptor from now on
        return value
