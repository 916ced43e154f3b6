"""Runs of a campaign on a local process pool or a Dask cluster, rows back in run order.

Runs are batched into tasks of about half a second (timed on a run in the
parent, which also compiles the kernels once before any worker starts: the
workers are forked from it, or load numba's disk cache it wrote); the last
tasks are shorter, so that the workers finish together. At most a few tasks
per worker are in flight, and finished tasks are handed on in run order, so
memory stays flat however many runs a campaign has.
"""

from __future__ import annotations

import ctypes
import logging
import math
import multiprocessing
import os
import signal
import sys
import time
from collections.abc import Callable, Generator, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, ThreadPoolExecutor, wait
from contextlib import contextmanager
from typing import Any, Final, NamedTuple, Protocol

from wmr_mission.campaign.cores import usable_cores
from wmr_mission.campaign.load import LoadedCampaign
from wmr_mission.campaign.plan import Plan
from wmr_mission.campaign.rows import Row, run_row, run_rows
from wmr_mission.kernels import jit
from wmr_mission.stopping import StopSignals

__all__ = [
    "DASK_LOGS",
    "LAST_TASK_SECONDS",
    "TASK_SECONDS",
    "Interrupted",
    "MixedCluster",
    "SchedulerLost",
    "SchedulerUnavailable",
    "check_cluster",
    "default_workers",
    "execute",
    "local_pool",
    "one_line",
    "reach_scheduler",
    "silence",
    "task_size",
    "tasks",
    "usable_workers",
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

# The libraries whose logs a Dask client writes to stderr.
DASK_LOGS: Final = ("distributed", "tornado")


class SchedulerUnavailable(RuntimeError):
    """``--scheduler`` without Dask installed, or an address where no Dask
    scheduler answers: said before anything is written or run."""


class SchedulerLost(RuntimeError):
    """The Dask scheduler stopped answering during the runs."""


class MixedCluster(SchedulerUnavailable):
    """Dask workers that differ from this process in what decides a run's bytes."""


class Interrupted(Exception):
    """Ctrl-C during a campaign; the rows handed on so far are complete."""


class _Executor(Protocol):
    def submit(self, fn: Callable[..., list[Row]], /, *args: Any) -> Any: ...


def default_workers() -> int:
    """One worker per core this process may use (:func:`usable_cores`: its
    CPU affinity, at most its container's CPU quota)."""
    return usable_cores()


def usable_workers(requested: int | None) -> int:
    """Local worker processes for ``requested`` (None: every core), at most one
    per core this process may use: runs are pure computation, so another
    process would only wait for a core, at the cost of a fork and its memory.

    Raises TypeError or ValueError for anything but a positive integer.
    """
    if requested is None:
        return default_workers()
    if isinstance(requested, bool) or not isinstance(requested, int):
        raise TypeError(f"workers is a positive integer or None, got {requested!r}")
    if requested < 1:
        raise ValueError(f"workers is a positive integer or None, got {requested}")
    return min(requested, default_workers())


class WarmUp(NamedTuple):
    """What a campaign's warm-up found: the seconds of one warm run, and
    whether its loop ran compiled (a plug-in of plain Python objects runs it
    plain; the campaign's manifest says which)."""

    seconds_per_run: float
    loop_compiled: bool | None


def warm_up(loaded: LoadedCampaign, workers: int | None = None) -> WarmUp:
    """Compile the kernels in this process; the seconds of one warm run.

    ``workers``: the local processes the runs will take (None: none here, a
    Dask cluster). Where each of them would judge enough samples for the
    judge's compiled passes to pay (jit.JUDGED_COMPILED_FROM), they are loaded
    here too, before the workers fork: each finds them loaded instead of
    loading them itself (0.03-0.05 s) after judging its first rows with
    numpy's forms, the same bits at a higher cost (docs/performance.md)."""
    plan = Plan(loaded.campaign)
    first = run_row(loaded, plan.draw(0))  # compiles (or loads the cache of) every kernel it uses
    if workers is not None and len(plan) * first.samples >= workers * jit.JUDGED_COMPILED_FROM:
        jit.judged(jit.JUDGED_COMPILED_FROM)
        run_row(loaded, plan.draw(0))  # loads the judge's passes, outside the time
    started = time.perf_counter()
    run_row(loaded, plan.draw(min(1, len(plan) - 1)))
    return WarmUp(time.perf_counter() - started, first.loop_compiled)


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


def _start_worker(parent: int) -> None:
    """A pool worker: Ctrl-C, which reaches the whole process group, is the
    parent's to handle; SIGTERM ends it (it inherits the parent's handlers);
    and it dies with its parent, however the parent ends (even by SIGKILL)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:  # the parent ended before the line above
        os._exit(1)


_PR_SET_PDEATHSIG: Final = 1


def execute(
    loaded: LoadedCampaign,
    *,
    workers: int,
    scheduler: str | None,
    seconds_per_run: float,
    stop: StopSignals,
    allow_mixed_cluster: bool = False,
    paths: bool = True,
) -> Generator[list[Row], None, None]:
    """The rows of every run, task by task, in run order; ``paths``: whether
    they keep their paths (for the campaign's trajectory figure).

    Once ``stop`` is set, the tasks already running finish, their rows are
    handed on (in run order, after the contiguous ones), and
    :class:`Interrupted` is raised.
    """
    runs = len(Plan(loaded.campaign))
    if scheduler is not None:
        yield from _on_dask(
            loaded, scheduler, seconds_per_run, runs, stop, allow_mixed_cluster, paths
        )
        return
    if workers == 1:
        for task in tasks(seconds_per_run, runs, 1):
            if stop.stopped:
                raise Interrupted
            yield run_rows(loaded, task.start, task.stop, paths)
        return
    with local_pool(workers) as pool:
        batches = tasks(seconds_per_run, runs, workers)
        yield from _in_order(pool, _wait_local, loaded, batches, workers, stop, paths)


@contextmanager
def local_pool(workers: int, *, writes: bool = False) -> Iterator[ProcessPoolExecutor]:
    """Worker processes forked from this one where the system can (they find the
    kernels loaded), which leave Ctrl-C to it; however this process ends, none
    outlives it. Left by an exception (a second Ctrl-C, a fault), the tasks not
    started are dropped and those under way stopped at once, unless they
    ``write`` files: those finish, so that no temporary file is left."""
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    pool = ProcessPoolExecutor(
        workers, mp_context=context, initializer=_start_worker, initargs=(os.getpid(),)
    )
    try:
        yield pool
    except BaseException:
        if not writes:
            # SIGKILL, not SIGTERM: a process forked a moment ago may not have
            # run _start_worker yet, and this process's handler of SIGTERM
            # would print a traceback from it (seen as a compile failed)
            for process in list((pool._processes or {}).values()):
                process.kill()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def reach_scheduler(address: str) -> None:
    """Raise :class:`SchedulerUnavailable`, in one line, unless a Dask scheduler
    answers at ``address`` within _CONNECT_SECONDS.

    Asked before anything is written: distributed's client waits forever for a
    server that accepts and never answers (its handshake has no time limit),
    and reads an HTTP server's reply as the length of a message.
    """
    import asyncio  # here: a local sweep never pays for importing it

    try:
        from distributed.comm.core import connect
        from distributed.security import Security
    except ImportError:
        raise SchedulerUnavailable(
            "--scheduler needs Dask distributed: pip install 'wmr-mission[dask]'"
        ) from None

    async def identity() -> Any:
        arguments = Security().get_connection_args("client")  # type: ignore[no-untyped-call]
        comm = await connect(address, timeout=_CONNECT_SECONDS, **arguments)  # type: ignore[no-untyped-call]
        try:
            await comm.write({"op": "identity"})
            return await comm.read()
        finally:
            comm.abort()

    def ask() -> Any:
        return asyncio.run(asyncio.wait_for(identity(), _CONNECT_SECONDS))

    where = f"cannot use the Dask scheduler {address}"
    # In a thread of its own: the caller may be running an event loop (a notebook).
    with ThreadPoolExecutor(1) as thread:
        try:
            reply = thread.submit(ask).result()
        except TimeoutError:
            raise SchedulerUnavailable(
                f"{where}: no answer within {_CONNECT_SECONDS:g} s "
                "(the address `dask scheduler` prints, e.g. tcp://host:8786)"
            ) from None
        except Exception as error:
            if address.startswith("tls://") and isinstance(error, TypeError):
                reason = (
                    "tls:// needs certificates in dask's configuration "
                    "(distributed.comm.tls: ca-file, client.cert, client.key)"
                )
            elif isinstance(error, OSError | ValueError):  # refused, or not an address
                reason = one_line(error)
            else:  # a server of another kind: its reply read as a message's length...
                reason = f"it answers, but not as a Dask scheduler ({type(error).__name__})"
            raise SchedulerUnavailable(f"{where}: {reason}") from None
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise SchedulerUnavailable(f"{where}: it answers, but not as a Dask scheduler")


def one_line(error: BaseException) -> str:
    """An exception in one line: its type and its message's first line."""
    lines = str(error).strip().splitlines()
    return f"{type(error).__name__}: {lines[0]}" if lines else type(error).__name__


def _on_dask(
    loaded: LoadedCampaign,
    scheduler: str,
    seconds_per_run: float,
    runs: int,
    stop: StopSignals,
    allow_mixed_cluster: bool,
    paths: bool,
) -> Iterator[list[Row]]:
    try:
        from distributed import Client
    except ImportError:
        raise SchedulerUnavailable(
            "--scheduler needs Dask distributed: pip install 'wmr-mission[dask]'"
        ) from None
    restore = silence(*DASK_LOGS)
    try:
        try:
            client: Any = Client(scheduler, timeout=_CONNECT_SECONDS)  # type: ignore[no-untyped-call]
        except Exception as error:
            raise SchedulerUnavailable(
                f"cannot use the Dask scheduler {scheduler}: {one_line(error)}"
            ) from None
        with client:
            check_cluster(client, allow_mixed_cluster)
            workers = max(1, sum(client.nthreads().values()))
            batches = tasks(seconds_per_run, runs, workers)
            try:
                waiter = _dask_waiter(client, scheduler)
                yield from _in_order(
                    _DaskPool(client), waiter, loaded, batches, workers, stop, paths
                )
            except Interrupted:
                raise
            except Exception as error:
                if client.status != "running":
                    raise SchedulerLost(f"lost the Dask scheduler {scheduler}") from error
                raise
    finally:
        restore()


def silence(*names: str) -> Callable[[], None]:
    """Drop the log records of the libraries ``names``; return what restores them.

    A scheduler that dies makes distributed log dozens of lines of tracebacks,
    some of them while the client closes, after the campaign has said in one
    line what happened: the command line keeps them dropped to its end.
    """
    loggers = [
        logging.getLogger(key)
        for key in list(logging.root.manager.loggerDict)
        if any(key == name or key.startswith(f"{name}.") for name in names)
    ]
    loggers += [logging.getLogger(name) for name in names]
    kept = [(logger, logger.handlers[:], logger.propagate) for logger in loggers]
    for logger in loggers:
        logger.handlers = [logging.NullHandler()]  # none at all: logging's last resort
        logger.propagate = False

    def restore() -> None:
        for logger, handlers, propagate in kept:
            logger.handlers, logger.propagate = handlers, propagate

    return restore


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


# [s] a scheduler may have no worker (a nanny restarts a killed one within
# seconds; a cluster scaling up takes longer) before the campaign stops, its
# finished runs kept: Dask itself would wait for a worker forever.
WORKERLESS_SECONDS: Final = 60.0


def _dask_waiter(client: Any, scheduler: str) -> Waiter:
    """:func:`_wait_dask`, raising :class:`SchedulerLost` once the scheduler
    has had no worker for WORKERLESS_SECONDS (asked once a second)."""
    seen = {"workers": time.monotonic(), "asked": 0.0}

    def wait_some(futures: list[Any]) -> list[Any]:
        now = time.monotonic()
        if now - seen["asked"] >= 1.0:
            seen["asked"] = now
            if client.scheduler_info().get("workers"):
                seen["workers"] = now
            elif now - seen["workers"] >= WORKERLESS_SECONDS:
                raise SchedulerLost(
                    f"the Dask scheduler {scheduler} has had no worker for {WORKERLESS_SECONDS:g} s"
                )
        return _wait_dask(futures)

    return wait_some


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
    stop: StopSignals,
    paths: bool,
) -> Iterator[list[Row]]:
    waiting = iter(range(len(batches)))
    pending: dict[Any, int] = {}  # future -> its task's index in ``batches``
    done: dict[int, list[Row]] = {}
    next_task = 0

    def submit() -> None:
        task = next(waiting, None)
        if task is not None:
            runs = batches[task]
            pending[pool.submit(run_rows, loaded, runs.start, runs.stop, paths)] = task

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
    except (KeyboardInterrupt, SystemExit):  # a second signal: stop waiting
        raise
    except BaseException:  # failed or cancelled (Dask's cancellation is a BaseException)
        return False
    return True
