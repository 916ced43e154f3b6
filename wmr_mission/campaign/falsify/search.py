"""The methods that choose the next points: ``gp`` (a model of the margin, then
CMA-ES: the default), ``cmaes`` and ``random``.

A method asks for a batch of points and is told their objectives (the run's
margin, or one check's: lower is nearer a failure) in the order it asked.
Both are seeded and draw nothing from outside: the same seed gives the same
points whatever ran in between, on however many workers.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, Final, Protocol

import numpy as np

from wmr_mission.campaign.falsify.space import Space

__all__ = ["METHODS", "RANDOM_BATCH", "SIGMA_LOCAL", "Method", "corners", "design", "make_method"]

METHODS: Final = ("gp", "cmaes", "random")

DESIGN: Final = 8
"""The fewest points of a space-filling design (more with more axes:
:func:`design_size`)."""

SIGMA_LOCAL: Final = 0.2
"""CMA-ES's first step from a design's best point, in the box's units (a
fifth of a continuous axis; of a discrete axis's values, scaled by CMA_stds):
a search about that point rather than over the box, which the design covered."""

TOLX: Final = 1e-3
"""CMA-ES restarts once its steps are below a thousandth of the box: a failing
region that small is not worth the rest of the budget (cma's default, 1e-11,
spends it converging on a margin's local minimum)."""

TOLFUN: Final = 1e-4
"""... or once a generation's margins differ by less than this (cma's: 1e-11)."""

STALL: Final = 10
"""... or once its best margin has not fallen for this many generations: a
search stuck in a basin that does not fail (whose margins a run's sensor noise
keeps from agreeing to TOLFUN) starts again rather than spend the budget there."""

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
    if name == "gp":
        return GpSearch(space, rng)
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
    """The corners of the box and a space-filling design, then CMA-ES (the
    ``cma`` package) from the design's best point; when CMA-ES stops, it starts
    again from the best point of a new design with twice the population (IPOP).

    The corners (:func:`corners`) come first: a failure that grows with each
    axis (the most noise, the longest lag, the furthest start) sits at one of
    them, and a corner is the one point of such a region a search can name in
    advance. The design (a scrambled Sobol batch: :func:`design_size` points)
    spreads its runs over the whole box, where a random mean would spend
    CMA-ES's first generations walking to a basin; CMA-ES then searches about
    the best of the design's points (never a corner: from a corner, most of a
    generation lies beyond the box and is run on its faces) with a step of
    :data:`SIGMA_LOCAL`. CMA-ES is not bounded: a point beyond the box runs at
    the nearest point of it (each coordinate clamped, :meth:`Space.values`)
    and is told its margin plus its squared distance beyond, so that a face or
    a corner of the box is reached in a step rather than approached.
    Continuous coordinates live in [0, 1]; a discrete one (choice, grid) is an
    index, which ``cma``'s ``integer_variables`` (a least step and integer
    centering: Hansen, "A CMA-ES for Mixed-Integer Nonlinear Optimization",
    2011) keeps searching across values rather than settling on one.
    """

    name = "cmaes"

    def __init__(
        self, space: Space, rng: np.random.Generator, start: list[float] | None = None
    ) -> None:
        """``start``: a point to search about first, instead of the corners and a design."""
        self.space = space
        self.rng = rng
        self.restarts = 0
        self.start = start
        self.design_size = design_size(space.dimension)
        with_corners = start is None and 2**space.dimension <= self.design_size
        self.corners = corners(space) if with_corners else []
        # cma draws from numpy's global generator: it gets one of its own,
        # swapped in around each call, so that nothing else moves it.
        self._state = np.random.RandomState(int(rng.integers(2**32))).get_state()
        self.es: Any = None  # None while a design is to be asked
        self.popsize: int | None = None
        self.first_popsize: int | None = None  # cma's own, for the first CMA-ES run
        self.run_best, self.stalled = math.inf, 0  # this CMA-ES run's lowest, generations since

    def _start(self, mean: list[float], sigma: float) -> Any:
        import cma

        counts = self.space.counts()
        options: dict[str, Any] = {
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
        if self.first_popsize is not None:  # IPOP: each restart doubles the population
            options["popsize"] = self.first_popsize * 2**self.restarts
        with self._own_random():
            es = cma.CMAEvolutionStrategy(mean, sigma, options)
        self.popsize = int(es.popsize)
        if self.first_popsize is None:
            self.first_popsize = self.popsize
        self.run_best, self.stalled = math.inf, 0
        return es

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
        if self.es is not None:
            with self._own_random():
                stopped = bool(self.es.stop()) or self.stalled >= STALL
            if stopped:
                self.restarts += 1
                self.es = None
        if self.es is None and self.start is not None:
            self.es, self.start = self._start(self.start, SIGMA_LOCAL), None
        if self.es is None:
            points = design(self.space, self.design_size, self.rng)
            return (self.corners if self.restarts == 0 else []) + points
        with self._own_random():
            points = self.es.ask()
        return [[float(x) for x in point] for point in points]

    def tell(self, points: list[list[float]], objectives: list[float]) -> None:
        if self.es is None:  # a design told: CMA-ES starts at its best point
            designed = list(zip(objectives, points, strict=True))[-self.design_size :]
            best = min(designed, key=lambda pair: pair[0])[1]
            self.es = self._start(best, SIGMA_LOCAL)
            return
        if len(points) != self.es.popsize:  # a last generation cut by the budget
            return
        lowest = min(objectives)
        self.run_best, self.stalled = (
            (lowest, 0) if lowest < self.run_best else (self.run_best, self.stalled + 1)
        )
        lower, upper = np.array(self.space.lower()), np.array(self.space.upper())
        told = [
            objective + float(np.sum((np.clip(point, lower, upper) - np.array(point)) ** 2))
            for point, objective in zip(points, objectives, strict=True)
        ]
        with self._own_random():
            self.es.tell([np.array(p) for p in points], told)

    def settings(self) -> dict[str, Any]:
        return {
            "corners": len(self.corners),
            "design": self.design_size,
            "popsize": self.popsize,
            "sigma0": SIGMA_LOCAL,
            "restarts": self.restarts,
            "integer_variables": self.space.discrete(),
        }


def design_size(dimension: int) -> int:
    """Points of a design: :data:`DESIGN`, or 4 a coordinate, as a power of 2
    (a Sobol batch is balanced at powers of 2)."""
    return 1 << (max(DESIGN, 4 * dimension) - 1).bit_length()


def design(space: Space, size: int, rng: np.random.Generator) -> list[list[float]]:
    """``size`` points spread over the box: a scrambled Sobol batch (Owen
    scrambling, seeded by ``rng``), a discrete coordinate rounded to its values."""
    from scipy.stats import qmc

    sobol = qmc.Sobol(space.dimension, scramble=True, seed=rng)
    lower, upper = space.lower(), space.upper()
    points = qmc.scale(sobol.random(size), lower, upper)
    discrete = space.discrete()
    points[:, discrete] = np.clip(np.round(points[:, discrete]), 0, np.array(upper)[discrete] - 0.5)
    return [[float(x) for x in row] for row in points]


def corners(space: Space) -> list[list[float]]:
    """The box's 2^d corners: each axis at its least or greatest value (a
    choice's first or last), the first axis slowest."""
    ends = [
        (0.0, count - 1.0) if count else (lo, hi)
        for count, lo, hi in zip(space.counts(), space.lower(), space.upper(), strict=True)
    ]
    return [list(point) for point in itertools.product(*ends)]


MODEL_RUNS: Final = 32
"""Runs the model proposes before CMA-ES takes over (its cost grows with the
runs it is fitted on: bounded, so that a long search stays fast)."""

MODEL_BATCH: Final = 2
"""Points the model proposes at once (the kriging believer between them)."""

CANDIDATES: Final = 1024
"""Sobol points of the box the model scores for each proposal, besides
Gaussian steps about the lowest runs."""


class GpSearch:
    """The corners of the box and a small design, then the points where a
    Gaussian-process model of the margin (:mod:`surrogate`) gives the greatest
    chance of a margin below 0, for :data:`MODEL_RUNS` runs; then CMA-ES
    (:class:`CmaEs`) about the lowest run, with its restarts."""

    name = "gp"

    def __init__(self, space: Space, rng: np.random.Generator) -> None:
        self.space = space
        self.rng = rng
        d = space.dimension
        self.design_size = max(4, 1 << (2 * d - 1).bit_length())
        self.corners = corners(space) if 2**d <= design_size(d) else []
        self.x: list[list[float]] = []
        self.y: list[float] = []
        self.params: Any = None
        self.cmaes: CmaEs | None = None
        lower, upper = np.array(space.lower()), np.array(space.upper())
        self._lower, self._width = lower, upper - lower

    def ask(self) -> list[list[float]]:
        if self.cmaes is None and len(self.x) >= self._initial() + MODEL_RUNS:
            best = self.x[int(np.argmin(self.y))]
            self.cmaes = CmaEs(self.space, self.rng, start=best)
        if self.cmaes is not None:
            return self.cmaes.ask()
        if not self.x:
            return self.corners + design(self.space, self.design_size, self.rng)
        from threadpoolctl import threadpool_limits

        with threadpool_limits(1):  # small matrices: threads only wait on each other
            return self._proposals()

    def _initial(self) -> int:
        return len(self.corners) + self.design_size

    def _proposals(self) -> list[list[float]]:
        from scipy.stats import qmc

        from wmr_mission.campaign.falsify.surrogate import Gp

        x = (np.array(self.x) - self._lower) / self._width
        y = np.clip(np.array(self.y), -1.0, 2.0)
        gp = Gp(x, y, self.params)
        self.params = gp.params
        d = self.space.dimension
        sobol = qmc.Sobol(d, scramble=True, seed=self.rng).random(CANDIDATES)
        lowest = np.argsort(y, kind="stable")[:5]
        local = [
            np.clip(x[i] + self.rng.normal(0, scale, size=(64, d)), 0, 1)
            for i in lowest
            for scale in (0.003, 0.01, 0.03, 0.1)
        ]
        candidates = np.vstack([sobol, *local])
        chosen = candidates[gp.most_likely_failures(candidates, MODEL_BATCH)]
        points = self._lower + chosen * self._width
        discrete = self.space.discrete()
        upper = self._lower + self._width
        points[:, discrete] = np.clip(np.round(points[:, discrete]), 0, upper[discrete] - 0.5)
        return [[float(v) for v in row] for row in points]

    def tell(self, points: list[list[float]], objectives: list[float]) -> None:
        if self.cmaes is not None:
            self.cmaes.tell(points, objectives)
            return
        self.x += points
        self.y += objectives

    def settings(self) -> dict[str, Any]:
        return {
            "corners": len(self.corners),
            "design": self.design_size,
            "model_runs": MODEL_RUNS,
            "model_batch": MODEL_BATCH,
            **({"cmaes": self.cmaes.settings()} if self.cmaes is not None else {}),
        }
