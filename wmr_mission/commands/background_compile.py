"""The first runs after an install: plain Python while the kernels compile aside.

Compiling the loop's kernels takes about 20 s; a case study runs as plain
Python (the same source, the same bytes: wmr_mission.kernels.jit) in about a second.
So while the compiled kernels are not in the cache, ``wmr-mission run`` runs a
mission whose sample budget plain Python gets through sooner than a compile
(:data:`PLAIN_PYTHON_SAMPLES`) as plain Python, and starts this module as one
detached process at low priority::

    python -m wmr_mission.commands.background_compile

It compiles the kernels into the cache (wmr_mission.kernels.cache) by running
a tiny mission, then writes a ready marker holding the kernels' source stamp (and the
Python and numba versions):
the runs after it load the compiled loop. A lock file lets one such process
run at a time. A longer mission compiles in the foreground, with a notice.
The library's ``run_mission``, ``bench`` and ``sweep`` always compile in the
foreground. ``WMR_MISSION_FOREGROUND_COMPILE=1`` makes ``run`` do so too (the
test suite sets it: no process outlives a test).
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from wmr_mission.kernels import cache, jit

if TYPE_CHECKING:
    from wmr_mission.spec.models import Mission

# As plain Python the example missions take 0.1-0.9 ms per sample (`python
# benchmarks/measure.py plain`), a compile of the loop 20-30 s: up to this
# sample budget plain Python finishes about as soon even where every sample
# is its slowest.
PLAIN_PYTHON_SAMPLES = 30_000
READY = "kernels-ready"
LOCK = "compiling.lock"
FOREGROUND = "WMR_MISSION_FOREGROUND_COMPILE"
NO_JIT = jit.NO_JIT

# A short run per built-in estimator and controller compiles what any mission
# runs: the loop's argument types depend on the mission only through those
# (tests/test_start_up.py), and the only other compiled function Python
# calls, the math of paths (wmr_mission.kernels.scalar_math), has one argument
# type, whatever the function: the sine here compiles it.
WARM_UP_MISSION = b"""
version: 1
name: warm-up
robot: {dt: 0.01, limits: {v: 1, omega: 2}}
estimator: {type: constrained-observer}
regions:
  field: {type: ellipse, center: [0, 0], semi_axes: [5, 3]}
  far: {type: ellipse, center: [50, 0], semi_axes: [1, 1]}
phases:
  - name: track
    track: {path: {type: expression, x: "0.1*t", y: "0.01*sin(t)"}}
    constraints: [{stay_inside: field}]
    until: {reaches: far}
    timeout: 0.05
  - name: park
    regulate: {target: {x: 0, y: 0, theta: 0}}
    constraints: [{stay_inside: field}]
    until: {elapsed: 0.05}
