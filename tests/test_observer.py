from __future__ import annotations

import itertools

import numpy as np
import pytest

from wmr_mission.basics import STATES, measurement_mask
from wmr_mission.estimators.observability import structurally_unobservable, unobservable_states
from wmr_mission.estimators.observer import error_matrix, observer_step, observer_tuning
from wmr_mission.kernels.model import step

SUBSETS = [list(c) for n in (1, 2, 3) for c in itertools.combinations(STATES, n)]


def expected_eigenvalues(measured: list[str], poles: np.ndarray, moving: bool) -> list[float]:
    """The design of wmr_mission.estimators.observer, written out per measurement set."""
    names = set(measured)
    if "theta" in names:
        return [poles[i] if STATES[i] in names else 1.0 for i in range(3)]
    positions = [i for i in (0, 1) if STATES[i] in names]
    p_pos = float(np.mean(poles[positions]))
    values = [1.0 if STATES[i] not in names else p_pos for i in (0, 1)]
    values.append(poles[2] if moving else 1.0)
    return values


@pytest.mark.parametrize("measured", SUBSETS, ids=["+".join(s) for s in SUBSETS])
def test_phase_one_error_eigenvalues_are_the_configured_poles(
    measured: list[str], rng: np.random.Generator
) -> None:
    mask = measurement_mask(measured)
    for _ in range(20):
        state = rng.uniform([-5, -5, -4], [5, 5, 4])
        u = np.array([rng.choice([-1, 1]) * rng.uniform(0.2, 5), rng.uniform(-3, 3)])
        poles = rng.uniform(0.5, 0.98, 3)
        # Positions measured together share their pole when theta is not measured.
        if "theta" not in measured:
            poles[0] = poles[1]
        eig = np.sort(np.linalg.eigvals(error_matrix(state, u, 0.01, mask, poles)).real)
        expected = np.sort(expected_eigenvalues(measured, poles, moving=True))
        if measured in (["x"], ["y"]):
            # The heading is seen through one position only: the pair along c.
            expected = np.sort([poles[0], poles[2], 1.0])
        np.testing.assert_allclose(eig, expected, atol=1e-9)


def test_full_measurement_error_matrix_is_diagonal() -> None:
    poles = np.array([0.85, 0.9, 0.95])
    matrix = error_matrix(np.array([1.0, 2.0, 0.7]), np.array([3.0, 1.0]), 0.01, np.ones(3), poles)
    np.testing.assert_allclose(matrix, np.diag(poles), atol=1e-15)


@pytest.mark.parametrize("speed", [0.01, 0.05, 0.1, 0.3, 1.0])
def test_heading_pole_relaxes_below_the_motion_floor(speed: float) -> None:
    """Moving less than the floor per sample, the heading pole goes towards 1
    as 1 - (1 - p_theta) |c|^2 / floor^2; at or above it, it is as configured."""
    mask = measurement_mask(["x", "y"])
    poles = np.array([0.8, 0.8, 0.9])
    dt, floor = 0.01, 0.002  # floor = 0.2 m/s at this dt
    state, u = np.array([0.3, -0.2, 0.4]), np.array([speed, 0.0])
    eig = np.sort(np.linalg.eigvals(error_matrix(state, u, dt, mask, poles, floor)).real)
    moved = speed * dt  # |c| with omega = 0
    heading_pole = 1.0 - 0.1 * min(1.0, moved**2 / floor**2)
    np.testing.assert_allclose(eig, np.sort([0.8, 0.8, heading_pole]), atol=1e-9)


def test_position_noise_at_creeping_speed_does_not_throw_the_heading() -> None:
    """Positions measured with 2 mm noise while the robot creeps at 1 mm/s:
    without the floor one sample's noise moves the heading estimate by
    (1 - p_theta)(1 - p_pos) sigma / (v dt) = 2 rad; with it by at most 0.02 rad."""
    mask = measurement_mask(["x", "y"])
    poles = np.array([0.8, 0.8, 0.9])
    sigma, dt = 0.002, 0.01
    rng = np.random.default_rng(7)
    worst = {}
    for floor in (0.0, sigma):
        state = np.zeros(3)
        estimate = state.copy()
        gain = np.zeros((3, 3))
        largest = 0.0
        for _ in range(500):
            state = np.array(step(*state, 0.001, 0.0, dt))
            measurement = state + rng.normal(0.0, sigma, 3)
            observer_step(
                estimate, 0.001, 0.0, dt, measurement, observer_tuning(mask, poles, floor), gain,
                poles,
            )  # fmt: skip
            largest = max(largest, abs(estimate[2] - state[2]))
        worst[floor] = largest
    assert worst[0.0] > 1.0
    assert worst[sigma] < 0.1


def test_heading_from_positions_is_unobservable_at_rest() -> None:
    mask = measurement_mask(["x", "y"])
    poles = np.full(3, 0.9)
    eig = np.linalg.eigvals(error_matrix(np.zeros(3), np.zeros(2), 0.01, mask, poles))
    assert max(abs(eig)) == pytest.approx(1.0)


