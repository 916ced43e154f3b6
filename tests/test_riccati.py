from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from wmr_mission.model import input_jacobian, state_jacobian
from wmr_mission.riccati import MIN_SPEED, dlqr


def paper_pair(
    theta: float, v: float, omega: float, dt: float = 0.01
) -> tuple[np.ndarray, np.ndarray]:
    state = np.array([0.0, 0.0, theta])
    u = np.array([v, omega])
    return state_jacobian(state, u, dt), input_jacobian(state, u, dt)


def test_agrees_with_scipy_on_random_well_posed_pairs(rng: np.random.Generator) -> None:
    for _ in range(100):
        theta = rng.uniform(-7, 7)
        v = rng.choice([-1, 1]) * rng.uniform(0.05, 10)
        a, b = paper_pair(theta, v, rng.uniform(-20, 20), rng.uniform(0.005, 0.05))
        q = rng.uniform(0.01, 10, 3)
        r = rng.uniform(0.01, 10, 2)
        gain, pi, doublings = dlqr(a, b, q, r)
        expected = scipy.linalg.solve_discrete_are(a, b, np.diag(q), np.diag(r))
        assert doublings > 0
        np.testing.assert_allclose(pi, expected, rtol=1e-8, atol=1e-8 * np.abs(expected).max())
        expected_gain = np.linalg.solve(np.diag(r) + b.T @ expected @ b, b.T @ expected @ a)
        np.testing.assert_allclose(gain, expected_gain, rtol=1e-8, atol=1e-10)


def test_solution_satisfies_eq_21_in_its_inverse_form() -> None:
    a, b = paper_pair(0.4, 2.0, 0.7)
    q, r = np.ones(3), np.ones(2)
    _, pi, _ = dlqr(a, b, q, r)
    # eq. (21): pi = Q + A^T (pi^-1 + B R^-1 B^T)^-1 A
    rhs = np.diag(q) + a.T @ np.linalg.inv(np.linalg.inv(pi) + b @ np.diag(1 / r) @ b.T) @ a
    np.testing.assert_allclose(pi, rhs, rtol=1e-10)


def test_gain_of_eq_20_equals_the_usual_form() -> None:
    a, b = paper_pair(-1.2, 0.5, -3.0)
    r = np.array([1.0, 2.0])
    gain, pi, _ = dlqr(a, b, np.ones(3), r)
    r_inv = np.diag(1 / r)
    eq20 = r_inv @ b.T @ np.linalg.inv(np.linalg.inv(pi) + b @ r_inv @ b.T) @ a
    np.testing.assert_allclose(gain, eq20, rtol=1e-9, atol=1e-12)


def test_closed_loop_is_stable_where_well_posed(rng: np.random.Generator) -> None:
    for _ in range(20):
        a, b = paper_pair(rng.uniform(-3, 3), rng.uniform(0.1, 5), rng.uniform(-5, 5))
        gain, _, _ = dlqr(a, b, np.ones(3), np.ones(2))
        assert max(abs(np.linalg.eigvals(a - b @ gain))) < 1.0


@pytest.mark.parametrize("omega", [0.0, 0.5])
def test_at_rest_the_pair_is_not_stabilisable_and_scipy_has_no_answer(omega: float) -> None:
    a, b = paper_pair(0.3, 0.0, omega)
    # The lateral direction is unreachable at v = 0: rank [B, AB, A^2B] = 2.
    reach = np.hstack([b, a @ b, a @ a @ b])
    assert np.linalg.matrix_rank(reach) == 2
    try:
        pi = scipy.linalg.solve_discrete_are(a, b, np.eye(3), np.eye(2))
    except np.linalg.LinAlgError:
        return  # "Failed to find a finite solution."
    # Otherwise what comes back is no solution: huge, with a residual of order 1
    # and a closed loop with an eigenvalue on the unit circle.
    gain = np.linalg.solve(np.eye(2) + b.T @ pi @ b, b.T @ pi @ a)
    residual = pi - (np.eye(3) + a.T @ pi @ a - a.T @ pi @ b @ gain)
    assert np.abs(pi).max() > 1e6
    assert np.abs(residual).max() > 1e-3
    assert max(abs(np.linalg.eigvals(a - b @ gain))) == pytest.approx(1.0, abs=1e-9)


def body_gain(theta: float, v: float) -> np.ndarray:
    from wmr_mission import control
    from wmr_mission.params import scratch

    work = scratch()
    memory = np.zeros(control.MEMORY_SIZE)
    control.scheduled_gain(theta, v, 0.0, 0.01, np.ones(3), np.ones(2), memory, work)
    # At rest the closed form; elsewhere a cold doubling solve.
    assert (memory[control.DOUBLINGS] > 0) == (v != 0.0)
    rot = np.array(
        [[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]]
    )
    return np.asarray(work.gain @ rot)


@pytest.mark.parametrize("theta", [0.0, 0.8, -2.5])
def test_at_rest_returns_the_gain_on_the_reachable_subspace(theta: float) -> None:
    gain = body_gain(theta, 0.0)
    assert np.all(np.isfinite(gain))
    # Body frame: speed acts on the longitudinal error, turn rate on the
    # heading error; the unreachable lateral error gets no gain.
    k = gain[0, 0]
    assert k == pytest.approx(0.99501, abs=1e-4)
    np.testing.assert_allclose(gain, [[k, 0, 0], [0, 0, k]], atol=1e-4)
    # It is the mean of the one-sided limits v -> 0+ and v -> 0-, which differ
    # in the sign of the lateral gain (steering reverses with travel).
    forward = body_gain(theta, MIN_SPEED)
    backward = body_gain(theta, -MIN_SPEED)
    assert forward[1, 1] == pytest.approx(k, abs=1e-2)
    assert backward[1, 1] == pytest.approx(-k, abs=1e-2)
    np.testing.assert_allclose(gain, 0.5 * (forward + backward), atol=5e-3)


def test_gain_is_continuous_in_speed_through_rest() -> None:
    # The lateral gain swings from -k to +k across the band |v| < MIN_SPEED:
    # steep but continuous, so halving the speed step halves the largest jump.
    jumps = []
    for count in (61, 121):
        speeds = np.linspace(-3 * MIN_SPEED, 3 * MIN_SPEED, count)
        gains = np.array([body_gain(0.3, v) for v in speeds])
        jumps.append(np.abs(np.diff(gains, axis=0)).max())
    assert jumps[0] < 0.11
    assert jumps[1] < 0.55 * jumps[0]
    # Outside the blend band it is exactly the Riccati gain, solved in the
    # body frame.
    a, b = paper_pair(0.0, 2 * MIN_SPEED, 0.0)
    exact, _, _ = dlqr(a, b, np.ones(3), np.ones(2))
    np.testing.assert_allclose(body_gain(0.3, 2 * MIN_SPEED), exact, atol=1e-12)


def test_rotation_invariance_of_the_solution() -> None:
    # pi(theta) = Rot pi(0) Rot^T when Q weighs x and y alike.
    a0, b0 = paper_pair(0.0, 1.5, 0.4)
    a1, b1 = paper_pair(1.1, 1.5, 0.4)
    _, pi0, _ = dlqr(a0, b0, np.ones(3), np.ones(2))
    _, pi1, _ = dlqr(a1, b1, np.ones(3), np.ones(2))
    c, s = np.cos(1.1), np.sin(1.1)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    np.testing.assert_allclose(pi1, rot @ pi0 @ rot.T, rtol=1e-9)
