"""The compiled loops the suite runs, compiled into the session's kernel cache
before the tests start, in one process per test worker side by side.

Left to the tests, each worker compiles a loop the first time one of its
tests runs it (10-25 s of CPU each), and with `-n auto` both workers often
reach the same one at the same time and both pay for it: numba's cache takes
no lock, so neither knows the other is compiling. Here the built-in loops
(every built-in estimator with every built-in controller, as ``wmr-mission
compile`` compiles them) are shared out over the processes; the workers then
load them from the cache.

numba's cache writes an entry as: read the function's index, add the entry,
write the index, write the entry's file. The loops of every estimator and
controller are entries of one function (wmr_mission.kernels.loop.run_segment),
so two processes saving at once could each lose the other's entry from the
index, or both number their entry's file alike. The save is made one at a
time here, under a lock on a file beside the kernels (the compiling itself,
the minutes, still runs side by side).

Once every process has compiled its share, the cache holds what ``wmr-mission
compile`` puts in it, and gets its ready marker as after that command: the
tests' commands then load the compiled loop where a user's would after it
(`run` of a mission over 5 500 samples compiled, not as plain Python: the
commands of docs/tutorial.md, tests/test_tutorial.py, 35 s of CPU as plain
Python, 12 s so).

:func:`compile_all` starts the processes (tests/conftest.py), each
``python tests/compile_first.py SHARE SHARES``.
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

LOCK = "compile-first.lock"


@contextmanager
def _locked(path: Any) -> Iterator[None]:
    with open(path, "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(held, fcntl.LOCK_UN)


def _save_one_at_a_time(directory: Any) -> None:
    from numba.core.caching import IndexDataCacheFile

    save = IndexDataCacheFile.save

    def locked_save(self: Any, key: Any, data: Any) -> None:
        with _locked(directory / LOCK):
            save(self, key, data)

    IndexDataCacheFile.save = locked_save  # type: ignore[method-assign]


def compile_share(share: int, shares: int) -> None:
    """Compile every ``shares``-th built-in loop from the ``share``-th, each
    run once with the EKF band's replay; the first share also judges a run
    (the judge's kernels take no variant)."""
    from wmr_mission.commands.compile import warm_up_missions
    from wmr_mission.kernels import cache, jit
    from wmr_mission.output.covariance import estimate_std
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.verdicts.metrics import judge

    directory = cache.cache_directory()
    if directory is None or not jit.load():
        return
    _save_one_at_a_time(directory)
    for mission in warm_up_missions()[share::shares]:
        result = run_mission(plan_mission(mission))
        result.mission = mission.model_dump(mode="json")
        estimate_std(result)
    if share == 0:
        jit.judged(jit.JUDGED_COMPILED_FROM)  # its passes compiled, as compile_kernels has them
        judge(result, result.mission)


def compile_all(shares: int, env: dict[str, str]) -> str:
    """Every built-in loop compiled in ``shares`` processes side by side, in
    ``env``; then the cache's ready marker. What the processes that failed
    said (no marker then), or ""."""
    from wmr_mission.kernels import cache

    # Read before compiling: sources edited meanwhile leave a stale marker,
    # never a wrong one (as `wmr-mission compile`).
    directory, stamp = cache.cache_directory(), cache.ready_stamp()
    processes = [
        subprocess.Popen(
            [sys.executable, __file__, str(share), str(shares)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        for share in range(shares)
    ]
    failed = []
    for process in processes:
        _, stderr = process.communicate()
        if process.returncode != 0:
            failed.append(stderr)
    if directory is not None and not failed:
        partial = directory / f"{cache.READY}.{os.getpid()}"
        partial.write_text(stamp)
        os.replace(partial, directory / cache.READY)
    return "\n".join(failed)


if __name__ == "__main__":
    compile_share(int(sys.argv[1]), int(sys.argv[2]))
