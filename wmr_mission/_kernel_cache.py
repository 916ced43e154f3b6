"""Where numba keeps the compiled kernels, and when they are stale.

numba's own cache has two gaps this closes:

* It writes beside the source (``__pycache__``) or under the user's home. An
  install by root run by another user, with no writable home (many
  containers), has neither: numba raises ``cannot cache function ...: no
  locator available`` at import. Here the first writable of
  ``$NUMBA_CACHE_DIR``, the package's ``__pycache__``, the user cache
  directory and a per-user temporary directory is used; with none, kernels
  compile on every run. Either fallback prints one line of notice.
* It judges a cached function by its own source file only, so the compiled
  loop (wmr_mission/loop.py) would keep a stale copy of a control law edited
  in wmr_mission/control.py. Here every kernel's stamp is the hash of all
  kernel modules together.
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

PACKAGE = Path(__file__).resolve().parent
# The modules holding kernels or what they call: a change to any recompiles all.
KERNEL_MODULES = (
    "_jit.py",
    "params.py",
    "model.py",
    "corrective.py",
    "riccati.py",
    "observer.py",
    "ekf.py",
    "disturbances.py",
    "control.py",
    "constrained_tracking.py",
    "loop.py",
    "scalar_math.py",
    "campaign/coverage.py",
)


def _writable(directory: Path) -> bool:
    try:
        directory.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=directory).close()
    except OSError:
        return False
    return True


def _candidates() -> list[tuple[Path, bool]]:
    """Cache directories in order of preference, each with whether using it
    deserves a notice (a temporary directory is lost on reboot)."""
    candidates = []
    configured = os.environ.get("NUMBA_CACHE_DIR")
    if configured:
        candidates.append((Path(configured) / "wmr_mission", False))
    candidates.append((PACKAGE / "__pycache__", False))
    user_cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    candidates.append((Path(user_cache) / "wmr-mission" / "numba", False))
    user = getattr(os, "getuid", lambda: "user")()
    candidates.append((Path(tempfile.gettempdir()) / f"wmr-mission-numba-{user}", True))
    return candidates


@functools.cache
def cache_directory() -> Path | None:
    """The first writable cache directory, or None; prints the notice (once:
    `run` asks before the kernels are declared, wmr_mission._jit after)."""
    for directory, notice in _candidates():
        if _writable(directory):
            if notice:
                print(
                    f"wmr-mission: no writable cache beside the package or in the home "
                    f"directory; compiled kernels are kept in {directory}",
                    file=sys.stderr,
                )
            return directory
    print(
        "wmr-mission: no writable cache directory; kernels are compiled on every run "
        "(set NUMBA_CACHE_DIR to a writable directory to keep them)",
        file=sys.stderr,
    )
    return None


def kernel_sources_stamp() -> str:
    digest = hashlib.sha256()
    for name in KERNEL_MODULES:
        digest.update((PACKAGE / name).read_bytes())
    return digest.hexdigest()


def install(directory: Path) -> bool:
    """Put a locator for this package's kernels in front of numba's own.
    False when this numba's caching internals are not the expected ones."""
    try:
        from numba.core import caching
    except ImportError:  # pragma: no cover - numba without its caching module
        return False
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    base = getattr(caching, "_CacheLocator", None)
    if impl is None or base is None or not isinstance(impl.__dict__.get("_locator_classes"), list):
        return False
    stamp = kernel_sources_stamp()

    class KernelLocator(base):  # type: ignore[misc, valid-type]
        def __init__(self, py_func: Any, py_file: str) -> None:
            # numba names the source file in its "cannot cache" warnings.
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._path = str(directory)

        def ensure_cache_path(self) -> None:
            os.makedirs(self._path, exist_ok=True)

        def get_cache_path(self) -> str:
            return self._path

        def get_source_stamp(self) -> str:
            return stamp

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> KernelLocator | None:
            module = getattr(py_func, "__module__", "") or ""
            if module.split(".")[0] != "wmr_mission":
                return None
            return cls(py_func, py_file)

    impl._locator_classes.insert(0, KernelLocator)
    return True
