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
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, Final, Protocol

import numpy as np

from wmr_mission.campaign.falsify import METHODS
from wmr_mission.campaign.falsify.space import Space

__all__ = ["RANDOM_BATCH", "SIGMA_LOCAL", "Method", "corners", "design", "make_method"]

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
        self.corners = first_corners(space) if start is None else []
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
            "integer_variables": self._integers(),
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

    def another(self) -> list[float] | None:
        """One more point of this generation's distribution (None while a
        design is asked), to stand for an asked point that should not run."""
        if self.es is None:
            return None
        with self._own_random():
            point = self.es.ask(1)[0]
        return [float(x) for x in point]

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
        import cma

        with self._own_random(), warnings.catch_warnings():
            # the points another() drew in place of repeats were asked, never told
            warnings.simplefilter("ignore", cma.evolution_strategy.InjectionWarning)
            self.es.tell([np.array(p) for p in points], told)

    def settings(self) -> dict[str, Any]:
        return {
            "corners": len(self.corners),
            "design": self.design_size,
            "popsize": self.popsize,
            "sigma0": SIGMA_LOCAL,
            "restarts": self.restarts,
            "integer_variables": self._integers(),
        }

    def _integers(self) -> list[int]:
        """The coordinates cma searches as integers: the discrete ones, but none
        in a box of one axis, where cma's integer handling fails on its first
        ``tell`` (an IndexError): a lone choice is searched as a number, rounded
        to its values as any point is."""
        return self.space.discrete() if self.space.dimension > 1 else []


def design_size(dimension: int) -> int:
    """Points of a design: :data:`DESIGN`, or 4 a coordinate, as a power of 2
    (a Sobol batch is balanced at powers of 2)."""
    return 1 << (max(DESIGN, 4 * dimension) - 1).bit_length()


def design(space: Space, size: int, rng: np.random.Generator) -> list[list[float]]:
    """``size`` points spread over the box: a scrambled Sobol batch (Owen
    scrambling, seeded by ``rng``), a discrete coordinate rounded to its values."""
    from scipy.stats import qmc

    if size == 0:
        return []
    sobol = qmc.Sobol(space.dimension, scramble=True, seed=rng)
    points = on_values(space, qmc.scale(sobol.random(size), space.lower(), space.upper()))
    return [[float(x) for x in row] for row in points]


def on_values(space: Space, points: np.ndarray) -> np.ndarray:
    """``points`` (rows of the box), each discrete coordinate rounded to the
    index of its nearest value, in place."""
    discrete = space.discrete()
    upper = np.array(space.upper())[discrete]
    points[:, discrete] = np.clip(np.round(points[:, discrete]), 0, upper - 0.5)
    return points


def corners(space: Space) -> list[list[float]]:
    """The box's 2^d corners: each axis at its least or greatest value (a
    choice's first or last), the first axis slowest."""
    ends = [
        (0.0, count - 1.0) if count else (lo, hi)
        for count, lo, hi in zip(space.counts(), space.lower(), space.upper(), strict=True)
    ]
    return [list(point) for point in itertools.product(*ends)]


def first_corners(space: Space) -> list[list[float]]:
    """The corners a search asks first: all of them, unless they would
    outnumber the design (beyond 5 axes: 64 corners against 32 points)."""
    return corners(space) if 2**space.dimension <= design_size(space.dimension) else []


MODEL_RUNS: Final = 32
"""Runs the model proposes before CMA-ES takes over (its cost grows with the
runs it is fitted on: bounded, so that a long search stays fast)."""

MODEL_BATCH: Final = 2
"""Points the model proposes at once (the kriging believer between them)."""

CANDIDATES: Final = 1024
"""Sobol points of the box the model scores for each proposal, besides
Gaussian steps about the lowest runs and points on its faces."""

FACE_CANDIDATES: Final = 256
"""Sobol points of each face of the box (a continuous axis at its least or
greatest value) the model scores besides: a failure that grows with an axis
reaches its end, as the corners' does (estimate-band's bands reach the faces
of the largest lateral error, heading-band's the fastest speed), and the
Sobol points of the box fall on no face."""