"""


def ready_stamp() -> str:
    """What the ready marker holds: what numba's cache entries depend on, the
    kernels' sources, the interpreter and numba's version."""
    from importlib import metadata  # loaded already by pydantic

    try:
        numba = metadata.version("numba")
    except metadata.PackageNotFoundError:  # installed without its metadata
        numba = "unknown"
    stamp = cache.kernel_sources_stamp()
    return f"{stamp} {sys.implementation.cache_tag} numba-{numba}"


def _ready(directory: Path) -> bool:
    try:
        return (directory / READY).read_text() == ready_stamp()
    except (OSError, ValueError):  # unreadable or not text: not ready
        return False


def prepare(max_samples: int) -> str | None:
    """Called by ``run`` before the loop is loaded: chooses plain Python for
    this run and starts the background compile when the compiled loop is not in
    the cache and ``max_samples`` is short enough. Returns the line of notice
    to print, or None (the compiled loop, cached: nothing to say)."""
    if (
        jit.loaded()  # compiled already (a library caller)
        or os.environ.get(FOREGROUND, "") not in ("", "0")
        or not jit.compiling()  # WMR_MISSION_NO_JIT=1, or no numba
        or os.name != "posix"  # a detached low-priority process with a lock
    ):
        return None
    directory = cache.cache_directory()
    if directory is not None and _ready(directory):
        return None
    if max_samples > PLAIN_PYTHON_SAMPLES:
        if directory is None:  # compiled on every run: wmr_mission.kernels.cache said so
            return None
        return (
            "wmr-mission: compiling the simulation loop for this long mission "
            "(about 20 s, once: later runs load it from the cache)"
        )
    jit.choose_plain_python()
    if directory is None:
        return "wmr-mission: running as plain Python: no cache to keep a compiled loop in"
    _start()
    return (
        "wmr-mission: running as plain Python while the simulation loop compiles "
        "in the background for the next runs"
    )


def foreground_notice() -> str | None:
    """The line a library call prints before it loads the compiled loop when the
    cache is not known to hold it (no ready marker): a compile of about 20 s
    then. None when the loop is loaded already, or nothing is compiled."""
    if jit.loaded() or not jit.compiling():
        return None
    directory = cache.cache_directory()
    if directory is not None and _ready(directory):
        return None
    return (
        "wmr-mission: loading the simulation loop, compiled first if it is not in the "
        "cache (about 20 s, once: later runs load it)"
    )


def _start() -> None:
    """Start ``python -m wmr_mission.commands.background_compile``, detached: it
    outlives this run and its output goes nowhere."""
    # No process to spare: the next run tries again.
    with contextlib.suppress(OSError):
        subprocess.Popen(
            # -P: the installed package, never a wmr_mission/ in the working directory
            [sys.executable, "-P", "-m", "wmr_mission.commands.background_compile"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )


def warm_up_missions() -> list[Mission]:
    """The warm-up mission with each built-in estimator and controller: the
    compiled loop is specialised to the types of their tuning records
    (wmr_mission.kernels.variants), every other argument type is the same for
    every mission."""
    from wmr_mission.controllers import CONTROLLERS
    from wmr_mission.estimators import ESTIMATORS
    from wmr_mission.fields import type_name
    from wmr_mission.spec.loader import Override, check_mission_bytes

    # A plug-in's loop is compiled for the user's code, never cached: none here.
    estimators = [type_name(e.settings) for e in ESTIMATORS if not e.plugin]
    controllers = [type_name(c.settings) for c in CONTROLLERS if not c.plugin]
    missions = []
    for estimator in estimators:
        for controller in controllers:
            overrides = [
                Override(("estimator", "type"), estimator, f"estimator.type={estimator}"),
                Override(("controller", "type"), controller, f"controller.type={controller}"),
            ]
            mission, diagnostics = check_mission_bytes(WARM_UP_MISSION, "warm-up.yaml", overrides)
            assert mission is not None, diagnostics
            missions.append(mission)
    return missions


def compile_kernels() -> None:
    """Compile every kernel the loop runs into the cache, and the EKF band's replay."""
    from wmr_mission.output.covariance import estimate_std
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission

    for mission in warm_up_missions():
        result = run_mission(plan_mission(mission))  # compiled: not judged, no metrics loaded
        result.mission = mission.model_dump(mode="json")
        estimate_std(result)  # the EKF band's replay, for the estimation figure


def main() -> int:
    """Compile into the cache and mark it ready; 0 also when another process
    holds the lock (it does the work), 1 when there is no cache to write."""
    import fcntl

    if hasattr(os, "nice"):
        os.nice(19)
    directory = cache.cache_directory()
    if directory is None:
        return 1
    with open(directory / LOCK, "a") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return 0
        if _ready(directory):
            return 0
        # The stamp of the sources compiled, read before: an edit meanwhile
        # leaves a stale marker, never a wrong one.
        stamp = ready_stamp()
        compile_kernels()
        partial = directory / f"{READY}.{os.getpid()}"
        partial.write_text(stamp)
        os.replace(partial, directory / READY)
    return 0


if __name__ == "__main__":
    sys.exit(main())