def run_observer(
    measured: list[str], initial_error: np.ndarray, samples: int, bounds: float | None = None
) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """A robot driving a circle; returns true states, estimates, phase-II iterations."""
    mask = measurement_mask(measured)
    poles = np.full(3, 0.9)
    lower = np.full(3, -np.inf if bounds is None else -bounds)
    upper = -lower
    gain = np.zeros((3, 3))
    state = np.array([0.0, 0.0, 0.0])
    estimate = state + initial_error
    states, estimates, iterations = [], [], []
    for _ in range(samples):
        v, omega = 1.0, 0.5
        state = np.array(step(*state, v, omega, 0.01))
        iterations.append(
            observer_step(
                estimate,
                v,
                omega,
                0.01,
                state.copy(),
                observer_tuning(mask, poles, 0.0, lower, upper, bounds is not None, 10),
                gain,
                poles,
            )
        )
        states.append(state)
        estimates.append(estimate.copy())
    return np.array(states), np.array(estimates), iterations


def test_paper_measurement_x_theta_leaves_y_unobservable() -> None:
    # Section IV: xi = [x, theta] and an estimate 1 m off in y.
    states, estimates, _ = run_observer(["x", "theta"], np.array([1.0, 1.0, 0.0]), 2000)
    errors = states - estimates
    assert abs(errors[-1, 0]) < 1e-9
    assert abs(errors[-1, 2]) < 1e-9
    # y never moves towards the truth: its error stays exactly 1 m.
    np.testing.assert_allclose(errors[:, 1], -1.0, atol=1e-9)
    trajectory = [np.array([0.0, 0.0, 0.005 * k]) for k in range(50)]
    inputs = [np.array([1.0, 0.5])] * 50
    assert unobservable_states(["x", "theta"], trajectory, inputs, 0.01) == ["y"]
    assert structurally_unobservable(["x", "theta"]) == ["y"]


def test_full_measurement_converges_within_a_second() -> None:
    states, estimates, _ = run_observer(list(STATES), np.array([1.0, 1.0, 0.0]), 100)
    assert np.abs(states - estimates)[-1].max() < 0.05


def test_position_only_recovers_the_heading_while_moving() -> None:
    states, estimates, _ = run_observer(["x", "y"], np.array([0.3, -0.2, 0.4]), 600)
    assert np.abs(states - estimates)[-1].max() < 1e-3
    trajectory = [np.array([0.0, 0.0, 0.005 * k]) for k in range(10)]
    assert unobservable_states(["x", "y"], trajectory, [np.array([1.0, 0.5])] * 10, 0.01) == []
    at_rest = [np.array([0.0, 0.0])] * 10
    assert unobservable_states(["x", "y"], trajectory, at_rest, 0.01) == ["theta"]


def test_phase_two_keeps_every_output_error_inside_its_bounds() -> None:
    states, estimates, iterations = run_observer(
        list(STATES), np.array([1.0, -2.0, 0.5]), 50, bounds=0.05
    )
    errors = states - estimates
    assert np.all(np.abs(errors) <= 0.05 + 1e-12)
    assert iterations[0] == 1  # the first sample needed phase II
    assert iterations[-1] == 0  # phase I alone is inside the bounds later


def test_phase_two_saturates_to_the_violated_bound(rng: np.random.Generator) -> None:
    mask = np.ones(3)
    lower = np.array([-0.1, -0.2, -0.05])
    upper = np.array([0.3, 0.1, 0.05])
    for _ in range(100):
        estimate = rng.uniform(-2, 2, 3)
        measurement = rng.uniform(-2, 2, 3)
        before = estimate.copy()
        observer_step(
            estimate,
            0.0,
            0.0,
            0.01,
            measurement,
            observer_tuning(mask, np.full(3, 0.9), 0.0, lower, upper, True, 10),
            np.zeros((3, 3)),
            np.full(3, 0.9),
        )
        phase_one = before + 0.1 * (measurement - before)  # poles 0.9, at rest
        error = measurement - estimate
        error[2] = (error[2] + np.pi) % (2 * np.pi) - np.pi
        assert np.all(error <= upper + 1e-12)
        assert np.all(error >= lower - 1e-12)
        # Outputs that were inside their bounds after phase I are untouched.
        inside = ((measurement - phase_one) <= upper) & ((measurement - phase_one) >= lower)
        inside[2] = False  # heading wraps; checked above
        np.testing.assert_allclose(estimate[inside], phase_one[inside], atol=1e-12)


def test_phase_two_iteration_matrix_is_not_a_contraction() -> None:
    # docs/paper-notes.md, eqs. (8)-(12): with H = D^T, (I - H D) A_c has
    # eigenvalues 0 (violated outputs) and 1 (the others): spectral radius 1,
    # and its 2-norm exceeds 1 once the robot moves. Phase II lands on the
    # bound in one step because D (I - H D) = 0, not because it contracts.
    from wmr_mission.kernels.model import state_jacobian

    a = state_jacobian(np.array([0.0, 0.0, 0.7]), np.array([2.0, 0.5]), 0.01)
    d = np.array([[1.0, 0.0, 0.0]])  # x violated
    iteration = (np.eye(3) - d.T @ d) @ a
    assert sorted(np.abs(np.linalg.eigvals(iteration))) == pytest.approx([0.0, 1.0, 1.0])
    assert np.linalg.norm(iteration, 2) > 1.0
    np.testing.assert_allclose(d @ (np.eye(3) - d.T @ d), 0.0)
