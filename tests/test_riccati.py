from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from wmr_mission.controllers import paper
from wmr_mission.kernels.model import input_jacobian, state_jacobian
from wmr_mission.kernels.records import scratch
from wmr_mission.kernels.riccati import (
    MIN_SPEED,
    NEWTON_STEPS,
    Mat3,
    _mat3,
    dlqr,
    newton_riccati,
    scalar_solution,
    solve_riccati,
)
from wmr_mission.sim import reference


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
    work = scratch()
    memory = np.zeros(paper.MEMORY_SIZE)
    paper.scheduled_gain(theta, v, 0.0, 0.01, np.ones(3), np.ones(2), memory, work.gain)
    # At rest the closed form; elsewhere a cold doubling solve.
    assert (memory[paper.DOUBLINGS] > 0) == (v != 0.0)
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


# --- the solution methods of eq. (21) (docs/paper-notes.md) ------------------


def test_scalar_solution_is_the_scalar_riccati_root(rng: np.random.Generator) -> None:
    for _ in range(50):
        q, b, r = rng.uniform(0.01, 10), rng.uniform(1e-4, 1.0), rng.uniform(0.01, 10)
        p = scalar_solution(q, b, r)
        expected = scipy.linalg.solve_discrete_are([[1.0]], [[b]], [[q]], [[r]])[0, 0]
        assert p == pytest.approx(expected, rel=1e-12)
        assert p == pytest.approx(q + p - p * p * b * b / (r + b * b * p), rel=1e-13)
    assert scalar_solution(0.0, 0.01, 1.0) == 0.0  # no weight, no cost


def test_at_rest_the_closed_form_equals_the_doubling_on_the_reachable_subspace(
    rng: np.random.Generator,
) -> None:
    # The doubling of eq. (21) at v = 0 with Q-hat kept along the direction
    # u the speed input moves the robot: how the at-rest gain was solved before.
    for _ in range(40):
        theta, omega = rng.uniform(-4, 4), rng.uniform(-5, 5)
        q, r = rng.uniform(0.1, 10, 3), rng.uniform(0.1, 10, 2)
        a, b = paper_pair(theta, 0.0, omega)
        u = b[:2, 0] / np.linalg.norm(b[:2, 0])
        q_hat = np.zeros((3, 3))
        q_hat[:2, :2] = (u @ np.diag(q[:2]) @ u) * np.outer(u, u)
        q_hat[2, 2] = q[2]
        doubling, _, _ = dlqr(a, b, q_hat, r)
        work, memory = scratch(), np.zeros(paper.MEMORY_SIZE)
        paper.scheduled_gain(theta, 0.0, omega, 0.01, q, r, memory, work.gain)
        np.testing.assert_allclose(work.gain, doubling, rtol=0, atol=1e-12 * np.abs(doubling).max())
        assert memory[paper.NEWTON] == memory[paper.DOUBLINGS] == 0  # no iteration


