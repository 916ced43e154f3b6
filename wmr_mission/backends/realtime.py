"""The wall-clock pace of a real-time run: a tick every dt, deadline misses
counted, the command latency measured (summary.json's ``realtime``)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np


class Pace:
    """Ticks every ``dt`` seconds of wall clock.

    A sample whose work ends after its deadline (the next tick) is a miss: the
    schedule starts again from then, without a burst of late ticks to catch up,
    so one slow step is one miss and the samples after it keep their period."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.misses = 0
        self.tick = time.perf_counter()
        self._next = self.tick + dt
        self._latencies: list[float] = []

    def start(self) -> None:
        self.tick = time.perf_counter()
        self._next = self.tick + self.dt

    def wait(self) -> None:
        """Until the next tick; a miss counted if it has already passed."""
        now = time.perf_counter()
        if now > self._next:
            self.misses += 1
            self._next = now
        else:
            time.sleep(self._next - now)
        self.tick = time.perf_counter()
        self._next += self.dt

    def commanded(self) -> None:
        """A command went out: its latency is the time since the tick (the
        measurement read, the estimator and the controller run)."""
        self._latencies.append(time.perf_counter() - self.tick)

    def record(self) -> dict[str, Any]:
        """``deadline_misses``, ``commands`` and ``latency_ms: {p50, p99}``."""
        latencies = np.asarray(self._latencies) * 1e3
        p50, p99 = (
            (round(float(np.percentile(latencies, q)), 4) for q in (50, 99))
            if latencies.size
            else (None, None)
        )
        return {
            "deadline_misses": self.misses,
            "commands": int(latencies.size),
            "latency_ms": {"p50": p50, "p99": p99},
        }
