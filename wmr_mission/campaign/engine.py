"""Runs of a campaign on a local process pool or a Dask cluster, rows back in run order.

Runs are batched into tasks of about half a second (timed on a run in the
parent, which also compiles the kernels once before any worker starts: the
workers are forked from it, or load numba's disk cache it wrote); the last
tasks are shorter, so that the workers finish together. At most a few tasks
per worker are in flight, and finished tasks are handed on in run order, so
memory stays flat however many runs a campaign has.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any, Final, Protocol

from wmr_mission.campaign.load import LoadedCampaign
from wmr_mission.campaign.plan import Plan
from wmr_mission.campaign.rows import Row, run_row, run_rows

__all__ = [
    "LAST_TASK_SECONDS",
    "TASK_SECONDS",
    "Interrupted",
    "MixedCluster",
    "SchedulerUnavailable",
    "StopFlag",
    "check_cluster",
    "default_workers",
    "execute",
    "local_pool",
    "task_size",
    "tasks",
    "warm_up",
]

TASK_SECONDS: Final = 0.5
"""Wall time of one task: long enough that sending it costs little, short enough
to balance the workers and to stop soon after Ctrl-C."""

LAST_TASK_SECONDS: Final = 0.05
"""Wall time of the shortest task, at the end: a worker that finishes early then
waits at most this long for the others."""

_IN_FLIGHT_PER_WORKER: Final = 3


_CONNECT_SECONDS: Final = 10


class SchedulerUnavailable(RuntimeError):
    """``--scheduler`` without Dask installed, or an address that does not answer."""


class MixedCluster(SchedulerUnavailable):
    """Dask workers that differ from this process in what decides a run's bytes."""


class Interrupted(Exception):
    """Ctrl-C during a campaign; the rows handed on so far are complete."""


class _Executor(Protocol):
    def submit(self, fn: Callable[..., list[Row]], /, *args: Any) -> Any: ...


def default_workers() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def warm_up(loaded: LoadedCampaign) -> float:
    """Compile the kernels in this process; return the seconds of one warm run."""
    plan = Plan(loaded.campaign)
    run_row(loaded, plan.draw(0))  # compiles (or loads the cache of) every kernel it uses
    started = time.perf_counter()
    run_row(loaded, plan.draw(min(1, len(plan) - 1)))
    return time.perf_counter() - started


def task_size(seconds_per_run: float, runs: int, workers: int) -> int:
    """Runs per task: about TASK_SECONDS of work, yet enough tasks to keep every worker busy."""
    by_time = max(1, round(TASK_SECONDS / max(seconds_per_run, 1e-6)))
    by_share = max(1, math.ceil(runs / (4 * workers)))
    return min(by_time, by_share)


def tasks(seconds_per_run: float, runs: int, workers: int) -> list[range]:
    """The runs of each task, in run order: :func:`task_size` runs each, then,
    once fewer runs are left than two such tasks per worker, half of a worker's
    share of what is left (no fewer than LAST_TASK_SECONDS of runs), so that the
    last tasks end together instead of one worker finishing a whole task alone."""
    size = task_size(seconds_per_run, runs, workers)
    least = min(size, max(1, round(LAST_TASK_SECONDS / max(seconds_per_run, 1e-6))))
    bounds = []
    start = 0
    while start < runs:
        share = math.ceil((runs - start) / (2 * workers))
        stop = min(runs, start + min(size, max(least, share)))
        bounds.append(range(start, stop))
        start = stop
    return bounds


def _ignore_interrupt() -> None:
    # Ctrl-C reaches the whole process group: the parent alone handles it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class StopFlag:
    """Ctrl-C, caught: set on SIGINT while active, so the campaign stops between
    tasks and keeps every finished run. A second Ctrl-C interrupts at once."""

    def __init__(self) -> None:
        self.stopped = False
        self._previous: Any = None

    def __enter__(self) -> StopFlag:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._on_interrupt)
        return self

    def __exit__(self, *_: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)

    def _on_interrupt(self, signum: int, frame: Any) -> None:
        if self.stopped:
            raise KeyboardInterrupt
        self.stopped = True


def execute(
    loaded: LoadedCampaign,
    *,
    workers: int,
    scheduler: str | None,
    seconds_per_run: float,
    stop: StopFlag,
    allow_mixed_cluster: bool = False,
) -> Iterator[list[Row]]:
    """The rows of every run, task by task, in run order.

    Once ``stop`` is set, the tasks already running finish, their rows are
    handed on (in run order, after the contiguous ones), and
    :class:`Interrupted` is raised.
    """
    runs = len(Plan(loaded.campaign))
    if scheduler is not None:
        yield from _on_dask(loaded, scheduler, seconds_per_run, runs, stop, allow_mixed_cluster)
        return
    if workers == 1:
        for task in tasks(seconds_per_run, runs, 1):
            if stop.stopped:
                raise Interrupted
            yield run_rows(loaded, task.start, task.stop)
        return
    with local_pool(workers) as pool:
        batches = tasks(seconds_per_run, runs, workers)
        yield from _in_order(pool, _wait_local, loaded, batches, workers, stop)


