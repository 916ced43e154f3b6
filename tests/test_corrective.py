from __future__ import annotations

import numpy as np
import pytest

from wmr_mission.kernels.corrective import corrective_input_array, max_row_value, row_value
from wmr_mission.kernels.model import f, input_jacobian

W = np.full(3, 100.0)
M = np.full(2, 100.0)


def test_two_constraints_are_met_exactly_when_reachable(rng: np.random.Generator) -> None:
    for _ in range(200):
        state = rng.uniform([-5, -5, -4], [5, 5, 4])
        u = rng.uniform([0.2, -5], [5, 5]) * rng.choice([-1, 1], 2)
        b = input_jacobian(state, u, 0.01)
        d = rng.normal(size=(2, 3))
        eta = rng.normal(size=2)
        du = corrective_input_array(d, eta, b, W, M)
        # eq. (26) with eq. (24): D B du = eta.
        np.testing.assert_allclose(d @ b @ du, eta, rtol=1e-7, atol=1e-9)


def test_one_constraint_is_met_with_the_smallest_weighted_change(rng: np.random.Generator) -> None:
    state = np.array([1.0, 2.0, 0.3])
    u = np.array([2.0, 0.5])
    b = input_jacobian(state, u, 0.01)
    d = np.array([[0.4, -1.2, 0.0]])
    eta = np.array([-0.01])
    du = corrective_input_array(d, eta, b, W, M)
    np.testing.assert_allclose(d @ b @ du, eta, rtol=1e-9)
    # Any other change meeting the constraint costs more in the norm of eq. (22).
    weight = b.T @ np.diag(W) @ b + np.diag(M)
    null = np.array([(d @ b)[0, 1], -(d @ b)[0, 0]])
    for scale in rng.normal(size=20):
        other = du + scale * null
        assert other @ weight @ other >= du @ weight @ du - 1e-15


def test_literal_law_equals_the_inverse_of_d_b_when_square() -> None:
    state = np.array([0.0, 0.0, 0.2])
    u = np.array([1.0, 0.1])
    b = input_jacobian(state, u, 0.01)
    d = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    eta = np.array([0.002, -0.001])
    du = corrective_input_array(d, eta, b, W, M)
    np.testing.assert_allclose(du, np.linalg.solve(d @ b, eta), rtol=1e-6)


def test_singular_case_at_rest_gives_a_finite_least_squares_answer() -> None:
    # At rest the axle cannot move sideways in one sample: D B is singular.
    state = np.array([0.0, 0.0, 0.0])
    b = input_jacobian(state, np.zeros(2), 0.01)
    d = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    eta = np.array([0.01, 0.02])  # the 0.02 m sideways is unreachable
    du = corrective_input_array(d, eta, b, W, M)
    assert np.all(np.isfinite(du))
    # The reachable part (forward 0.01 m) is met; the unreachable part ignored.
    np.testing.assert_allclose((d @ b @ du)[0], 0.01, rtol=1e-6)
    assert abs(du[1]) < 1e-6
    # Nothing reachable at all: no change.
    assert np.all(corrective_input_array(np.zeros((1, 3)), np.array([1.0]), b, W, M) == 0.0)


def test_corrective_action_keeps_the_robot_inside_the_ellipse_of_eq_33() -> None:
    kinds = np.array([0])
    params = np.array([[0.0, 0.0, 5.5, 3.0, 0.0, 1.0]])
    state = np.array([5.49, 0.0, 0.0])
    u = np.array([3.0, 0.0])  # heading straight out of the ellipse
    predicted = f(state, u, 0.01)
    value, gx, gy = row_value(0, params[0], predicted[0], predicted[1])
    assert value > 0
    b = input_jacobian(state, u, 0.01)
    du = corrective_input_array(np.array([[gx, gy, 0.0]]), np.array([-value]), b, W, M)
    corrected = f(state, u + du, 0.01)
    # The linearised constraint of eq. (26) holds exactly; the true one up to
    # second order in the 3 cm step: from 7e-3 to 1e-5.
    linearised = value + np.array([gx, gy, 0.0]) @ (b @ du)
    assert linearised == pytest.approx(0.0, abs=1e-12)
    after = max_row_value(kinds, params, corrected[0], corrected[1])
    assert value > 5e-3
    assert abs(after) < 2e-5


