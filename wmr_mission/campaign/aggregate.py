"""Statistics of a campaign, gathered row by row as runs finish.

Memory grows by one float per run and metric (for the percentiles and the
figures' histograms), never by a run's trajectory: rows stream to runs.csv,
and only the few worst runs are remembered (to be re-simulated at the end).
"""

from __future__ import annotations

import heapq
import json
import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np

from wmr_mission.campaign.models import Axis
from wmr_mission.campaign.recovery import RecoveryCounts
from wmr_mission.campaign.rows import METRICS, Row

__all__ = ["WORST_RUNS", "Aggregate", "clopper_pearson"]

WORST_RUNS: Final = 5
"""Runs kept as full run directories under worst/."""

# The figure of every trajectory draws at most this many runs (all failures among them first).
DRAWN_PATHS: Final = 2000
DRAWN_FAILURES: Final = 500

_RANKING_METRIC: Final = "final_position_error"


def clopper_pearson(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval of a success probability, from ``successes``
    in ``trials``: quantiles of beta distributions (scipy's ``betaincinv``)."""
    from scipy.special import betaincinv

    if trials == 0:
        return 0.0, 1.0
    tail = (1.0 - confidence) / 2.0
    failures = trials - successes
    lo = 0.0 if successes == 0 else float(betaincinv(successes, failures + 1, tail))
    hi = 1.0 if failures == 0 else float(betaincinv(successes + 1, failures, 1.0 - tail))
    return lo, hi


def _badness(row: Row) -> tuple[int, float, int]:
    """Larger is worse: a failure before any success, then the larger final position
    error (a missing one counts as infinite), then the earlier run."""
    error = row.metrics[METRICS.index(_RANKING_METRIC)]
    return (
        0 if row.succeeded else 1,
        math.inf if error is None or not math.isfinite(error) else error,
        -row.run,
    )


def value_label(value: Any) -> str:
    """A short label of an axis value for figures: a mapping by its ``type``, if any,
    else by its values (``0.01/0.01/0.02`` for a noise_std)."""
    if isinstance(value, dict):
        if "type" in value:
            return str(value["type"])
        return "/".join(str(v) for v in value.values())
    text = value if isinstance(value, str) else json.dumps(value)
    return text if len(text) <= 24 else text[:21] + "..."


@dataclass
class Aggregate:
    """Counts, metric values, axis values and the worst runs seen so far.

    A grid or choice axis is recorded by the index of its value in the list; a
    uniform or normal one by its value.
    """

    axes: dict[str, Axis]
    outcomes: Counter[str] = field(default_factory=Counter)
    metric_values: dict[str, list[float]] = field(default_factory=dict)
    axis_values: dict[str, list[float]] = field(default_factory=dict)
    success: list[bool] = field(default_factory=list)
    worst: list[tuple[tuple[int, float, int], int, int, str, str]] = field(default_factory=list)
    drawn: list[tuple[bool, np.ndarray]] = field(default_factory=list)
    drawn_failures: int = 0
    # grid cell (index of each grid axis' value) -> [runs, successes]
    cells: dict[tuple[int, ...], list[int]] = field(default_factory=dict)
    # grid cell -> metric -> its values over the cell's runs (NaN: none)
    cell_metrics: dict[tuple[int, ...], dict[str, list[float]]] = field(default_factory=dict)
    recovery: RecoveryCounts = field(default_factory=RecoveryCounts)

    @property
    def paths(self) -> list[str]:
        return list(self.axes)

    @property
    def discrete(self) -> list[str]:
        return [path for path, axis in self.axes.items() if axis.kind in ("grid", "choice")]

    def labels(self, path: str) -> list[str]:
        axis = self.axes[path]
        return [value_label(v) for v in (axis.grid or axis.choice or [])]

    def _coordinate(self, path: str, value: Any) -> float:
        axis = self.axes[path]
        listed = axis.grid if axis.grid is not None else axis.choice
        if listed is not None:
            return float(listed.index(value))
        return float(value) if isinstance(value, int | float) else math.nan

    def add(self, row: Row) -> None:
        self.outcomes[row.outcome] += 1
        self.success.append(row.succeeded)
        self.recovery.add(row)
        for name, value in zip(METRICS, row.metrics, strict=True):
            self.metric_values.setdefault(name, []).append(math.nan if value is None else value)
        cell = []
        for path, value in zip(self.paths, row.values, strict=True):
            coordinate = self._coordinate(path, value)
            self.axis_values.setdefault(path, []).append(coordinate)
            if self.axes[path].grid is not None:
                cell.append(int(coordinate))
        counts = self.cells.setdefault(tuple(cell), [0, 0])
        counts[0] += 1
        counts[1] += row.succeeded
        in_cell = self.cell_metrics.setdefault(tuple(cell), {})
        for name, value in zip(METRICS, row.metrics, strict=True):
            in_cell.setdefault(name, []).append(math.nan if value is None else value)
        entry = (_badness(row), row.run, row.seed, row.outcome, row.reason)
        if len(self.worst) < WORST_RUNS:
            heapq.heappush(self.worst, entry)
        else:
            heapq.heappushpop(self.worst, entry)
        self._keep_path(row)

    def _keep_path(self, row: Row) -> None:
        if row.path_xy.shape[1] == 0:
            return
        if not row.succeeded and self.drawn_failures < DRAWN_FAILURES:
            self.drawn_failures += 1
            self.drawn.append((False, row.path_xy))
        elif row.succeeded and len(self.drawn) - self.drawn_failures < DRAWN_PATHS:
            self.drawn.append((True, row.path_xy))

    @property
    def runs(self) -> int:
        return len(self.success)

    @property
    def succeeded(self) -> int:
        return self.outcomes["success"]

    def worst_runs(self) -> list[tuple[int, int, str, str]]:
        """(run, seed, outcome, reason) of the worst runs, worst first."""
        ranked = sorted(self.worst, reverse=True)
        return [(run, seed, outcome, reason) for _, run, seed, outcome, reason in ranked]

    def statistics(self) -> dict[str, Any]:
        """``runs``, ``succeeded``, ``success_rate``, ``success_interval``, ``outcomes``,
        ``metrics`` (per metric: p50, p95, p99, max over the runs that have it)."""
        runs, succeeded = self.runs, self.succeeded
        lo, hi = clopper_pearson(succeeded, runs)
        metrics = _percentiles(self.metric_values)
        return {
            "runs": runs,
            "succeeded": succeeded,
            "success_rate": succeeded / runs if runs else None,
            "success_interval": [lo, hi],
            "outcomes": dict(sorted(self.outcomes.items())),
            "metrics": metrics,
            "cells": self._cell_statistics(),
            "recovery": self.recovery.statistics(clopper_pearson),
        }

    def _cell_statistics(self) -> list[dict[str, Any]]:
        """Success per grid cell, in grid order (empty without grid axes)."""
        grid = [(p, a.grid) for p, a in self.axes.items() if a.grid is not None]
        if not grid:
            return []
        table = []
        for cell, (runs, succeeded) in sorted(self.cells.items()):
            lo, hi = clopper_pearson(succeeded, runs)
            table.append(
                {
                    "values": {
                        path: values[i] for (path, values), i in zip(grid, cell, strict=True)
                    },
                    "runs": runs,
                    "succeeded": succeeded,
                    "success_rate": succeeded / runs,
                    "success_interval": [lo, hi],
                    "metrics": _percentiles(self.cell_metrics[cell]),
                }
            )
        return table


def _percentiles(metric_values: dict[str, list[float]]) -> dict[str, dict[str, float | None]]:
    """Per metric: p50, p95, p99 and max over the runs that have it."""
    metrics: dict[str, dict[str, float | None]] = {}
    for name in METRICS:
        values = np.asarray(metric_values.get(name, []), dtype=float)
        values = values[np.isfinite(values)]
        if values.size == 0:
            metrics[name] = {"p50": None, "p95": None, "p99": None, "max": None}
            continue
        p50, p95, p99 = np.percentile(values, [50, 95, 99])
        metrics[name] = {
            "p50": float(p50),
            "p95": float(p95),
            "p99": float(p99),
            "max": float(values.max()),
        }
    return metrics
