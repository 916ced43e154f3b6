"""Where numba keeps the compiled kernels, and when they are stale.

numba caches a compiled function beside its source (``__pycache__``) or in
the user's home, and judges it by its own source file. Both fall short here,
and both are closed by one public setting: the directory numba caches in,
``NUMBA_CACHE_DIR``, chosen here and set before numba loads.

* An install by root run by another user, with no writable home (many
  containers), has neither place: numba raises ``cannot cache function ...:
  no locator available``. Here the first writable of ``$NUMBA_CACHE_DIR``,
  the package's ``__pycache__``, the user cache directory and a per-user
  temporary directory is used; with none, kernels compile on every run.
  Either fallback prints one line of notice.
* Judged by its own source file, the compiled loop (wmr_mission/kernels/loop.py)
  would keep a stale copy of a control law edited in wmr_mission/controllers/paper.py.
  Here the directory is named after the hash of all kernel modules together:
  an edit to any of them is a new directory, compiled afresh, and the
  directories of earlier sources are removed.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

from wmr_mission.version import installed_version

PACKAGE = Path(__file__).resolve().parent.parent
# The modules holding kernels or what they call: every module of the packages
# of kernels, estimators and controllers (a new one is counted as it is
# added), the campaign's pixel counts, the EKF band's replay and the judge's
# distance to the path, places on it and passes over a phase's samples. A
# change to any recompiles all.
KERNEL_PACKAGES = ("kernels", "estimators", "controllers")
KERNEL_MODULES = (
    *sorted(
        path.relative_to(PACKAGE).as_posix()
        for package in KERNEL_PACKAGES
        for path in (PACKAGE / package).glob("*.py")
    ),
    "campaign/coverage.py",
    "output/covariance.py",
    "verdicts/passes.py",
    "verdicts/path_distance.py",
    "verdicts/placing.py",
)
# What the kernels' directories are called: this prefix, then their sources' stamp.
PREFIX = "kernels-"


def kernel_sources_stamp() -> str:
    digest = hashlib.sha256()
    for name in KERNEL_MODULES:
        digest.update((PACKAGE / name).read_bytes())
    return digest.hexdigest()


def _name() -> str:
    return PREFIX + kernel_sources_stamp()[:16]


# The marker ``wmr-mission compile`` leaves in the kernels' directory once
# every variant of the loop is in it (wmr_mission.commands.compile).
READY = "kernels-ready"


def ready_stamp() -> str:
    """What the ready marker holds: what numba's cache entries depend on, the
    kernels' sources, the interpreter and numba's version."""
    numba = installed_version("numba") or "unknown"  # "unknown": installed without its metadata
    return f"{kernel_sources_stamp()} {sys.implementation.cache_tag} numba-{numba}"


def is_ready(directory: Path) -> bool:
    """Whether ``directory`` holds a ready marker of these kernels."""
    try:
        return (directory / READY).read_text() == ready_stamp()
    except (OSError, ValueError):  # unreadable or not text: not ready
        return False


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
    name = _name()
    candidates = []
    configured = os.environ.get("NUMBA_CACHE_DIR")
    if configured:
        # The choice of the process that started this one (a sweep's
        # worker) is taken as it is.
        chosen = Path(configured)
        candidates.append((chosen if chosen.name == name else chosen / "wmr_mission" / name, False))
    candidates.append((PACKAGE / "__pycache__" / name, False))
    user_cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    candidates.append((Path(user_cache) / "wmr-mission" / "numba" / name, False))
    user = getattr(os, "getuid", lambda: "user")()
    candidates.append((Path(tempfile.gettempdir()) / f"wmr-mission-numba-{user}" / name, True))
    return candidates


@functools.cache
def cache_directory() -> Path | None:
    """The first writable cache directory, or None; prints the notice (once:
    `run` asks before the kernels are declared, wmr_mission.kernels.jit after)."""
    for directory, notice in _candidates():
        fresh = not directory.exists()
        if _writable(directory):
            if fresh:
                _remove_earlier(directory)
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


def _remove_earlier(directory: Path) -> None:
    """Remove the kernels compiled from earlier sources beside ``directory``
    (numba takes a missing cache file as one not yet written)."""
    for sibling in directory.parent.glob(PREFIX + "*"):
        if sibling != directory:
            shutil.rmtree(sibling, ignore_errors=True)


def point_numba_at(directory: Path) -> None:
    """Make ``directory`` numba's cache: ``NUMBA_CACHE_DIR``, read by numba as
    it loads (and again before each compile), and inherited by the processes
    this one starts."""
    os.environ["NUMBA_CACHE_DIR"] = str(directory)
    if "numba" in sys.modules:  # loaded before this package: read the setting now
        from numba.core.config import reload_config

        reload_config()  # type: ignore[no-untyped-call]