def test_row_gradients_match_finite_differences(rng: np.random.Generator) -> None:
    rows = [
        (0, np.array([0.5, -1.0, 5.5, 3.0, 0.4, 1.0])),
        (0, np.array([0.0, 0.0, 2.0, 2.0, 0.0, -1.0])),
        (1, np.array([0.6, 0.8, 2.0, 0.0, 0.0, 0.0])),
    ]
    h = 1e-6
    for kind, params in rows:
        for _ in range(20):
            x, y = rng.uniform(-6, 6, 2)
            _, gx, gy = row_value(kind, params, x, y)
            fx = (row_value(kind, params, x + h, y)[0] - row_value(kind, params, x - h, y)[0]) / (
                2 * h
            )
            fy = (row_value(kind, params, x, y + h)[0] - row_value(kind, params, x, y - h)[0]) / (
                2 * h
            )
            assert gx == pytest.approx(fx, abs=1e-6)
            assert gy == pytest.approx(fy, abs=1e-6)


def test_ellipse_row_is_eq_33() -> None:
    params = np.array([0.0, 0.0, 5.5, 3.0, 0.0, 1.0])
    for x, y in [(0.0, 0.0), (5.5, 0.0), (1.0, 2.0), (6.0, 1.0)]:
        value, _, _ = row_value(0, params, x, y)
        assert value == pytest.approx((x / 5.5) ** 2 + (y / 3) ** 2 - 1)


LIMITS = (10.0, 20.0)  # |v| [m/s], |omega| [rad/s] of the case studies


def test_one_nearly_unreachable_row_asks_for_no_more_than_the_inputs_span() -> None:
    # A lateral gradient while creeping at 1e-9 m/s: the exact law of eq. (28)
    # asks for a turn rate of order -1e11 rad/s. Truncated to the inputs, the
    # change stays within the span of the inputs (limit to limit), in the
    # direction that moves the row.
    state = np.array([0.0, 0.0, 0.0])
    b = input_jacobian(state, np.array([1e-9, 0.0]), 0.01)
    d = np.array([[0.0, 1.0, 0.0]])
    eta = np.array([-0.01])
    exact = corrective_input_array(d, eta, b, W, M)
    assert abs(exact[1]) > 1e10  # the literal answer without an input range
    du = corrective_input_array(d, eta, b, W, M, LIMITS)
    assert abs(du[0]) <= 2 * LIMITS[0]
    assert abs(du[1]) == pytest.approx(2 * LIMITS[1])
    assert (d @ b @ du)[0] * eta[0] > 0  # towards the constraint, not away


@pytest.mark.parametrize("speed", [1e-3, 1e-4, 1e-5, 1e-6])
def test_two_nearly_dependent_rows_meet_their_reachable_part(speed: float) -> None:
    # The axle at two constraints while creeping: S = D B Rw^-1 (D B)^T has a
    # condition number from about 1e8 to 1e12 [~ (2 / (speed dt))^2]. The change
    # stays within the inputs' span and the reachable (forward) part of eta is
    # met exactly.
    b = input_jacobian(np.array([0.0, 0.0, 0.3]), np.array([speed, 0.0]), 0.01)
    d = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    eta = np.array([0.004, 0.02])
    weight = np.linalg.inv(b.T @ np.diag(W) @ b + np.diag(M))
    s = d @ b @ weight @ (d @ b).T
    values, vectors = np.linalg.eigh(s)
    assert values[1] / values[0] > 1e7
    du = corrective_input_array(d, eta, b, W, M, LIMITS)
    assert np.all(np.abs(du) <= 2 * 2 * np.array(LIMITS))
    reachable = vectors[:, 1]
    residual = reachable @ (d @ b @ du - eta)
    assert abs(residual) <= 1e-9 * abs(reachable @ eta)
