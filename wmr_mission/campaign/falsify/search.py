"""The methods that choose the next points: ``cmaes`` and ``random``.

A method asks for a batch of points and is told their objectives (the run's
margin, or one check's: lower is nearer a failure) in the order it asked.
Both are seeded and draw nothing from outside: the same seed gives the same
points whatever ran in between, on however many workers.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, Final, Protocol

import numpy as np

from wmr_mission.campaign.falsify.space import Space

__all__ = ["METHODS", "RANDOM_BATCH", "SIGMA0", "Method", "make_method"]

METHODS: Final = ("cmaes", "random")

SIGMA0: Final = 0.3
"""CMA-ES's first step, in the box's units (a third of a continuous axis; a
third of a discrete axis's values, scaled by CMA_stds)."""

TOLX: Final = 1e-3
"""CMA-ES restarts once its steps are below a thousandth of the box: a failing
region that small is not worth the rest of the budget (cma's default, 1e-11,
spends it converging on a margin's local minimum)."""

TOLFUN: Final = 1e-4
"""... or once a generation's margins differ by less than this (cma's: 1e-11)."""

RANDOM_BATCH: Final = 16
"""Points of random search evaluated together: a fixed number, so that where
`--first` stops does not depend on the workers."""


class Method(Protocol):
    name: str

    def ask(self) -> list[list[float]]: ...

    def tell(self, points: list[list[float]], objectives: list[float]) -> None: ...

    def settings(self) -> dict[str, Any]: ...


def make_method(name: str, space: Space, seed: int) -> Method:
    """The method ``name`` over ``space``, seeded by ``seed``."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1,)))
    if name == "random":
        return RandomSearch(space, rng)
    if name == "cmaes":
        return CmaEs(space, rng)
    raise ValueError(f"method is one of {', '.join(METHODS)}, got {name!r}")


class RandomSearch:
    """Uniform points of the box: the campaign's own draws (the baseline)."""

    name = "random"

    def __init__(self, space: Space, rng: np.random.Generator) -> None:
        self.space = space
        self.rng = rng

    def ask(self) -> list[list[float]]:
        lower, upper = np.array(self.space.lower()), np.array(self.space.upper())
        draws = self.rng.uniform(lower, upper, size=(RANDOM_BATCH, self.space.dimension))
        return [[float(x) for x in row] for row in draws]

    def tell(self, points: list[list[float]], objectives: list[float]) -> None:
        pass

    def settings(self) -> dict[str, Any]:
        return {"batch": RANDOM_BATCH}


class CmaEs:
    """CMA-ES (the ``cma`` package) in the box, restarted from a new random mean
    when it stops (its step too small to move, or the objective flat).

    Continuous coordinates live in [0, 1]; a discrete one (choice, grid) is an
    index, which ``cma``'s ``integer_variables`` (a least step and integer
    centering: Hansen, "A CMA-ES for Mixed-Integer Nonlinear Optimization",
    2011) keeps searching across values rather than settling on one.
    """

    name = "cmaes"

    def __init__(self, space: Space, rng: np.random.Generator) -> None:
        self.space = space
        self.rng = rng
        self.restarts = 0
        # cma draws from numpy's global generator: it gets one of its own,
        # swapped in around each call, so that nothing else moves it.
        self._state = np.random.RandomState(int(rng.integers(2**32))).get_state()
        self.es = self._start()

    def _start(self) -> Any:
        import cma

        lower, upper = self.space.lower(), self.space.upper()
        mean = [float(x) for x in self.rng.uniform(lower, upper)]
        counts = self.space.counts()
        options = {
            "bounds": [lower, upper],
            "CMA_stds": [float(count) if count else 1.0 for count in counts],
            "integer_variables": self.space.discrete(),
            "seed": np.nan,  # "do nothing": the generator is ours (_own_random)
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
            "tolflatfitness": 3,
            "tolx": TOLX,
            "tolfun": TOLFUN,
        }
        with self._own_random():
            return cma.CMAEvolutionStrategy(mean, SIGMA0, options)

    @contextmanager
    def _own_random(self) -> Iterator[None]:
        kept = np.random.get_state()
        np.random.set_state(self._state)
        try:
            yield
        finally:
            self._state = np.random.get_state()
            np.random.set_state(kept)

    def ask(self) -> list[list[float]]:
        with self._own_random():
            if self.es.stop():
                self.restarts += 1
                self.es = self._start()
            points = self.es.ask()
        return [[float(x) for x in point] for point in points]

    def tell(self, points: list[list[float]], objectives: list[float]) -> None:
        if len(points) != self.es.popsize:  # a last generation cut by the budget
            return
        with self._own_random():
            self.es.tell([np.array(p) for p in points], objectives)

    def settings(self) -> dict[str, Any]:
        return {
            "popsize": int(self.es.popsize),
            "sigma0": SIGMA0,
            "restarts": self.restarts,
            "integer_variables": self.space.discrete(),
        }
