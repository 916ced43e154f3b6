"""One point of the search as a campaign run, and batches of them on the campaign engine.

Evaluation i is the campaign's mission with the point's values set and the
sensor seed drawn from ``SeedSequence(seed, spawn_key=(0, i))``: it depends on
nothing else, so a batch split between workers, or sent to Dask, gives the
same evaluations, handed back in evaluation order, never in the order they end.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from wmr_mission.campaign.engine import Interrupted, local_pool
from wmr_mission.campaign.load import LoadedCampaign
from wmr_mission.campaign.plan import Draw
from wmr_mission.campaign.rows import ERROR, INVALID
from wmr_mission.campaign.written import written_runs
from wmr_mission.record import Outcome
from wmr_mission.stopping import StopSignals

__all__ = [
    "PENALTY",
    "Evaluation",
    "Evaluator",
    "Stopped",
    "check_names",
    "evaluate",
    "evaluate_draws",
    "evaluation_seed",
]

PENALTY: Final = 1e3
"""What the search is told for a run that cannot fail (no check: margin +inf)
or was not run (invalid values, an internal error), and, negated, for a run
that failed otherwise than by a check (a timeout, a divergence: margin -inf):
margins of checks lie within a few units of 0."""


def evaluation_seed(seed: int, evaluation: int) -> int:
    """The sensor seed of evaluation ``evaluation`` of a search seeded by ``seed``."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0, evaluation)))
    return int(rng.integers(2**32, dtype=np.uint64))


@dataclass(frozen=True)
class Evaluation:
    """One run of the search: its index, sensor seed, values and margins."""

    index: int
    seed: int
    values: dict[str, Any]
    outcome: str
    margin: float  # the run's (summary.json's), -inf / +inf where it has no number
    margin_check: str | None
    objective: float  # what the search minimises: the margin, or one check's
    reason: str
    # how its loop ran (RunRecord.loop_compiled; None: not run): the manifest says so
    loop_compiled: bool | None = None

    @property
    def ran(self) -> bool:
        return self.outcome not in (INVALID, ERROR)

    @property
    def falsified(self) -> bool:
        """The run fails, as ``wmr-mission run`` would judge it: any outcome but a
        success (a missed check of any phase, a timeout, ...), whatever the
        search minimises. ``--objective`` only steers the search: a run that
        misses another check is still a counterexample."""
        return self.ran and (self.outcome != Outcome.success.value or self.margin < 0)

    def told(self) -> float:
        """The objective as the search is told it: finite."""
        if not self.ran:
            return PENALTY
        return min(max(self.objective, -PENALTY), PENALTY)


def evaluate(loaded: LoadedCampaign, draw: Draw, objective: str | None) -> Evaluation:
    """The run of ``draw``, simulated and judged as a campaign's row is
    (``wmr_mission.campaign.rows.run_row``): checked and planned once per
    combination of the choice values, its drawn pose written into the plan
    (``wmr_mission.campaign.written``), reduced to its margins."""
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.verdicts.metrics import judge_run_metrics

    plan, record, reason = written_runs(loaded).run(draw)
    if plan is None:
        return Evaluation(
            draw.run, draw.seed, draw.values, INVALID, math.inf, INVALID, math.inf, reason
        )
    result = run_mission(plan)
    if result.outcome is Outcome.interrupted:  # a stop ends the search, never a run
        raise KeyboardInterrupt
    summary = judge_run_metrics(result, record)
    check = summary["margin_check"]
    margin = summary["margin"]
    if margin is None:
        margin = -math.inf if check is not None else math.inf
    value = margin if objective is None else _check_margin(result, record, objective)
    reason = "" if result.outcome is Outcome.success else result.message
    return Evaluation(
        draw.run,
        draw.seed,
        draw.values,
        result.outcome.value,
        margin,
        check,
        value,
        reason,
        result.loop_compiled,
    )


def _check_margin(result: Any, mission: dict[str, Any], objective: str) -> float:
    """The least margin of the checks named ``objective`` (``phase: metric``, or a
    metric for every phase's check of it), measured exactly (summary.json's)."""
    from wmr_mission.verdicts.metrics import check_expectations, summarize

    margins = [
        check.margin
        for check in check_expectations(summarize(result, mission), mission)
        if objective in (check.name, check.metric)
    ]
    return min(margins, default=math.inf)


