"""The judge's compiled passes over a phase's samples (wmr_mission/verdicts/passes.py)
give the numpy forms' bits: the input metrics, the stalled time of a regulate
phase, the depth beyond an ellipse zone and its bounds, and the largest finite
value of a column, compiled and as plain Python."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest

from wmr_mission.kernels import jit
from wmr_mission.spec.numbers import mission_numbers
from wmr_mission.verdicts import passes
from wmr_mission.verdicts.inputs import input_quality, jitter, progress_to
from wmr_mission.verdicts.regulation import WINDOW, regulated, stall_time
from wmr_mission.verdicts.zones import Zone

NUMBERS = mission_numbers(None, 0.01, (1.0, 2.0))


def _bits(value: Any) -> Any:
    """A result with each float as its bytes (NaN as one word): equal means the same bits."""
    if isinstance(value, dict):
        return {key: _bits(v) for key, v in value.items()}
    if isinstance(value, tuple | list):
        return [_bits(v) for v in value]
    if isinstance(value, np.ndarray):
        return _bits(value.tolist())
    if isinstance(value, float):
        return "nan" if math.isnan(value) else np.float64(value).tobytes()
    return value


@contextmanager
def _counted(monkeypatch: pytest.MonkeyPatch, compiled: bool) -> Iterator[list[str]]:
    """The judge as a compiled run has it (numba loaded; ``compiled`` False: the
    kernels as plain Python), with the names of the passes it called."""
    called: list[str] = []
    if compiled:
        jit.load()
    make = jit.compiled if compiled else jit.plain

    def counting(fn: Callable[..., Any], **options: Any) -> Callable[..., Any]:
        called.append(getattr(fn, "__name__", ""))
        return make(fn) if compiled else jit.plain(fn)

    with monkeypatch.context() as patch:
        patch.setattr(jit, "judging_compiled", lambda: True)  # also where numba is turned off
        patch.setattr(jit, "compiled", counting)
        yield called


def _both(monkeypatch: pytest.MonkeyPatch, judged: Callable[[], Any], name: str) -> None:
    """``judged()`` by numpy, then by the pass ``name`` compiled and as plain
    Python: the same bits each time."""
    with monkeypatch.context() as patch:
        patch.setattr(jit, "judging_compiled", lambda: False)
        expected = _bits(judged())
    for compiled in (False, True):
        with _counted(monkeypatch, compiled) as called:
            assert _bits(judged()) == expected
        assert name in called  # the pass judged it, not numpy


def _inputs(rng: np.random.Generator, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inputs that reverse, jump, and sit at their limits (one sign and both
    signs in turn), with a NaN now and then in some."""
    t = np.arange(samples) * 0.01
    v = np.clip(np.cumsum(rng.normal(0.0, 0.15, samples)), -1.0, 1.0)
    omega = np.clip(2.5 * np.sin(t * rng.uniform(0.5, 8.0)) + rng.normal(0, 0.3, samples), -2, 2)
    omega[samples // 3 : samples // 3 + 40 : 2] *= -1.0  # both signs at the limit
    return t, v, omega


@pytest.mark.parametrize("seed", range(6))
def test_the_input_metrics_pass_has_the_numpy_forms_bits(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(seed)
    t, v, omega = _inputs(rng, 600 + seed)  # odd and even counts: the median's two forms
    if seed == 3:
        omega = np.round(omega, 1)  # many equal deviations: the median's selection among ties
    if seed == 4:
        omega[300] = math.nan  # the jitter and the jump are then unknown
    if seed == 5:
        v[10:] = 0.0  # a robot that stops: no reversal, no jump
    x, y = np.cumsum(v) * 0.01, np.zeros(v.size)
    progress = progress_to(x, y, (0.5, 0.0))
    counted = rng.uniform(size=v.size) < 0.7  # the jitter of some samples only
    counted[: 290 + seed] = True
    found = {}

    def judged() -> list[dict[str, Any]]:
        found["last"] = input_quality(t, v, omega, NUMBERS, progress)
        return [
            found["last"],
            # stretches at a limit cut where an update took over, judged apart
            input_quality(t, v, omega, NUMBERS, progress, None, (150, 421)),
            input_quality(t, v, omega, NUMBERS, progress, counted),  # NaN at 300 counted or not
            input_quality(t, v, omega, NUMBERS, progress, np.ones(v.size, dtype=bool)),
            input_quality(t, v, omega, NUMBERS, progress, np.zeros(v.size, dtype=bool)),  # all
            jitter(omega, NUMBERS, counted),  # the jitter alone, as a campaign's row takes it
        ]

    _both(monkeypatch, judged, "input_pass")
    if seed < 4:  # the samples reverse and fight: the metrics are not all trivial
        assert found["last"]["turn_rate_reversals"] > 0
        assert found["last"]["turn_rate_fight_time"] > 0.0


def test_a_speed_limit_never_reached_is_never_fought(monkeypatch: pytest.MonkeyPatch) -> None:
    """Limits of inf and speeds of inf beside them: a stretch "at" the limit
    is none, and no fight, compiled, as plain Python and by numpy (fight_time
    has it so)."""
    t = np.arange(400) * 0.01
    k = np.arange(400)
    for v in (
        np.where(k % 100 < 60, math.inf, 0.3),
        np.where((k >= 100) & (k < 160), math.inf, 0.3),
    ):
        _never_fought(monkeypatch, t, v, np.where(k % 90 < 50, -math.inf, 0.2))


def _never_fought(
    monkeypatch: pytest.MonkeyPatch, t: np.ndarray, v: np.ndarray, omega: np.ndarray
) -> None:
    """:func:`test_a_speed_limit_never_reached_is_never_fought` of these inputs
    (stretches of 60 samples at inf: several, and one alone)."""
    unlimited = mission_numbers(None, 0.01, (math.inf, math.inf))
    progress = progress_to(np.zeros(400), np.zeros(400), (0.5, 0.0))  # none made

    def judged() -> dict[str, Any]:
        with np.errstate(invalid="ignore"):  # inf - inf: a jump of NaN
            return input_quality(t, v, omega, unlimited, progress)

    _both(monkeypatch, judged, "input_pass")
    found = judged()
    assert found["speed_fight_time"] == 0.0
    assert found["turn_rate_fight_time"] == 0.0


@pytest.mark.parametrize("samples", [0, 1, 2, 3, 10, 23, 130, 131, 141, 142])
def test_the_input_metrics_pass_of_few_samples_has_the_numpy_forms_bits(
    samples: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Phases too short for a jump, a stretch at the limit, or the jitter
    (1 s skipped, then 21 samples of the moving mean), and limits never
    reached (infinite) or always (a speed that sits at it, an update inside)."""
    rng = np.random.default_rng(samples)
    t, v, omega = _inputs(rng, samples)
    unlimited = mission_numbers(None, 0.01, (math.inf, math.inf))
    progress = progress_to(np.cumsum(v) * 0.01, np.zeros(samples), (0.5, 0.0))
    k = np.arange(samples)
    at = k % 23 < 10  # stretches at the limits of one time constant exactly, and the rest
    both_ways = np.where(at, 2.0, 0.5) * (-1.0) ** k
    one_way = np.where(at, -1.0, 0.2)

    def judged() -> list[Any]:
        with np.errstate(invalid="ignore"):  # numpy's inf - inf, a NaN jump
            endless = input_quality(t, v, np.where(at, math.inf, -math.inf), unlimited, progress)
        return [
            input_quality(t, v, omega, NUMBERS, progress),
            input_quality(t, one_way, both_ways, NUMBERS, progress),
            input_quality(t, one_way, np.abs(both_ways), NUMBERS, progress, None, (5,)),
            input_quality(t, v, omega, unlimited, progress, None, (1, 15)),
            endless,  # at a limit never reached: no fight
            # both ways at the speed limit: a fight, however far it goes
            input_quality(t, np.where(at, (-1.0) ** k, 0.2), omega, NUMBERS, lambda a, b: 1e9),
            input_quality(t, np.full(samples, -1.0), -omega, NUMBERS, progress, None, (12,)),
            input_quality(t, v, omega, NUMBERS, progress, np.arange(samples) % 3 == 0),
            jitter(omega, NUMBERS),
            # moving means of 11 and 7 samples: sums not made of whole threes
            *(jitter(omega, mission_numbers(None, dt, (1.0, 2.0))) for dt in (0.02, 0.03)),
        ]

    _both(monkeypatch, judged, "input_pass")


@pytest.mark.parametrize("seed", range(4))
def test_the_stall_pass_has_the_numpy_forms_bits(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A robot that closes on its target, stalls short of it, and shakes in place."""
    rng = np.random.default_rng(seed)
    samples = 3000
    k = np.arange(samples)
    distance = np.where(k < 1000, 2.0 - k * 0.0015, 0.5) + rng.normal(0, 1e-3, samples)
    x, y = 1.0 - distance, np.zeros(samples) + 0.1 * seed
    theta = np.sin(k * 0.05) * (k > 2000) + 7.0 * seed
    target = (1.0, 0.0, float(seed))

    def judged() -> float | None:
        return stall_time(x, y, theta, target, (0.05, 0.05), NUMBERS)

    _both(monkeypatch, judged, "regulation_pass")
    with monkeypatch.context() as patch:
        patch.setattr(jit, "judging_compiled", lambda: False)
        assert (judged() or 0.0) > 0.0  # it stalled: the count is not trivially 0


def _window_samples() -> int:
    """The samples of a stall's window with NUMBERS (regulation._window)."""
    tau = NUMBERS.time_constant
    return max(2, round(max(WINDOW * tau, math.pi / NUMBERS.omega_limit + 10 * tau) / NUMBERS.dt))


@pytest.mark.parametrize("seed", range(4))
def test_the_regulation_pass_has_the_numpy_forms_bits(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The stall and the overshoot of stretches found together: position
    errors on the goal's edge and windows whose progress is on its share, a
    rounding either side (where the square root of the squares and hypot may
    part), a robot that passes its target, one that ends on it (a zero
    overshoot), headings many turns round, poses not finite, a target beyond
    a zone and stretches shorter than a window."""
    rng = np.random.default_rng(seed)
    window = _window_samples()
    samples = 3 * window + 17
    angle = rng.uniform(0.0, 2.0 * math.pi, samples)
    goal = (0.05, 0.05)
    # distances: closing in, then each window's end on its start's progress share
    distance = np.where(np.arange(samples) < window, 2.0 - np.arange(samples) * 1e-3, 0.0)
    for k in range(window, samples):
        distance[k] = distance[k - window] * (1.0 - 0.1) * (1.0 + rng.integers(-3, 4) * 2.0**-52)
    distance[::7] = goal[0] * (1.0 + rng.integers(-3, 4, distance[::7].size) * 2.0**-52)
    x, y = 1.0 + distance * np.cos(angle), -2.0 + distance * np.sin(angle)
    theta = rng.uniform(-1.0, 1.0, samples) * 10.0 ** (seed + 1)
    target = (1.0, -2.0, 0.5)
    rock = Zone("rock", {"type": "circle", "center": [1.0, -2.0], "radius": 0.3}, False)
    passing = np.linspace(0.0, 1.5, 300)  # past a target at 1.0 by 0.5
    landing = np.r_[np.linspace(0.0, 1.0, 250), np.full(50, 1.0)]  # on it: 0.0 beyond
    landing_y = np.zeros(landing.size)
    if seed == 1:
        theta[40] = math.nan
    if seed == 2:
        x[window + 3] = math.inf
    if seed == 3:  # a zero beyond where the way points back (-0.0 of each product)
        landing, landing_y = -landing, -landing_y

    def judged() -> list[Any]:
        return [
            regulated(x, y, theta, target, goal, NUMBERS),
            regulated(x, y, theta, target, goal, NUMBERS, [rock]),
            regulated(x[:window], y[:window], theta[:window], target, goal, NUMBERS),
            regulated(x[:1], y[:1], theta[:1], target, goal, NUMBERS),
            regulated(passing, passing * 0.0, passing, (1.0, 0.0, 0.0), goal, NUMBERS),
            regulated(landing, landing_y, landing, (landing[-1], 0.0, 0.0), goal, NUMBERS),
            regulated(x, y, theta, (float(x[0]), float(y[0]), 0.0), goal, NUMBERS),
            stall_time(x[:window], y[:window], theta[:window], target, goal, NUMBERS),
        ]

    with np.errstate(invalid="ignore"):  # an infinite position's products, as plain Python
        _both(monkeypatch, judged, "regulation_pass")
    found = judged()
    assert found[1][0] is None  # a target within the rock
    assert found[3][0] == 0.0  # no whole window
    assert found[4][1] == pytest.approx(0.5)
    assert found[5][1] == 0.0
    assert found[6][1] is None  # it starts at its target
    if seed == 0:
        assert found[0][0] is not None
        assert found[0][0] > 0.0


@pytest.mark.parametrize(
    ("semi_axes", "rotation", "inside"),
    [((5.5, 3.0), 0.0, True), ((2.0, 4.0), 0.7, True), ((3.0, 1.0), -2.0, False)],
)
def test_the_ellipse_bounds_pass_has_the_numpy_forms_bits(
    semi_axes: tuple[float, float], rotation: float, inside: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Points about the edge of an ellipse zone, on both sides (and on its axes)."""
    region = {"type": "ellipse", "center": [0.5, -1.0], "semi_axes": list(semi_axes)}
    region["rotation"] = rotation
    zone = Zone("ellipse", region, inside)
    rng = np.random.default_rng(7)
    angle = rng.uniform(0, 2 * math.pi, 500)
    scale = rng.uniform(0.6, 1.4, 500)
    a, b = semi_axes
    u, w = a * scale * np.cos(angle), b * scale * np.sin(angle)
    if rotation == 0.0:  # on the axes (turned, they would be a rounding off them)
        u[:5], w[5:10] = 0.0, 0.0
    c, s = math.cos(rotation), math.sin(rotation)
    x, y = 0.5 + c * u - s * w, -1.0 + s * u + c * w

    gap_x, gap_y = x.copy(), y.copy()
    gap_x[[3, 400]], gap_y[17] = math.nan, math.inf  # (a position not finite: beyond none)

    def judged() -> list[Any]:
        return [
            zone.beyond(x, y),
            zone.max_depth(x, y),
            zone.deepest(x[:50], y[:50]),
            zone.beyond(gap_x, gap_y),
            zone.deepest(x[-1:], y[-1:]),
        ]

    def depths() -> list[Any]:  # a few points (stepped as Python numbers), and many
        return [zone.depth(x[:6], y[:6]), zone.depth(x, y), zone.depth(x, y, within=0.3)]

    with np.errstate(invalid="ignore"):  # numpy's products of an infinite position
        _both(monkeypatch, judged, "ellipse_bounds")
        _both(monkeypatch, judged, "ellipse_deepest")
    _both(monkeypatch, depths, "ellipse_depth")


def test_the_largest_finite_pass_has_the_numpy_forms_bits(monkeypatch: pytest.MonkeyPatch) -> None:
    """The largest of a column's finite values, of some of them, scaled, and of
    their magnitudes; NaN and infinities left out, and none when none is finite."""
    from wmr_mission.verdicts import metrics

    rng = np.random.default_rng(5)
    values = rng.normal(0.0, 2.0, 1001)
    values[[3, 500]], values[[7, 800]], values[900] = math.nan, math.inf, -math.inf
    values[-1] = -50.0  # the largest magnitude, at the last sample
    chosen = rng.uniform(size=values.size) < 0.7
    chosen[-1] = False  # not chosen: the largest chosen magnitude is another
    nothing = np.full(20, math.nan)
    nothing[4] = math.inf

    def judged() -> list[float | None]:
        return [
            metrics._largest(values),
            metrics._largest(values, chosen),
            metrics._largest(values, magnitude=True),
            metrics._largest(values, chosen, magnitude=True),
            metrics._largest(values, factor=-1.0, divisor=0.3),
            metrics._largest(nothing),
            metrics.overshoot(values[10:], 0.5),
        ]

    _both(monkeypatch, judged, "largest_finite")
    found = judged()
    assert found[2] == 50.0  # not trivial: the magnitude, finite values only
    assert found[3] is not None
    assert 0.0 < found[3] < 50.0
    assert found[5] is None


def test_the_estimation_passes_have_the_numpy_forms_bits(monkeypatch: pytest.MonkeyPatch) -> None:
    """The run's estimation errors (headings wrapped from many turns away, at
    pi exactly, NaN and infinite) and the first sample within the tolerances,
    found by samples on the edge of the position's ellipse (where hypot
    decides) and by one within it whose heading is not."""
    from types import SimpleNamespace

    from wmr_mission.verdicts import metrics
    from wmr_mission.verdicts.inputs import first_judged

    rng = np.random.default_rng(11)
    samples = 400
    t = np.arange(samples) * 0.01
    x, y = rng.normal(0.0, 1.0, samples), rng.normal(0.0, 1.0, samples)
    theta = rng.uniform(-40.0, 40.0, samples)
    theta_est = theta - rng.choice([math.pi, -math.pi, 0.3, 7.0, 1e6], samples)
    theta_est[250:] = theta[250:] - 1e-4  # converged in the end
    theta[[5, 6]] = math.nan, math.inf
    x_est = x - rng.normal(0.0, 0.5, samples) * np.exp(-t)
    y_est = y - rng.normal(0.0, 0.5, samples) * np.exp(-t)
    result = SimpleNamespace(x=x, y=y, theta=theta, x_est=x_est, y_est=y_est, theta_est=theta_est)
    numbers = mission_numbers(None, 0.01, (1.0, 2.0))
    tolerance = numbers.convergence_tolerance
    on_edge = {"x": np.zeros(3), "y": np.zeros(3), "theta": np.zeros(3)}
    on_edge["x"][:2] = tolerance["x"] * (1.0 + np.array([4e-10, -4e-10]))  # beyond, within
    on_edge["theta"][0] = 0.0
    heading_off = {
        "x": np.zeros(2),
        "y": np.zeros(2),
        "theta": np.array([2.0, 0.0]) * tolerance["theta"],
    }

    def judged() -> list[Any]:
        errors = metrics.estimation_errors(result)  # type: ignore[arg-type]
        part = metrics.estimation_errors(result, slice(100, 300))  # type: ignore[arg-type]
        return [
            errors,
            part,
            first_judged(t, errors, numbers),
            first_judged(t[:3], on_edge, numbers),
            first_judged(t[:2], heading_off, numbers),
            first_judged(t[:2], {s: e[:2] for s, e in heading_off.items()} | {"x": np.ones(2)},
                         numbers),
        ]  # fmt: skip

    with np.errstate(invalid="ignore"):  # numpy's remainder of inf warns
        _both(monkeypatch, judged, "estimation_error_pass")
        _both(monkeypatch, judged, "first_within")
        found = judged()
    assert np.all(found[0]["theta"][np.isfinite(theta)] >= -math.pi)
    assert np.all(found[0]["theta"][np.isfinite(theta)] < math.pi)
    assert found[3] == t[1]
    assert found[4] == t[1]
    assert found[5] is None
    assert found[2] is not None


# Heading differences whose value shifted by pi is at the ends of (0, 2 pi),
# just within and just beyond them: where the passes take the shifted value
# itself, and where the float remainder wraps it.
_HEADING_EDGES = [
    math.pi,
    -math.pi,
    float(np.nextafter(math.pi, 0.0)),
    float(np.nextafter(-math.pi, 0.0)),
    float(np.nextafter(math.pi, 4.0)),
    float(np.nextafter(-math.pi, -4.0)),
    3 * math.pi,
    -3 * math.pi,
    1e-300,
    -1e-300,
    0.0,
    2.5,
    -2.5,
]


def test_the_passes_wrap_headings_at_the_edges_as_numpy_does(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The estimation errors' and the stall's headings, compiled, take the
    difference plus pi as its own remainder only strictly within (0, 2 pi): a
    difference just below pi whose shift rounds to 2 pi wraps to -pi, as
    numpy's remainder has it, not to pi."""
    from types import SimpleNamespace

    from wmr_mission.verdicts import metrics

    edges = np.array(_HEADING_EDGES * 3)
    estimate = np.repeat([0.0, 1e-3, -2.0], len(_HEADING_EDGES))
    theta = edges + estimate
    zeros = np.zeros(edges.size)
    result = SimpleNamespace(x=zeros, y=zeros, theta=theta, x_est=zeros, y_est=zeros,
                             theta_est=estimate)  # fmt: skip
    # a robot at its target, its heading at the edges (the goal met at none)
    far = np.full(400, 0.5)  # (more than a window)
    heading = np.concatenate([np.full(10, value) for value in _HEADING_EDGES * 4])[:400]

    def judged() -> list[Any]:
        return [
            metrics.estimation_errors(result),  # type: ignore[arg-type]
            stall_time(far, far * 0.0, heading, (0.0, 0.0, 0.0), (0.01, 1e-3), NUMBERS),
        ]

    _both(monkeypatch, judged, "estimation_error_pass")
    _both(monkeypatch, judged, "regulation_pass")
    wrapped = judged()[0]["theta"]
    assert wrapped[2] == -math.pi  # just below pi: its shift is 2 pi, wrapped


def test_the_reference_distance_pass_has_the_numpy_forms_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Each sample's distance from its reference point (NaN, infinite, and
    squares beyond the largest float), and their RMS."""
    from wmr_mission.verdicts import metrics

    rng = np.random.default_rng(9)
    samples = 7001
    x, y = rng.normal(0.0, 1.0, samples), rng.normal(0.0, 1.0, samples)
    x_ref, y_ref = x + rng.normal(0.0, 0.1, samples), y + rng.normal(0.0, 0.1, samples)
    x[[5, 6]], y_ref[7], x_ref[8] = math.nan, math.inf, 1e300

    def judged() -> list[Any]:
        distance = metrics.reference_distance(x, y, x_ref, y_ref)
        return [distance, metrics.reference_error(distance[10:])]

    with np.errstate(over="ignore", invalid="ignore"):  # numpy's squares overflow
        _both(monkeypatch, judged, "reference_distances")
        found = judged()
    assert found[0][8] == math.inf
    assert math.isnan(found[0][5])
    assert found[1] is not None


def test_the_convergence_pass_has_the_numpy_forms_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The first sample from which every estimation error stays within its
    tolerance (never, from the first, from the last; NaN and a value on the
    tolerance itself not within)."""
    from wmr_mission.verdicts import metrics

    rng = np.random.default_rng(8)
    samples = 500
    decay = np.exp(-np.arange(samples) * 0.02)
    errors = {state: rng.normal(0.0, 1.0, samples) * decay for state in ("x", "y", "theta")}
    tolerance = {"x": 0.01, "y": 0.02, "theta": 0.05}
    late = {state: error.copy() for state, error in errors.items()}
    late["theta"][400] = math.nan
    late["y"][450] = 0.02  # on the tolerance: not below it
    never = {state: error.copy() for state, error in errors.items()}
    never["x"][-1] = 1.0
    always = {state: np.zeros(10) for state in errors}
    empty = {state: np.zeros(0) for state in errors}

    def judged() -> list[Any]:
        return [
            metrics.convergence_index(errors, tolerance),
            metrics.convergence_index(late, tolerance),
            metrics.convergence_index(never, tolerance),
            metrics.convergence_index(always, tolerance),
            metrics.convergence_index(empty, tolerance),
        ]

    _both(monkeypatch, judged, "last_unconverged")
    found = judged()
    assert 0 < found[0] < found[1] == 451
    assert found[2:] == [None, 0, None]


@pytest.mark.parametrize("seed", range(4))
def test_the_kept_up_pass_has_the_numpy_forms_bits(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A robot that closes on its reference, keeps up with it a while, drifts,
    stops and keeps up again: the first sample by which it has kept up, from
    the start, from within a run of samples with it, and past them all."""
    from wmr_mission.verdicts.tracking import _kept_up

    rng = np.random.default_rng(seed)
    samples = 1500
    k = np.arange(samples)
    rx, ry = k * 0.01 * (0.5 + 0.1 * seed), np.sin(k * 0.003)
    gap = np.where(k < 300, 0.5 * (1.0 - k / 300.0), 0.0)
    gap[701:800] += 0.3  # a drift off its reference
    px, py = rx - gap + rng.normal(0.0, 2e-4, samples), ry + rng.normal(0.0, 2e-4, samples)
    px[1000:1100] = px[1000]  # at rest while the reference moves on
    if seed == 3:
        px[500] = math.nan

    def judged() -> list[int | None]:
        return [
            _kept_up(px, py, rx, ry, NUMBERS, begin, end)
            for begin, end in ((0, samples), (0, 200), (350, samples), (720, samples),
                               (1000, samples), (1050, 1120), (samples, samples), (10, 5))
        ]  # fmt: skip

    _both(monkeypatch, judged, "kept_up")
    found = judged()
    assert found[0] is not None
    assert found[0] > 300  # the gap taken out first
    assert found[1] is None
    assert found[5] is None  # at rest while the reference moves on


def test_judging_the_compile_commands_warm_up_calls_every_pass(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`wmr-mission compile` judges one warm-up run (phases of 5 samples): each
    pass is called there, so each is compiled into the cache with the loop."""
    from wmr_mission.commands.compile import first_variant, warm_up_missions
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.verdicts.metrics import judge

    mission = warm_up_missions()[first_variant()]  # the run it judges
    with monkeypatch.context() as patch:
        patch.setattr(jit, "loaded", lambda: False)
        patch.setattr(jit, "compiled", lambda fn, **options: jit.plain(fn))
        result = run_mission(plan_mission(mission))  # as plain Python: 11 samples
    with _counted(monkeypatch, compiled=False) as called:
        judge(result, mission)
    assert set(passes.__all__) <= set(called)


@pytest.mark.parametrize("offset", [1e-300, 1e-17, -1e-17])
def test_a_point_a_rounding_off_the_major_axis_is_as_deep_as_one_on_it(
    offset: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Newton's start for a point inside, t = b w - b^2, rounds t + b^2 to zero
    when w is below b^2's rounding: the depth was NaN, compiled and in numpy."""
    region = {"type": "ellipse", "center": [0.0, 0.0], "semi_axes": [2.0, 1.0], "rotation": 0.0}
    zone = Zone("ellipse", region, False)
    x = np.array([0.5, 0.5, -1.2, 0.5])
    y = np.array([offset, 0.0, offset, 1e-9])

    def depths() -> list[Any]:
        return [zone.depth(x, y), zone.depth(np.repeat(x, 10), np.repeat(y, 10))]

    with monkeypatch.context() as patch:
        patch.setattr(jit, "judging_compiled", lambda: False)
        few, many = depths()
    assert np.all(np.isfinite(few))
    assert np.array_equal(few, many[::10])
    assert few[0] == few[1]
    assert few[2] == zone.depth(np.array([-1.2]), np.array([0.0]))[0]
    assert few[3] == pytest.approx(few[1], abs=1e-8)  # beside it, a step away in w
    _both(monkeypatch, depths, "ellipse_depth")


def test_the_passes_run_compiled_once_the_process_has_judged_enough_samples(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Loading them costs a process 0.03-0.05 s: a short run's judge keeps the
    numpy forms (the same bits), a long run or a campaign's worker past its
    first rows the passes (kernels/jit.py, JUDGED_COMPILED_FROM)."""
    monkeypatch.setattr(jit._state, "ready", True)
    monkeypatch.setattr(jit._state, "judged", 0)
    jit.judged(jit.JUDGED_COMPILED_FROM - 1)
    assert not jit.judging_compiled()
    jit.judged(1)
    assert jit.judging_compiled()
    monkeypatch.setattr(jit._state, "ready", False)  # numba not loaded: numpy however many
    assert not jit.judging_compiled()


@pytest.mark.parametrize("seed", range(3))
def test_the_entry_pass_has_the_numpy_forms_bits(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The samples of a track phase's entry (kept_up with times): a robot that
    closes on its reference and keeps up, one that never does, one whose
    entry outlasts the phase, and phases of one and two samples."""
    from wmr_mission.verdicts.tracking import _entry_judged

    rng = np.random.default_rng(seed)
    samples = 800
    k = np.arange(samples)
    t = k * 0.01
    rx, ry = k * 0.01 * (0.5 + 0.1 * seed), np.cos(k * 0.004)
    gap = np.where(k < 200, 0.4 * (1.0 - k / 200.0), 0.0)
    px, py = rx - gap + rng.normal(0.0, 2e-4, samples), ry + rng.normal(0.0, 2e-4, samples)
    far = px - 1.0  # never keeps up
    if seed == 2:
        px[100] = math.nan

    def judged() -> list[Any]:
        found = []
        for x in (px, far):
            for bound in (0.0, 1.5, 5.0, 20.0, math.nan):
                for n in (samples, 1, 2, 300):
                    sampled = (t[:n], bound, (x[:n], py[:n]), (rx[:n], ry[:n]), NUMBERS)
                    flags, count = _entry_judged(*sampled)
                    found.append((flags.tolist(), count))
        return found

    _both(monkeypatch, judged, "kept_up")
    found = judged()
    assert 200 < found[8][1] < 500  # kept up before the bound's end (5 s)
    assert found[20 + 8][1] == 500  # never kept up: the whole bound


def test_the_heading_errors_wrap_many_turns_round_as_numpy_does(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Heading errors of any number of turns either way, whole turns a
    rounding or two either side, and beyond the few million turns whose
    remainder the passes take apart: numpy's remainder's bits."""
    from types import SimpleNamespace

    from wmr_mission.verdicts import metrics

    rng = np.random.default_rng(12)
    turns = 2.0 * math.pi * np.arange(-3000, 3000)
    values = [
        rng.uniform(-1e3, 1e3, 4000),
        rng.uniform(-2.0 * math.pi, 2.0 * math.pi, 1000),
        rng.uniform(-1e9, 1e9, 200),
        turns - math.pi,  # whole turns once pi is added
        np.nextafter(turns, math.inf) - math.pi,
        np.nextafter(turns, -math.inf) - math.pi,
        turns * (1.0 + 2.0**-52) - math.pi,
        turns * (1.0 - 2.0**-52) - math.pi,
        np.array([0.0, -0.0, 1e-300, -1e-300, 2.0**26, -(2.0**26), 1e300, math.nan, -math.inf]),
    ]
    theta = np.concatenate(values)
    zeros = np.zeros(theta.size)
    result = SimpleNamespace(x=zeros, y=zeros, theta=theta, x_est=zeros, y_est=zeros,
                             theta_est=zeros)  # fmt: skip

    def judged() -> list[Any]:
        return [metrics.estimation_errors(result)]  # type: ignore[arg-type]

    with np.errstate(invalid="ignore"):  # numpy's remainder of inf warns
        _both(monkeypatch, judged, "estimation_error_pass")


def _phase(t: np.ndarray, x: np.ndarray, start: int, end: int) -> Any:
    """A phase's samples of a run of sample times ``t`` and positions ``x``
    (and y, the heading alike), its settle time 0.5 s."""
    from types import SimpleNamespace

    from wmr_mission.verdicts import metrics

    result = SimpleNamespace(t=t, v=t, omega=t, dt=0.01, x=x, y=x.copy(), theta=x.copy())
    info = SimpleNamespace(name="go", kind="track")
    judged = metrics._Judged(NUMBERS, None, {}, None, None)
    entry = metrics.Entry(0, start, end, None)
    return metrics.PhaseSamples(result, info, entry, 0.5, metrics._off_path_bound, judged)  # type: ignore[arg-type]


def test_the_settled_samples_pass_has_the_numpy_forms_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A phase's samples after its settle time, their count and whether they
    are its last ones (a slice), of sample times in order, on the settle time
    to a rounding, going back, NaN, and of phases of no sample and of all or
    none settled."""
    t = np.arange(300) * 0.01
    back = t.copy()
    back[250] = 0.1  # a time going back: the settled ones not the last ones
    gap = t.copy()
    gap[120] = math.nan
    positions = np.zeros(t.size)

    def judged() -> list[Any]:
        found = []
        for times in (t, back, gap, t + 1e-12, t - 1e-12):
            for start, end in ((0, 300), (100, 300), (0, 40), (7, 7), (120, 175), (260, 300)):
                phase = _phase(times, positions, start, end)
                settled = phase.settled
                if isinstance(settled, slice):
                    settled = (settled.start, settled.stop)
                found.append([phase.settled_samples, settled])
        return found

    _both(monkeypatch, judged, "settled_count")
    found = judged()
    assert found[0] == [250, (50, 300)]
    assert isinstance(found[6][1], np.ndarray)  # not the last ones: the mask


def test_the_finite_poses_pass_has_the_numpy_forms_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Whether every pose of a phase is finite: NaN, an infinity, and none."""
    t = np.arange(50) * 0.01
    x = np.linspace(0.0, 1.0, t.size)
    x[10], x[30] = math.nan, math.inf

    def judged() -> list[bool]:
        return [
            _phase(t, x, start, end).pose_finite
            for start, end in ((0, 50), (11, 30), (11, 31), (0, 10), (10, 11), (5, 5))
        ]

    _both(monkeypatch, judged, "poses_finite")
    assert judged() == [False, True, False, True, False, True]


@pytest.mark.parametrize(
    ("semi_axes", "rotation", "inside"),
    [((5.5, 3.0), 0.0, True), ((2.0, 4.0), 0.7, False), ((1.5, 1.5), -2.0, True)],
)
def test_a_points_side_of_an_ellipse_is_its_depths(
    semi_axes: tuple[float, float], rotation: float, inside: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Zone.holds_beyond of a point, near an ellipse's edge (a rounding off
    it, on it) and away from it, and at its centre: whether its depth is
    above 0, compiled and in numpy."""
    region = {"type": "ellipse", "center": [0.5, -1.0], "semi_axes": list(semi_axes)}
    region["rotation"] = rotation
    zone = Zone("ellipse", region, inside)
    rng = np.random.default_rng(3)
    angle = rng.uniform(0, 2 * math.pi, 300)
    scale = np.r_[rng.uniform(0.0, 2.0, 100), 1.0 + rng.integers(-4, 5, 200) * 2.0**-52]
    a, b = semi_axes
    u, w = a * scale * np.cos(angle), b * scale * np.sin(angle)
    c, s = math.cos(rotation), math.sin(rotation)
    x, y = np.r_[0.5 + c * u - s * w, 0.5, math.nan], np.r_[-1.0 + s * u + c * w, -1.0, 0.0]
    for compiled in (False, True):
        with _counted(monkeypatch, compiled):
            for px, py in zip(x.tolist(), y.tolist(), strict=True):
                depth = zone.depth(np.array([px]), np.array([py]))[0]
                assert zone.holds_beyond(px, py) == (depth > 0.0)