def weaving_run(count: int = 250) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta, v, omega) of a robot slowing from 2 to 0.35 m/s while weaving, dt = 0.01."""
    t = np.arange(count) * 0.01
    v = 1.8 * np.exp(-t) + 0.2
    omega = 1.5 * np.sin(2.0 * t)
    return 0.3 + 0.01 * np.cumsum(omega), v, omega


def test_warm_started_solution_agrees_with_the_cold_doubling_and_scipy() -> None:
    q, r = np.array([1.0, 2.0, 0.5]), np.array([1.0, 0.5])
    memory, work = np.zeros(paper.MEMORY_SIZE), scratch()
    newton_steps = []
    for theta, v, omega in zip(*weaving_run(), strict=True):
        paper.scheduled_gain(theta, v, omega, 0.01, q, r, memory, work.gain)
        warm = work.gain.copy()
        newton_steps.append(memory[paper.NEWTON])
        if len(newton_steps) > 1:
            assert memory[paper.DOUBLINGS] == 0  # Newton from the previous samples
        cold = scratch()
        paper.scheduled_gain(theta, v, omega, 0.01, q, r, np.zeros(paper.MEMORY_SIZE), cold.gain)
        np.testing.assert_allclose(warm, cold.gain, rtol=0, atol=1e-12 * np.abs(cold.gain).max())
        # scipy's own solution is good to ~1e-12 here (a 40-digit solution
        # agrees with the warm-started one to ~1e-15).
        slow = reference.scheduled_gain(theta, v, omega, 0.01, q, r)
        np.testing.assert_allclose(warm, slow, rtol=0, atol=1e-11 * np.abs(slow).max())
        # The stored body-frame solution satisfies eq. (21).
        s = memory[paper.WARM_MOVING + 1 : paper.WARM_MOVING + 7]
        pi = np.array([[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]])
        a, b = paper_pair(0.0, v, omega)
        c, s_ = np.cos(theta), np.sin(theta)
        rot = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]])
        q_body = rot.T @ np.diag(q) @ rot
        gain = np.linalg.solve(np.diag(r) + b.T @ pi @ b, b.T @ pi @ a)
        residual = q_body + a.T @ pi @ (a - b @ gain) - pi
        assert np.abs(residual).max() <= 1e-12 * np.abs(pi).max()
    # A count, not a time: two Newton steps per sample on a smooth run.
    assert newton_steps[0] == 0
    assert max(newton_steps[1:]) <= 3
    assert np.mean(newton_steps[1:]) <= 2.1


def test_near_rest_the_warm_started_blend_agrees_with_the_cold_one() -> None:
    # Turning on the spot (|v| < MIN_SPEED): the at-rest closed form blended
    # with the solution at +-MIN_SPEED, warm-started from sample to sample.
    # Eq. (21) is ill-conditioned there (closed-loop radius 0.99999): the
    # doubling itself is only good to ~2e-11 (docs/paper-notes.md).
    q, r = np.ones(3), np.ones(2)
    memory, work = np.zeros(paper.MEMORY_SIZE), scratch()
    speeds = 0.8 * MIN_SPEED * np.cos(0.01 * np.arange(300))  # through 0 at k = 157
    steps = []
    for k, v in enumerate(speeds):
        omega = 1.5 * np.exp(-0.01 * k)
        theta = 1.5 * (1.0 - np.exp(-0.01 * k))
        paper.scheduled_gain(theta, v, omega, 0.01, q, r, memory, work.gain)
        steps.append((memory[paper.NEWTON], memory[paper.DOUBLINGS]))
        cold = scratch()
        paper.scheduled_gain(theta, v, omega, 0.01, q, r, np.zeros(paper.MEMORY_SIZE), cold.gain)
        np.testing.assert_allclose(work.gain, cold.gain, rtol=0, atol=1e-10)
    newton, doublings = np.array(steps).T
    # Doubling only where there is no solution at +-MIN_SPEED of the same sign.
    turned = np.flatnonzero(np.diff(np.sign(speeds))) + 1
    assert list(np.flatnonzero(doublings)) == [0, *turned] == [0, 158]
    # Near rest Newton converges linearly at first: three steps, four when
    # there is no change to extrapolate yet.
    assert newton.max() <= 4
    assert np.median(newton) <= 3


def step_counts(memory: np.ndarray) -> tuple[int, int]:
    return int(memory[paper.NEWTON]), int(memory[paper.DOUBLINGS])


def test_each_fallback_to_the_doubling() -> None:
    q, r = np.ones(3), np.ones(2)

    def gain(theta: float, v: float, omega: float, memory: np.ndarray) -> np.ndarray:
        work = scratch()
        paper.scheduled_gain(theta, v, omega, 0.01, q, r, memory, work.gain)
        return work.gain

    def cold(theta: float, v: float, omega: float) -> np.ndarray:
        return gain(theta, v, omega, np.zeros(paper.MEMORY_SIZE))

    # No warm start (a phase's first sample): doubling.
    memory = np.zeros(paper.MEMORY_SIZE)
    gain(0.3, 0.5, 0.2, memory)
    assert step_counts(memory)[0] == 0
    assert step_counts(memory)[1] > 0
    # The next sample: Newton.
    gain(0.31, 0.51, 0.2, memory)
    assert step_counts(memory)[0] > 0
    assert step_counts(memory)[1] == 0
    # The speed changed sign: doubling, exactly the cold solution.
    assert np.array_equal(gain(0.31, -0.51, 0.2, memory), cold(0.31, -0.51, 0.2))
    assert step_counts(memory)[0] == 0
    assert step_counts(memory)[1] > 0
    # A warm start too far off (5 cm/s, then 1.1 mm/s): one Newton step, then doubling.
    memory = np.zeros(paper.MEMORY_SIZE)
    gain(0.0, 0.05, 0.5, memory)
    assert np.array_equal(gain(0.0, 0.0011, 0.5, memory), cold(0.0, 0.0011, 0.5))
    assert step_counts(memory)[0] == 1
    assert step_counts(memory)[1] > 0
    # No weight on the position: the Newton step's Lyapunov system is singular.
    q = np.array([0.0, 0.0, 1.0])
    memory = np.zeros(paper.MEMORY_SIZE)
    gain(0.3, 0.5, 0.2, memory)
    assert np.array_equal(gain(0.31, 0.51, 0.2, memory), cold(0.31, 0.51, 0.2))
    assert step_counts(memory)[0] == 1
    assert step_counts(memory)[1] > 0


def body_pair(v: float, omega: float) -> tuple[Mat3, tuple[float, ...], Mat3]:
    a, b = paper_pair(0.0, v, omega)
    g = b @ b.T
    return _mat3(a), tuple(b.reshape(6)), _mat3(g)


def test_newton_gives_up_after_newton_steps(rng: np.random.Generator) -> None:
    # Warm starts perturbed by up to 45 % of the solution: some stay within
    # reach but converge too slowly.
    q = _mat3(np.eye(3))
    outcomes = set()
    for _ in range(200):
        a, b, g = body_pair(10 ** rng.uniform(-3, 0.5), rng.uniform(-2, 2))
        exact, _ = solve_riccati(a, g, q)
        p = np.array(exact).reshape(3, 3)
        d = rng.normal(size=(3, 3))
        d = (d + d.T) * rng.uniform(0.05, 0.45) * np.abs(p).max() / np.abs(d + d.T).max()
        pi, steps = newton_riccati(a, b, np.ones(2), q, _mat3(p + d), np.zeros(42), 0)  # type: ignore[arg-type]
        outcomes.add(steps)
        if steps > 0:
            np.testing.assert_allclose(pi, exact, rtol=0, atol=1e-10 * np.abs(p).max())
    assert -NEWTON_STEPS in outcomes  # gave up: not converged within NEWTON_STEPS
    assert -1 in outcomes  # gave up: the first correction was beyond NEWTON_REACH


def test_newton_does_not_trust_a_solution_that_is_not_the_stabilising_one() -> None:
    # Decoupled states: A = diag(1, 1, 0.5), the first driven by b0, the second
    # by b1, the third unreachable but stable. Each scalar Riccati equation has
    # a negative root besides the stabilising one; starting Newton on the
    # solution made of the negative root for the first state, it converges at
    # once to that non-stabilising solution, which is not positive definite.
    a = _mat3(np.diag([1.0, 1.0, 0.5]))
    b = (0.1, 0.0, 0.0, 0.2, 0.0, 0.0)
    q, r = np.diag([1.0, 2.0, 1.0]), np.array([1.0, 0.5])
    negative = 0.5 - np.sqrt(0.25 + 1.0 * 1.0 / 0.1**2)
    stabilising = scalar_solution(2.0, 0.2, 0.5)
    start = np.diag([negative, stabilising, 1.0 / 0.75])
    pi, steps = newton_riccati(a, b, r, _mat3(q), _mat3(start), np.zeros(42), 0)
    np.testing.assert_allclose(np.array(pi).reshape(3, 3), start, atol=1e-12)
    assert steps < 0
    # From the stabilising solution it is trusted.
    start[0, 0] = scalar_solution(1.0, 0.1, 1.0)
    _, steps = newton_riccati(a, b, r, _mat3(q), _mat3(start), np.zeros(42), 0)
    assert steps > 0


def test_a_controller_memory_too_small_is_refused() -> None:
    # Compiled code checks no bounds: a memory of the old size (3) would be
    # written past its end.
    with pytest.raises(ValueError, match="MEMORY_SIZE"):
        paper.scheduled_gain(
            0.0, 0.5, 0.0, 0.01, np.ones(3), np.ones(2), np.zeros(3), scratch().gain
        )
