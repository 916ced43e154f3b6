"""A process forked while another thread computes a cached value does not
wait for ever (wmr_mission.basics.cached_value).

A campaign forks its worker processes from the process that runs `sweep`;
with a Dask cluster of threads in that process, a worker thread may be judging
a run at that moment."""

from __future__ import annotations

import multiprocessing
import threading

from wmr_mission.basics import cached_value

ENTERED = threading.Event()
RELEASE = threading.Event()


class Judged:
    @cached_value
    def value(self) -> int:
        if threading.current_thread() is not threading.main_thread():
            ENTERED.set()
            RELEASE.wait(30)  # inside the computation while the fork happens
        return 7


def _child(queue: multiprocessing.Queue[int]) -> None:
    queue.put(Judged().value)


def test_a_fork_during_a_cached_computation_in_another_thread_finishes() -> None:
    judged = Judged()
    thread = threading.Thread(target=lambda: judged.value)
    thread.start()
    try:
        assert ENTERED.wait(10)
        context = multiprocessing.get_context("fork")
        queue: multiprocessing.Queue[int] = context.Queue()
        child = context.Process(target=_child, args=(queue,))
        child.start()
        child.join(20)
        alive = child.is_alive()
        if alive:
            child.kill()
        assert not alive, "the forked process waits on a lock it inherited held"
        assert queue.get(timeout=5) == 7
    finally:
        RELEASE.set()
        thread.join()
    assert judged.value == 7
    assert Judged.value.name == "value"
