"""Memory a long run gives back to the system once it no longer needs it.

* **The compiler's code.** Loading numba and a cached loop runs much of
  LLVM, and the pages of ``libllvmlite.so`` it ran stay in the process's
  resident set, about 68 MB (docs/performance.md, "Long missions"), though a
  run calls none of them again. They are read-only pages of the file, never
  written: told with ``madvise(MADV_DONTNEED)`` that they are not needed,
  the kernel unmaps them, and reads them back from the file (its page
  cache) should the compiler run again, a later compile in the same
  process. A mapping holding a page of its own (``Anonymous`` in
  ``/proc/self/smaps``: relocated data) is left as it is. Given back once
  the loop is loaded, and again before a long run's figures: the judge's
  compiled passes, loaded from the cache, run LLVM and read some back.
* **The heap's free pages.** The C library keeps what a run's arrays freed
  for its next allocations; ``malloc_trim`` returns the free pages (the
  judge's temporaries, before the figures are drawn; a figure's, drawn).

Linux and its C library only; elsewhere nothing is done.
"""

from __future__ import annotations

import ctypes
import gc
import sys
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

# Samples (a mission's budget, a run's record) from which a run gives memory
# back: a record of 14 MB or more. Below, the 12 ms of CPU that reading the
# process's mappings costs, or the 60-90 ms of a full garbage collection, would not pay.
LONG_RUN = 100_000
_COMPILER = "/libllvmlite"
_MADV_DONTNEED = 4  # Linux's value


def _libc() -> Any:
    """The C library's functions (None where it is not Linux's)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True)
    except OSError:  # pragma: no cover - a Linux without a C library to load
        return None


def give_back_compiler_pages(library: str = _COMPILER) -> int:
    """Unmap the read-only file pages of the compiler (``library``: a part of
    its path); the bytes of the mappings given back. Reading the mappings
    costs 7-12 ms: for long runs only (LONG_RUN)."""
    libc = _libc()
    if libc is None:
        return 0
    try:
        with open("/proc/self/smaps", encoding="ascii", errors="replace") as lines:
            spans = read_only_spans(lines, library)
        madvise = libc.madvise
    except (OSError, AttributeError):
        return 0
    madvise.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int)
    given = 0
    for start, end in spans:
        if madvise(start, end - start, _MADV_DONTNEED) == 0:
            given += end - start
    return given


def read_only_spans(lines: Iterable[str], library: str) -> list[tuple[int, int]]:
    """(start, end) of each mapping of a file whose path holds ``library``
    that cannot be written and holds no page of its own (``/proc/self/smaps``)."""
    spans: list[tuple[int, int]] = []
    current: tuple[int, int] | None = None
    for line in lines:
        fields = line.split()
        if not fields:
            continue
        if not fields[0].endswith(":"):  # a mapping's first line: range, mode, ..., path
            current = None
            path = " ".join(fields[5:])  # a path may hold spaces
            if path and library in path and "w" not in fields[1]:
                start, end = (int(bound, 16) for bound in fields[0].split("-"))
                current = (start, end)
        elif fields[0] == "Anonymous:" and current is not None:
            if int(fields[1]) == 0:
                spans.append(current)
            current = None
    return spans


def give_back_freed_heap() -> None:
    """Collect the garbage, and return the heap's free pages to the system."""
    gc.collect()
    libc = _libc()
    trim = getattr(libc, "malloc_trim", None)  # glibc's: not in musl
    if trim is not None:
        trim(0)


@contextmanager
def collecting_new_objects_only() -> Iterator[None]:
    """Within, garbage collections pass over the objects alive at entry
    (``gc.freeze``): those of numba, pydantic and the run live on, and a
    collection among a long run's figures costs what the figures made, not
    the 60-90 ms of looking at them all."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