class GpSearch:
    """The corners of the box and a small design, then the points where a
    Gaussian-process model of the margin (:mod:`surrogate`) gives the greatest
    chance of a margin below 0, for :data:`MODEL_RUNS` runs or until a run
    fails; then CMA-ES (:class:`CmaEs`) about the lowest run, with its restarts.

    The model's job is a first failure: once a run fails, its chance of failing
    is the greatest of all, and the model would propose it (or a Gaussian step
    about it clipped to the same face) again and again."""

    name = "gp"

    def __init__(self, space: Space, rng: np.random.Generator) -> None:
        self.space = space
        self.rng = rng
        d = space.dimension
        self.corners = first_corners(space)
        # Where the corners are asked, they are the design: the model starts on them.
        self.design_size = 0 if self.corners else max(4, 1 << (2 * d - 1).bit_length())
        self.x: list[list[float]] = []  # every point told, and its objective
        self.y: list[float] = []
        self.params: Any = None
        self.cmaes: CmaEs | None = None
        lower, upper = np.array(space.lower()), np.array(space.upper())
        self._lower, self._width = lower, upper - lower

    def ask(self) -> list[list[float]]:
        if self.cmaes is None and (
            len(self.x) >= self._initial() + MODEL_RUNS or min(self.y, default=0.0) < 0
        ):
            self._hand_over()
        if self.cmaes is None and not self.x:
            return self.corners + design(self.space, self.design_size, self.rng)
        if self.cmaes is None:
            from threadpoolctl import threadpool_limits

            with threadpool_limits(1):  # small matrices: threads only wait on each other
                proposals = self._proposals()
            if proposals:
                return proposals
            self._hand_over()  # every point of a discrete box has run
        assert self.cmaes is not None
        return self._unrepeated(self.cmaes.ask())

    def _unrepeated(self, points: list[list[float]]) -> list[list[float]]:
        """CMA-ES's ``points``, each that would run where a run already has
        (clamped to the same corner of the box: about a failing corner, an
        eighth of a generation in 3 axes) drawn again, up to :data:`REDRAWS`
        times."""
        assert self.cmaes is not None
        seen = {self._key(point) for point in self.x}
        kept = []
        for point in points:
            for _ in range(REDRAWS):
                if self._key(point) not in seen:
                    break
                point = self.cmaes.another() or point
            seen.add(self._key(point))
            kept.append(point)
        return kept

    def _key(self, point: list[float]) -> tuple[float, ...]:
        """Where ``point`` runs: clamped to the box, rounded to its values."""
        at = np.clip(np.array([point]), self._lower, self._lower + self._width)
        return _keys(on_values(self.space, at), self._width)[0]

    def _hand_over(self) -> None:
        """CMA-ES about the lowest run, each continuous coordinate a step
        (:data:`SIGMA_LOCAL`) inside the box: from a corner or a face, most of a
        generation would lie beyond it and run on the same points of the face."""
        start = np.array(self.x[int(np.argmin(self.y))])
        continuous = [i for i, count in enumerate(self.space.counts()) if not count]
        start[continuous] = np.clip(start[continuous], SIGMA_LOCAL, 1 - SIGMA_LOCAL)
        self.cmaes = CmaEs(self.space, self.rng, start=[float(v) for v in start])

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
        unit = np.vstack([sobol, *local, *self._on_faces()])
        points = on_values(self.space, self._lower + unit * self._width)
        discrete = self.space.discrete()  # the model scores the value a run would have
        unit[:, discrete] = (points[:, discrete] - self._lower[discrete]) / self._width[discrete]
        kept = _unrun(points, np.array(self.x), self._width)
        if not kept:
            return []
        unit, points = unit[kept], points[kept]
        chosen = gp.most_likely_failures(unit, min(MODEL_BATCH, len(points)))
        return [[float(v) for v in points[k]] for k in chosen]

    def _on_faces(self) -> list[np.ndarray]:
        """:data:`FACE_CANDIDATES` Sobol points on each face of the unit box: one
        continuous coordinate at 0 or at 1, the others anywhere."""
        from scipy.stats import qmc

        spread = qmc.Sobol(self.space.dimension, scramble=True, seed=self.rng)
        points = spread.random(FACE_CANDIDATES)
        faces = []
        for axis, count in enumerate(self.space.counts()):
            for end in () if count else (0.0, 1.0):
                face = points.copy()
                face[:, axis] = end
                faces.append(face)
        return faces

    def tell(self, points: list[list[float]], objectives: list[float]) -> None:
        self.x += points
        self.y += objectives
        if self.cmaes is not None:
            self.cmaes.tell(points, objectives)

    def settings(self) -> dict[str, Any]:
        return {
            "corners": len(self.corners),
            "design": self.design_size,
            "model_runs": MODEL_RUNS,
            "model_batch": MODEL_BATCH,
            **({"cmaes": self.cmaes.settings()} if self.cmaes is not None else {}),
        }


REDRAWS: Final = 10
"""Draws of CMA-ES for a point that would repeat a run, before it runs anyway
(in a box of few discrete values, every point may have run)."""

SAME: Final = 1e-9
"""Points nearer than this, in each coordinate and in the box's units, are one
point (a Gaussian step clipped to a face and that face's corner run)."""


def _unrun(points: np.ndarray, runs: np.ndarray, width: np.ndarray) -> list[int]:
    """Indices of the first of each distinct row of ``points`` that is no row of
    ``runs``, in order: rounded to its values, a candidate may be a point already
    run or another candidate."""
    seen = set(_keys(runs, width))
    kept = []
    for i, key in enumerate(_keys(points, width)):
        if key not in seen:
            seen.add(key)
            kept.append(i)
    return kept


def _keys(points: np.ndarray, width: np.ndarray) -> list[tuple[float, ...]]:
    """Each row of ``points`` (in the box, on its values) as the same key for
    points nearer than :data:`SAME`."""
    return [tuple(row) for row in np.round(points / width / SAME).tolist()]
