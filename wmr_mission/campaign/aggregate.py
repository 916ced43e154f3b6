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

__all__ = ["WORST_PER_FAILURE", "WORST_RUNS", "Aggregate", "Failure", "clopper_pearson"]

WORST_RUNS: Final = 5
"""Runs kept as full run directories under worst/ (more when more kinds of failure)."""
WORST_PER_FAILURE: Final = 3
"""Runs listed for each kind of failure, the worst first."""

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


def _badness(row: Row) -> tuple[int, float, float, int]:
    """Larger is worse: a failure before any success, then the smaller margin
    (wmr_mission.verdicts.check), then the larger final position error (a
    missing one counts as infinite), then the earlier run."""
    error = row.metrics[METRICS.index(_RANKING_METRIC)]
    return (
        0 if row.succeeded else 1,
        -_margin(row),
        math.inf if error is None or not math.isfinite(error) else error,
        -row.run,
    )


def _margin(row: Row) -> float:
    """The run's margin; an empty cell is -inf where an outcome or a check
    without a value sets it, +inf for a run without a check."""
    if row.margin is not None:
        return row.margin
    return -math.inf if row.margin_check else math.inf


@dataclass(frozen=True, order=True)
class Failure:
    """One way a run failed: ``kind`` the metric it missed (``speed_jump_max``)
    or, for a run that did not end, its outcome (``timeout``, ``diverged``...);
    ``severity`` orders the runs of a kind (larger is worse): how many times its
    bound the value is (its excess where the bound is 0), or for an outcome the
    final position error."""

    severity: tuple[float, float, int]
    run: int
    seed: int
    kind: str
    phase: str | None
    value: float | None
    bound: float | None
    outcome: str = field(default="", compare=False)
    reason: str = field(default="", compare=False)
    margin: float | None = field(default=None, compare=False)  # the run's (Row.margin)
    margin_check: str | None = field(default=None, compare=False)
    # the key of its bound, as summary.json has it: "min" for a lower bound (Check.side)
    side: str = field(default="max", compare=False)


def failures_of(row: Row) -> list[Failure]:
    """Each way ``row``'s run failed (one per kind, its worst); none for a success."""
    if row.succeeded:
        return []
    error = row.metrics[METRICS.index(_RANKING_METRIC)]
    error = math.inf if error is None or not math.isfinite(error) else error
    if row.outcome != "expect-failed":
        return [
            Failure(
                (error, 0.0, -row.run),
                row.run,
                row.seed,
                row.outcome,
                None,
                error,
                None,
                row.outcome,
                row.reason,
                row.margin,
                row.margin_check,
            )
        ]
    worst: dict[str, Failure] = {}
    for check in row.missed:
        kind, value, bound = check.metric, check.value, check.bound
        amount = math.inf if value is None else value
        if check.lower:  # a lower bound (clearance_min): ranked by the shortfall
            times = math.inf if value is None else bound - amount
        else:
            times = amount / bound if bound > 0 else math.inf
        failure = Failure(
            (times, amount - bound, -row.run),
            row.run,
            row.seed,
            kind,
            check.phase,
            value,
            bound,
            row.outcome,
            row.reason,
            row.margin,
            row.margin_check,
            check.side,
        )
        if kind not in worst or failure > worst[kind]:
            worst[kind] = failure
    return list(worst.values())


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
    worst: list[
        tuple[tuple[int, float, float, int], int, int, str, str, float | None, str | None]
    ] = field(default_factory=list)
    # each run's margin (-inf, +inf where runs.csv's cell is empty) and the checks setting them
    margins: list[float] = field(default_factory=list)
    margin_checks: Counter[str] = field(default_factory=Counter)
    drawn: list[tuple[bool, np.ndarray]] = field(default_factory=list)
    drawn_failures: int = 0
    # grid cell (index of each grid axis' value) -> [runs, successes]
    cells: dict[tuple[int, ...], list[int]] = field(default_factory=dict)
    # grid cell -> metric -> its values over the cell's runs (NaN: none)
    cell_metrics: dict[tuple[int, ...], dict[str, list[float]]] = field(default_factory=dict)
    recovery: RecoveryCounts = field(default_factory=RecoveryCounts)
    # kind of failure -> the runs that failed so, and the worst of them (a heap)
    failed_by: Counter[str] = field(default_factory=Counter)
    worst_by: dict[str, list[Failure]] = field(default_factory=dict)

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
        for failure in failures_of(row):
            self.failed_by[failure.kind] += 1
            kept = self.worst_by.setdefault(failure.kind, [])
            if len(kept) < WORST_PER_FAILURE:
                heapq.heappush(kept, failure)
            else:
                heapq.heappushpop(kept, failure)
        self.margins.append(_margin(row))
        if row.margin_metric:
            self.margin_checks[row.margin_metric] += 1
        entry = (
            _badness(row),
            row.run,
            row.seed,
            row.outcome,
            row.reason,
            row.margin,
            row.margin_check,
        )
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

    def worst_runs(self) -> list[tuple[int, int, str, str, float | None, str | None]]:
        """(run, seed, outcome, reason, margin, margin_check) of the worst runs: the
        worst of each kind of failure, the most frequent kind first, then the
        others by :func:`_badness` (the least margin first)."""
        ranked = sorted(self.worst, reverse=True)
        chosen = {
            f.run: (f.run, f.seed, f.outcome, f.reason, f.margin, f.margin_check)
            for f in self._leaders()
        }
        for _, run, seed, outcome, reason, margin, check in ranked:
            if len(chosen) >= WORST_RUNS:
                break
            chosen.setdefault(run, (run, seed, outcome, reason, margin, check))
        return list(chosen.values())

    def _leaders(self) -> list[Failure]:
        """The worst run of each kind of failure, the most frequent kind first."""
        return [max(self.worst_by[kind]) for kind in self.failure_kinds()]

    def failure_kinds(self) -> list[str]:
        """The kinds of failure seen, the most frequent first (then by name)."""
        return sorted(self.failed_by, key=lambda kind: (-self.failed_by[kind], kind))

    def worst_by_failure(self) -> list[tuple[str, int, list[Failure]]]:
        """Per kind of failure, the most frequent first: its runs and the worst of them."""
        return [
            (kind, self.failed_by[kind], sorted(self.worst_by[kind], reverse=True))
            for kind in self.failure_kinds()
        ]

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
            "margin": self.margin_statistics(),
        }

    def margin_statistics(self) -> dict[str, Any]:
        """The runs' margins: least, p1, p5, p50, most (over the finite ones,
        ``finite`` runs), how many runs missed (a margin below 0, -inf included)
        and of those how many have no number (``minus_inf``: a run that did not
        end, a check without a value), so that a reader of the quantiles knows
        which runs they leave out; and how many runs each check (by metric, or
        outcome) sets the margin of."""
        margins = np.asarray(self.margins, dtype=float)
        finite = margins[np.isfinite(margins)]
        quantiles: dict[str, float | None] = {"min": None, "p1": None, "p5": None, "p50": None}
        if finite.size:
            low = np.percentile(finite, [1, 5, 50])
            quantiles = {
                "min": float(finite.min()),
                "p1": float(low[0]),
                "p5": float(low[1]),
                "p50": float(low[2]),
            }
        return {
            **quantiles,
            "max": float(finite.max()) if finite.size else None,
            "finite": int(finite.size),
            "below_zero": int(np.count_nonzero(margins < 0.0)),
            "minus_inf": int(np.count_nonzero(margins == -np.inf)),
            "set_by": dict(sorted(self.margin_checks.items(), key=lambda kv: (-kv[1], kv[0]))),
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
