"""Where the suite's time goes: each test's CPU, its subprocesses' and numba's
compiles, for docs/performance.md ("The test suite").

    export NUMBA_CACHE_DIR=$(mktemp -d) SUITE_COSTS=/tmp/costs
    /usr/bin/time -v pytest -n auto -p suite_costs
    python tests/suite_costs.py /tmp/costs

The plug-in (``-p suite_costs``) appends a line of JSON per test to
``$SUITE_COSTS-WORKER.jsonl``: its wall time, the CPU of its process
(``getrusage``, user and system) and of the processes it waited for, and the
CPU of each compile numba made for it (its ``numba:compile`` events, the
outermost ones). The script sums them by file, costliest first. Neither is
part of a test run unless named.
"""

from __future__ import annotations

import collections
import glob
import json
import os
import resource
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

_compiles: list[tuple[str, float]] = []  # (function, CPU seconds), outermost compiles
_open: list[float] = []  # the CPU clock at each compile's start, innermost last
_listening: list[bool] = []


def _listen() -> None:
    """Listen to numba's compiles, once numba is loaded (not before: the
    package chooses numba's cache directory as it loads it,
    wmr_mission.kernels.cache)."""
    if _listening or "numba" not in sys.modules:
        return
    from numba.core import event

    class Compiles(event.Listener):  # type: ignore[misc]
        def on_start(self, record: Any) -> None:
            _open.append(time.process_time())

        def on_end(self, record: Any) -> None:
            started = _open.pop()
            if not _open:
                function = getattr(record.data["dispatcher"], "py_func", None)
                name = getattr(function, "__qualname__", "?")
                _compiles.append((name, time.process_time() - started))

    event.register("numba:compile", Compiles())
    _listening.append(True)


def pytest_configure(config: pytest.Config) -> None:
    """Listen from the moment the package loads numba, its first compile included."""
    from wmr_mission.kernels import jit

    load = jit._load

    def loading_and_listening() -> bool:
        loaded = load()
        if loaded:
            _listen()
        return loaded

    jit._load = loading_and_listening


def _cpu() -> tuple[float, float]:
    own = resource.getrusage(resource.RUSAGE_SELF)
    theirs = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, theirs.ru_utime + theirs.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item) -> Iterator[None]:
    _listen()
    compiled = len(_compiles)
    own, theirs = _cpu()
    started = time.perf_counter()
    yield
    wall = time.perf_counter() - started
    _listen()  # numba loaded by other means than the package
    own_after, theirs_after = _cpu()
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    line = {
        "test": item.nodeid,
        "worker": worker,
        "wall": wall,
        "cpu": own_after - own,
        "subprocesses": theirs_after - theirs,
        "compiles": _compiles[compiled:],
    }
    with open(f"{os.environ.get('SUITE_COSTS', 'suite-costs')}-{worker}.jsonl", "a") as out:
        out.write(json.dumps(line) + "\n")


def summary(prefix: str) -> None:
    """The costs by file, costliest first, and the compiles by function."""
    tests = [
        json.loads(line)
        for path in glob.glob(f"{prefix}-*.jsonl")
        for line in Path(path).read_text(encoding="utf-8").splitlines()
    ]
    files: dict[str, list[float]] = collections.defaultdict(lambda: [0, 0.0, 0.0, 0.0])
    functions: dict[str, list[float]] = collections.defaultdict(lambda: [0, 0.0])
    for test in tests:
        row = files[test["test"].split("::")[0]]
        row[0] += 1
        row[1] += test["cpu"]
        row[2] += test["subprocesses"]
        for name, seconds in test["compiles"]:
            row[3] += seconds
            functions[name][0] += 1
            functions[name][1] += seconds
    print(f"{'file':40s} {'tests':>5s} {'CPU s':>7s} {'theirs':>7s} {'compiles':>8s}")
    for name, (count, cpu, theirs, compiles) in sorted(
        files.items(), key=lambda f: -f[1][1] - f[1][2]
    ):
        print(f"{name:40s} {count:5.0f} {cpu:7.1f} {theirs:7.1f} {compiles:8.1f}")
    cpu = sum(row[1] for row in files.values())
    theirs = sum(row[2] for row in files.values())
    print(f"{len(tests)} tests: {cpu:.0f} s of CPU, {theirs:.0f} s in their subprocesses")
    for name, (count, seconds) in sorted(functions.items(), key=lambda f: -f[1][1]):
        print(f"  compiled {name}: {count:.0f} time(s), {seconds:.1f} s of CPU")


if __name__ == "__main__":
    summary(sys.argv[1])
