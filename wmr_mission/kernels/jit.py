"""Optional compilation of the per-sample kernels.

Every kernel is written once, in the subset of Python that numba compiles. When
numba is missing, or ``WMR_MISSION_NO_JIT=1`` is set, the very same functions
run as plain Python: slower, same equations. Compiled kernels are cached on
disk where a directory can be written (wmr_mission.kernels.cache).
"""

from __future__ import annotations

import importlib.util
import os
import platform
import time
import types
from collections.abc import Callable
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])

_DISABLED = os.environ.get("WMR_MISSION_NO_JIT", "") not in ("", "0")

# With Intel's short vector math library installed (icc_rt), numba would
# vectorise loops of math functions with it: results chosen by the CPU's SIMD
# level (wmr_mission.kernels.scalar_math). Read by numba at import.
os.environ["NUMBA_DISABLE_INTEL_SVML"] = "1"

_njit: Callable[..., Any] | None = None
_CACHED = False
if not _DISABLED and importlib.util.find_spec("numba") is not None:
    from wmr_mission.kernels import cache

    _directory = cache.cache_directory()
    if _directory is not None:  # before numba loads: it reads its cache directory then
        cache.point_numba_at(_directory)
        _CACHED = True
    try:
        import numba

        _njit = numba.njit
    except ImportError:  # pragma: no cover - a numba that cannot load (another numpy)
        _njit = None

COMPILED = _njit is not None


def _compile(fn: F, **options: Any) -> F:
    assert _njit is not None
    if _CACHED:
        try:
            return cast(F, _njit(cache=True, **options)(fn))
        except RuntimeError:  # no cache locator after all: compile uncached
            pass
    return cast(F, _njit(**options)(fn))


def kernel(fn: F) -> F:
    """Compile ``fn`` with numba (cached on disk) when available; else return it as is."""
    if _njit is None:
        return fn
    # error_model="numpy": a division by zero gives inf or nan, as in the
    # pure-Python build, never a Python exception out of the compiled loop;
    # the runner reports a non-finite input or state as a divergence.
    return _compile(fn, nogil=True, error_model="numpy")


def inlined(fn: F) -> F:
    """:func:`kernel`, compiled into each compiled function that calls it
    (numba's ``inline="always"``) instead of called there: for the kernels the
    loop runs once per sample with whole records (a phase, the controller, the
    estimator), which cost more to pass, tens of machine words each, than much
    of their work (docs/performance.md). From Python it is called like any
    kernel."""
    if _njit is None:
        return fn
    return _compile(fn, nogil=True, error_model="numpy", inline="always")


def plain(function: F, _made: dict[int, Any] | None = None) -> F:
    """The plain-Python form of a kernel, calling the plain-Python form of the
    kernels it calls: the same bytes, and no compiled entry loaded from the
    cache (each costs tens of milliseconds) for a call made once per run."""
    source = getattr(function, "py_func", None)
    if source is None:
        return function
    made = {} if _made is None else _made
    if id(function) not in made:
        namespace = dict(source.__globals__)
        made[id(function)] = types.FunctionType(
            source.__code__, namespace, source.__name__, source.__defaults__, source.__closure__
        )
        for name, value in namespace.items():
            if hasattr(value, "py_func"):
                namespace[name] = plain(value, made)
    return cast(F, made[id(function)])


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

    return _compile(counter, nogil=True)


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
    time.perf_counter_ns if _njit is None else _counter if _counter is not None else _compile(_zero)
)


def uncounted(fn: F) -> F:
    """:func:`kernel` without numba's reference counting (``_nrt=False``,
    an option numba accepts though it documents it only for its developers),
    for the loop: it allocates nothing, and the arrays it is handed stay
    held by its Python caller for the call. Each array then reaches the
    kernels it calls uncounted, so no call pays atomic count updates for
    the records it passes (docs/performance.md)."""
    if _njit is None:
        return fn
    if not _accepts_nrt_option():  # a numba without the option: counted, still correct
        return kernel(fn)
    return _compile(fn, nogil=True, error_model="numpy", _nrt=False)


def _accepts_nrt_option() -> bool:
    """Whether this numba knows ``_nrt``: an unknown option would only fail at
    the first call, as a KeyError out of the compiler."""
    try:
        from numba.core.cpu import CPUTargetOptions
    except ImportError:  # pragma: no cover - a numba without its CPU target module
        return False
    return hasattr(CPUTargetOptions, "_nrt")
