from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission.kernels import jit
from wmr_mission.kernels.model import f, hypot, input_jacobian, state_jacobian, step, wrap_angle


def central_difference(fun, point: np.ndarray, h: float = 1e-6) -> np.ndarray:  # type: ignore[no-untyped-def]
    columns = []
    for i in range(point.size):
        e = np.zeros_like(point)
        e[i] = h
        columns.append((fun(point + e) - fun(point - e)) / (2 * h))
    return np.column_stack(columns)


def test_step_matches_eq_1_written_out() -> None:
    x, y, th, v, om, dt = 0.3, -1.2, 0.7, 2.0, -1.5, 0.01
    expected = (
        x + dt * v * math.cos(th) - dt**2 / 2 * v * om * math.sin(th),
        y + dt * v * math.sin(th) + dt**2 / 2 * v * om * math.cos(th),
        th + dt * om,
    )
    assert step(x, y, th, v, om, dt) == pytest.approx(expected, rel=1e-15, abs=1e-15)


def test_heading_is_not_wrapped_by_the_model() -> None:
    assert step(0.0, 0.0, 3.1, 0.0, 10.0, 0.01)[2] == pytest.approx(3.2)


def test_jacobians_match_central_differences(rng: np.random.Generator) -> None:
    for _ in range(200):
        state = rng.uniform([-10, -10, -7], [10, 10, 7])
        u = rng.uniform([-10, -20], [10, 20])
        dt = float(rng.uniform(0.001, 0.1))
        a_fd = central_difference(lambda s, u=u, dt=dt: f(s, u, dt), state)
        b_fd = central_difference(lambda w, state=state, dt=dt: f(state, w, dt), u)
        np.testing.assert_allclose(state_jacobian(state, u, dt), a_fd, atol=1e-6)
        np.testing.assert_allclose(input_jacobian(state, u, dt), b_fd, atol=1e-6)


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [(0.0, 0.0), (math.pi / 2, math.pi / 2), (3 * math.pi, -math.pi), (-7.0, -7.0 + 2 * math.pi)],
)
def test_wrap_angle(angle: float, wrapped: float) -> None:
    assert wrap_angle(angle) == pytest.approx(wrapped)


def test_wrap_angle_is_the_remainder_to_the_bit(rng: np.random.Generator) -> None:
    # The kernel skips the remainder for angles already in range; it must give
    # the bits of the plain formula everywhere, the edges of the range included.
    edges = [0.0, -0.0, math.pi, -math.pi, 2 * math.pi, -2 * math.pi, 1e300, -1e300]
    edges += [math.nextafter(a, b) for a in (math.pi, -math.pi) for b in (-math.inf, math.inf)]
    edges += [math.nextafter(math.pi, math.inf) - math.pi, math.inf, -math.inf, math.nan]
    for angle in [*edges, *rng.uniform(-20.0, 20.0, 20_000), *rng.normal(0.0, 1e6, 1_000)]:
        expected = (angle + math.pi) % (2.0 * math.pi) - math.pi
        assert np.float64(wrap_angle(angle)).tobytes() == np.float64(expected).tobytes(), angle


def test_hypot_is_the_same_bits_compiled_and_as_plain_python(rng: np.random.Generator) -> None:
    """math.hypot is the C library's compiled and CPython's own as plain Python,
    which differ in the last bit about once in 500 calls; the kernels' hypot
    gives the plain-Python build the compiled build's bytes, within 2 ulp
    of the exact value (math.hypot's error is below 1 ulp)."""
    compiled_hypot = jit.compiled(hypot)
    pairs = rng.normal(size=(20_000, 2)) * rng.choice([1e-300, 1e-8, 1.0, 1e8, 1e300], (20_000, 1))
    edges = [(0.0, 0.0), (-0.0, 3.0), (3.0, -4.0), (math.inf, 1.0), (1.0, -math.inf)]
    edges += [(math.inf, math.nan), (math.nan, 1.0), (1e308, 1e308), (5e-324, 5e-324)]
    for x, y in [*edges, *pairs.tolist()]:
        compiled, python = compiled_hypot(x, y), hypot(x, y)
        assert np.float64(compiled).tobytes() == np.float64(python).tobytes(), (x, y)
        exact = math.hypot(x, y)
        if math.isfinite(exact) and exact > 0.0:
            assert abs(compiled - exact) <= 2.0 * math.ulp(exact), (x, y)
        else:
            assert compiled == exact or (math.isnan(compiled) and math.isnan(exact)), (x, y)
