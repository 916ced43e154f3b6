"""Optional compilation of the per-sample kernels.

Every kernel is written once, in the subset of Python that numba compiles. When
numba is missing, or ``WMR_MISSION_NO_JIT=1`` is set, the very same functions
run as plain Python: slower, same equations.
"""

from __future__ import annotations

import os
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
    # error_model="numpy": a division by zero gives inf or nan, as in the
    # pure-Python build, never a Python exception out of the compiled loop;
    # the runner reports a non-finite input or state as a divergence.
    return cast(F, _njit(cache=True, nogil=True, error_model="numpy")(fn))