def local_pool(workers: int) -> ProcessPoolExecutor:
    """Worker processes forked from this one where the system can (they find the
    kernels loaded), which leave Ctrl-C to it."""
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    return ProcessPoolExecutor(workers, mp_context=context, initializer=_ignore_interrupt)


def _on_dask(
    loaded: LoadedCampaign,
    scheduler: str,
    seconds_per_run: float,
    runs: int,
    stop: StopFlag,
    allow_mixed_cluster: bool,
) -> Iterator[list[Row]]:
    try:
        from distributed import Client
    except ImportError:
        raise SchedulerUnavailable(
            "--scheduler needs Dask distributed: pip install 'wmr-mission[dask]'"
        ) from None
    try:
        client: Any = Client(scheduler, timeout=_CONNECT_SECONDS)  # type: ignore[no-untyped-call]
    except (OSError, ValueError, TimeoutError) as error:
        raise SchedulerUnavailable(
            f"cannot reach the Dask scheduler {scheduler}: {error}"
        ) from None
    with client:
        check_cluster(client, allow_mixed_cluster)
        workers = max(1, sum(client.nthreads().values()))
        batches = tasks(seconds_per_run, runs, workers)
        yield from _in_order(_DaskPool(client), _wait_dask, loaded, batches, workers, stop)


def check_cluster(client: Any, allow_mixed_cluster: bool) -> None:
    """Before the first run: every worker's versions and C math library against
    this process's (which simulates the worst runs again). Raises
    :class:`MixedCluster` naming what differs where, unless ``allow_mixed_cluster``,
    which says it in one line on stderr instead."""
    from wmr_mission.output.environment import differences, machine_record

    mine = machine_record()
    try:
        theirs = client.run(machine_record)
    except Exception as error:  # a worker that cannot import wmr_mission cannot run either
        raise SchedulerUnavailable(
            f"cannot ask the Dask workers what they run ({type(error).__name__}: {error})"
        ) from None
    found = [
        f"{worker}: {'; '.join(differ)}"
        for worker, record in sorted(theirs.items())
        if (differ := differences(mine, record))
    ]
    if not found:
        return
    what = f"{len(found)} of {len(theirs)} Dask workers differ from this machine: " + " | ".join(
        found
    )
    if not allow_mixed_cluster:
        raise MixedCluster(
            f"{what}; their rows could differ in the last digits from this machine's "
            "(docs/reliability.md): give every worker the same versions, or pass "
            "--allow-mixed-cluster"
        )
    print(f"wmr-mission: warning: {what}", file=sys.stderr)


class _DaskPool:
    """A Dask client seen as an executor; tasks are not pure (never reuse a result)."""

    def __init__(self, client: Any) -> None:
        self.client = client

    def submit(self, fn: Callable[..., list[Row]], /, *args: Any) -> Any:
        return self.client.submit(fn, *args, pure=False)


_POLL_SECONDS: Final = 0.2

Waiter = Callable[[list[Any]], list[Any]]


def _wait_local(futures: list[Any]) -> list[Any]:
    finished, _ = wait(futures, timeout=_POLL_SECONDS, return_when=FIRST_COMPLETED)
    return list(finished)


def _wait_dask(futures: list[Any]) -> list[Any]:
    from distributed import TimeoutError as DaskTimeout
    from distributed import wait as dask_wait

    try:
        finished, _ = dask_wait(  # type: ignore[no-untyped-call]
            futures, timeout=_POLL_SECONDS, return_when="FIRST_COMPLETED"
        )
    except (DaskTimeout, TimeoutError):
        return []
    return list(finished)


def _in_order(
    pool: _Executor,
    wait_some: Waiter,
    loaded: LoadedCampaign,
    batches: list[range],
    workers: int,
    stop: StopFlag,
) -> Iterator[list[Row]]:
    waiting = iter(range(len(batches)))
    pending: dict[Any, int] = {}  # future -> its task's index in ``batches``
    done: dict[int, list[Row]] = {}
    next_task = 0

    def submit() -> None:
        task = next(waiting, None)
        if task is not None:
            runs = batches[task]
            pending[pool.submit(run_rows, loaded, runs.start, runs.stop)] = task

    for _ in range(_IN_FLIGHT_PER_WORKER * workers):
        submit()
    while pending and not stop.stopped:
        for future in wait_some(list(pending)):
            done[pending.pop(future)] = future.result()
            submit()
        while next_task in done:
            yield done.pop(next_task)
            next_task += 1
    if not stop.stopped:
        return
    for future, task in pending.items():
        if not future.cancel() and _ran_to_end(future):  # was running: let it finish
            done[task] = future.result()
    for task in sorted(done):
        yield done[task]
    raise Interrupted


def _ran_to_end(future: Any) -> bool:
    try:
        future.result()
    except BaseException:
        return False
    return True
