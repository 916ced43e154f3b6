"""Optional compilation of the per-sample kernels.

Every kernel is written once, in the subset of Python that numba compiles. When
numba is missing, or ``WMR_MISSION_NO_JIT=1`` is set, the very same functions
run as plain Python: slower, same equations.
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])

_DISABLED = os.environ.get("WMR_MISSION_NO_JIT", "") not in ("", "0")

try:
    if _DISABLED:
        raise ImportError
    import numba

    _njit: Callable[..., Any] | None = numba.njit
except ImportError:  # pragma: no cover - exercised where numba cannot install
    _njit = None

COMPILED = _njit is not None


def kernel(fn: F) -> F:
    """Compile ``fn`` with numba (cached on disk) when available; else return it as is."""
    if _njit is None:
        return fn
    return cast(F, _njit(cache=True, nogil=True)(fn))


def _time_stamp_counter() -> Callable[[], int] | None:
    """A compiled read of the processor's time-stamp counter (x86-64 only:
    elsewhere the cycle counter may not be readable from user space)."""
    if _njit is None or platform.machine().lower() not in ("x86_64", "amd64"):
        return None
    from llvmlite import ir
    from numba import types
    from numba.extending import intrinsic

    @intrinsic
    def read_counter(typingctx: Any) -> Any:
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            function_type = ir.FunctionType(ir.IntType(64), [])
            counter = builder.module.declare_intrinsic("llvm.readcyclecounter", fnty=function_type)
            return builder.call(counter, [])

        return types.int64(), codegen

    def counter() -> int:
        return read_counter()  # type: ignore[call-arg]

    return cast(Callable[[], int], _njit(cache=True, nogil=True)(counter))


def _zero() -> int:
    return 0


# ``ticks()``: a clock cheap enough to read twice per sample inside the loop.
# Compiled on x86-64 it counts processor cycles (the runner converts them to
# nanoseconds against time.perf_counter_ns over the run); as plain Python it
# is time.perf_counter_ns; compiled elsewhere there is no such clock: 0.
_counter = _time_stamp_counter()
TICKS_ARE_NS = _njit is None
TICKS_TIMED = _njit is None or _counter is not None
ticks: Callable[[], int] = (
    time.perf_counter_ns
    if _njit is None
    else _counter
    if _counter is not None
    else cast(Callable[[], int], _njit(cache=True)(_zero))
)
