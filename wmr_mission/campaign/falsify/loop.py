"""The search: ask the method for points, evaluate them as runs, tell it their objectives.

Stops at the budget, or with ``first`` after the batch that holds the first
failure; a signal stops it after the runs under way (:class:`Stopped`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from wmr_mission.campaign.falsify.evaluate import Evaluation, Stopped, evaluation_seed
from wmr_mission.campaign.falsify.search import Method
from wmr_mission.campaign.falsify.space import Space
from wmr_mission.campaign.plan import Draw

__all__ = ["Search", "draws_of", "search"]


@dataclass
class Search:
    """What the search evaluated, in evaluation order, and whether a signal stopped it."""

    evaluations: list[Evaluation] = field(default_factory=list)
    stopped: bool = False

    @property
    def first_failure(self) -> int | None:
        """Runs to the first failure (its evaluation index + 1), None without one."""
        return next((e.index + 1 for e in self.evaluations if e.falsified), None)


def draws_of(space: Space, seed: int, start: int, points: Sequence[Sequence[float]]) -> list[Draw]:
    """The runs of ``points``, numbered from ``start``."""
    return [
        Draw(start + i, evaluation_seed(seed, start + i), space.values(point))
        for i, point in enumerate(points)
    ]


def search(
    space: Space,
    method: Method,
    evaluate: Callable[[list[Draw]], list[Evaluation]],
    *,
    budget: int,
    seed: int,
    first: bool,
) -> Iterator[list[Evaluation]]:
    """Each batch's evaluations, in order, as they are known. A signal raises
    :class:`Stopped` with the finished runs of the batch under way."""
    done = 0
    while done < budget:
        points = method.ask()[: budget - done]
        evaluations = evaluate(draws_of(space, seed, done, points))
        done += len(evaluations)
        yield evaluations
        if first and any(e.falsified for e in evaluations):
            return
        method.tell(points, [e.told() for e in evaluations])


def run_search(
    space: Space,
    method: Method,
    evaluate: Callable[[list[Draw]], list[Evaluation]],
    *,
    budget: int,
    seed: int,
    first: bool,
    on_batch: Callable[[list[Evaluation]], Any] | None = None,
) -> Search:
    """The whole search, each batch handed to ``on_batch`` as it is known."""
    result = Search()
    try:
        for batch in search(space, method, evaluate, budget=budget, seed=seed, first=first):
            result.evaluations += batch
            if on_batch is not None:
                on_batch(batch)
    except Stopped as stopped:
        result.evaluations += stopped.evaluations
        if on_batch is not None and stopped.evaluations:
            on_batch(stopped.evaluations)
        result.stopped = True
    return result