def check_names(loaded: LoadedCampaign, draw: Draw) -> list[str]:
    """The checks of the run of ``draw`` (``phase: metric`` or the metric), for
    ``--objective`` to name one; empty when the mission refuses the draw."""
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.verdicts.metrics import check_expectations, summarize

    plan, record, _ = written_runs(loaded).run(draw)
    if plan is None:
        return []
    result = run_mission(plan)
    return [check.name for check in check_expectations(summarize(result, record), record)]


def evaluate_draws(
    loaded: LoadedCampaign, draws: Sequence[Draw], objective: str | None
) -> list[Evaluation]:
    """One task of a worker: the evaluations of ``draws``, in their order."""
    evaluations = []
    for draw in draws:
        try:
            evaluations.append(evaluate(loaded, draw, objective))
        except Exception as error:  # one run's fault must not lose the search
            reason = f"internal error ({type(error).__name__}: {error}); please report it"
            evaluations.append(
                Evaluation(
                    draw.run, draw.seed, draw.values, ERROR, math.inf, ERROR, math.inf, reason
                )
            )
    return evaluations


class Stopped(Interrupted):
    """A signal stopped a batch; ``evaluations`` are those that finished, in order."""

    def __init__(self, evaluations: list[Evaluation]) -> None:
        super().__init__()
        self.evaluations = evaluations


_POLL_SECONDS: Final = 0.2


class Evaluator:
    """Batches of draws evaluated in this process (one worker), on a local
    process pool, or on a Dask client; opened and closed with ``with``."""

    def __init__(
        self,
        loaded: LoadedCampaign,
        objective: str | None,
        *,
        workers: int,
        client: Any = None,
        stop: StopSignals,
    ) -> None:
        self.loaded = loaded
        self.objective = objective
        self.workers = workers
        self.client = client
        self.stop = stop
        self._pool: Any = None
        self._pool_context: Any = None

    def __enter__(self) -> Evaluator:
        if self.client is None and self.workers > 1:
            self._pool_context = local_pool(self.workers)
            self._pool = self._pool_context.__enter__()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._pool_context is not None:
            self._pool_context.__exit__(*exc)

    def __call__(self, draws: Sequence[Draw]) -> list[Evaluation]:
        """The evaluations of ``draws`` in their order; raises :class:`Stopped`
        with those that finished once a signal stops the search."""
        if self._pool is None and self.client is None:
            done: list[Evaluation] = []
            for draw in draws:
                if self.stop.stopped:
                    raise Stopped(done)
                done += evaluate_draws(self.loaded, [draw], self.objective)
            return done
        workers = (
            self.workers if self.client is None else max(1, sum(self.client.nthreads().values()))
        )
        size = max(1, math.ceil(len(draws) / workers))
        chunks = [list(draws[i : i + size]) for i in range(0, len(draws), size)]
        submit: Callable[..., Any]
        if self.client is not None:
            submit = lambda *args: self.client.submit(*args, pure=False)  # noqa: E731
        else:
            submit = self._pool.submit
        futures = [submit(evaluate_draws, self.loaded, chunk, self.objective) for chunk in chunks]
        return self._gather(futures)

    def _gather(self, futures: list[Any]) -> list[Evaluation]:
        pending = set(range(len(futures)))
        results: dict[int, list[Evaluation]] = {}
        while pending and not self.stop.stopped:
            for index in list(pending):
                if futures[index].done():
                    results[index] = futures[index].result()
                    pending.discard(index)
            if pending:
                self._wait([futures[i] for i in pending])
        if pending:  # stopped: what runs finishes, what waits is dropped
            for index in sorted(pending):
                future = futures[index]
                if future.cancel():
                    continue
                try:
                    results[index] = future.result()
                except (KeyboardInterrupt, SystemExit):
                    raise
                except BaseException:
                    pass
            raise Stopped([e for i in sorted(results) for e in results[i]])
        return [e for i in sorted(results) for e in results[i]]

    def _wait(self, futures: list[Any]) -> None:
        if self.client is None:
            wait(futures, timeout=_POLL_SECONDS, return_when=FIRST_COMPLETED)
            return
        from distributed import TimeoutError as DaskTimeout
        from distributed import wait as dask_wait

        try:
            dask_wait(futures, timeout=_POLL_SECONDS, return_when="FIRST_COMPLETED")  # type: ignore[no-untyped-call]
        except (DaskTimeout, TimeoutError):
            time.sleep(0)
