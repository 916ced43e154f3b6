"""The reference step (numpy/scipy) against the fast kernels: the oracle.

Whole missions: the paper's two case studies and two short missions covering
the EKF, partial measurement sets, noise, rate limits, the other regulation
forms and half-plane constraint rows. Then each function on random inputs.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from wmr_mission.basics import STATES, measurement_mask
from wmr_mission.commands.bench import one_blas_thread
from wmr_mission.controllers import paper
from wmr_mission.controllers.paper import PaperTuning
from wmr_mission.estimators import ekf, observer
from wmr_mission.estimators.ekf import ekf_tuning
from wmr_mission.estimators.observer import observer_tuning
from wmr_mission.kernels import jit
from wmr_mission.kernels.corrective import corrective_input_array
from wmr_mission.kernels.model import saturate
from wmr_mission.kernels.records import Plant, scratch
from wmr_mission.kernels.riccati import MIN_SPEED
from wmr_mission.output.result import RunResult
from wmr_mission.sim import reference
from wmr_mission.sim.plan import MissionPlan, plan_mission
from wmr_mission.sim.reference import REFERENCE
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission, load_mission_text

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
STATE_COLUMNS = ("x", "y", "theta", "x_est", "y_est", "theta_est", "v", "omega")
SUBSETS = [list(c) for n in (1, 2, 3) for c in itertools.combinations(STATES, n)]
DT = 0.01
# The fast kernels as the loop runs them: compiled (plain Python without numba).
observer_step = jit.compiled(observer.observer_step)
ekf_step = jit.compiled(ekf.ekf_step)
track_input = jit.compiled(paper.track_input)
regulate_input = jit.compiled(paper.regulate_input)

# EKF, positions measured with noise, rate limits, the literal eq. (19)
# (increment form) inside a box (four half-plane rows).
EKF_MISSION = """
version: 1
name: oracle-ekf
robot:
  limits: {v: 2, omega: 3, v_rate: 5, omega_rate: 20}
sensors:
  measure: [x, y]
  noise_std: {x: 0.01, y: 0.01}
  seed: 7
estimator:
  type: ekf
  initial_estimate: {x: 0.2, y: -0.1, theta: 0.1}
controller:
  regulation: {form: increment}
regions:
  yard: {type: box, min: [-1, -1], max: [1.6, 1.2]}
phases:
  - name: out
    track: {path: {type: circle, center: [0, 1], radius: 1, angular_rate: 0.5}}
    until: {elapsed: 4}
  - name: back
    regulate: {target: {x: 0.5, y: 0.5, theta: 0}}
    constraints: [{stay_inside: yard}]
    until: {elapsed: 3}
"""

# The paper's observer with the heading unmeasured (seen through the motion),
# distinct poles and asymmetric bounds, tracking only: at rest the heading is
# unobservable from positions.
HEADINGLESS_MISSION = """
version: 1
name: oracle-headingless
sensors:
  measure: [x, y]
  noise_std: {x: 0.002, y: 0.002}
  seed: 3
estimator:
  type: constrained-observer
  initial_estimate: {x: 0.3, y: -0.2, theta: 0.2}
  poles: {x: 0.8, y: 0.8, theta: 0.95}
  output_error_bounds: {x: [-0.02, 0.03], y: [-0.03, 0.02]}
phases:
  - name: line
    track: {path: {type: line, heading: 0.2, speed: 0.8}}
    until: {elapsed: 2}
  - name: turn
    track: {path: {type: circle, center: [1.5, 1.5], radius: 1, angular_rate: 1}}
    until: {elapsed: 3}
"""

# The whole pose measured with distinct poles, the deviation form driving
# straight at a rock it must stay out of, then a hold phase.
DEVIATION_MISSION = """
version: 1
name: oracle-deviation
sensors:
  noise_std: {x: 0.001, y: 0.001, theta: 0.001}
estimator:
  type: constrained-observer
  initial_estimate: {x: 0.05, y: -0.05, theta: 0.02}
  poles: {x: 0.7, y: 0.85, theta: 0.9}
controller:
  regulation: {form: deviation}
regions:
  rock: {type: circle, center: [2.744, 0.556], radius: 0.3}
phases:
  - name: line
    track: {path: {type: line, heading: 0.2, speed: 0.8}}
    until: {elapsed: 2.5}
  - name: push
    regulate: {target: {x: 3.332, y: 0.675, theta: 0.2}}
    constraints: [{stay_outside: rock}]
    until: {elapsed: 2}
  - name: wait
    hold: {}
    until: {elapsed: 0.5}
"""

OTHER_MISSIONS = {
    "ekf": EKF_MISSION,
    "headingless": HEADINGLESS_MISSION,
    "deviation": DEVIATION_MISSION,
}


def assert_same_run(fast: RunResult, slow: RunResult, tolerance: float = 1e-6) -> None:
    assert fast.outcome == slow.outcome
    assert fast.samples == slow.samples
    assert [(t.time, t.from_phase, t.to_phase, t.condition) for t in fast.transitions] == [
        (t.time, t.from_phase, t.to_phase, t.condition) for t in slow.transitions
    ]
    np.testing.assert_array_equal(fast.phase, slow.phase)
    np.testing.assert_array_equal(fast.phase2_iterations, slow.phase2_iterations)
    for name in STATE_COLUMNS:
        np.testing.assert_allclose(
            getattr(fast, name), getattr(slow, name), rtol=0.0, atol=tolerance, err_msg=name
        )


def case_study(name: str) -> MissionPlan:
    return plan_mission(load_mission(MISSIONS / f"{name}.yaml"))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["case1", "case2"])
def test_fast_kernels_follow_the_reference_through_the_case_studies(name: str) -> None:
    mission = case_study(name)
    fast = run_mission(mission)
    with one_blas_thread():  # 3x3 BLAS calls: threads only wait
        slow = run_mission(mission, substitutes=REFERENCE)
    assert fast.outcome.value == "success"
    assert len(fast.transitions) == len(mission.phases)
    assert_same_run(fast, slow)


@pytest.mark.parametrize("name", list(OTHER_MISSIONS))
def test_fast_kernels_follow_the_reference_on_other_settings(name: str) -> None:
    mission = plan_mission(load_mission_text(OTHER_MISSIONS[name], f"{name}.yaml"))
    fast = run_mission(mission)
    slow = run_mission(mission, substitutes=REFERENCE)
    assert fast.samples > 400
    assert_same_run(fast, slow)


def test_the_other_missions_exercise_what_they_claim() -> None:
    """The settings above are not idle: constraints and phase II act."""
    runs = {
        name: run_mission(plan_mission(load_mission_text(text, f"{name}.yaml")))
        for name, text in OTHER_MISSIONS.items()
    }
    for run in runs.values():
        assert run.outcome.value == "success"
    ekf = runs["ekf"]
    assert np.nanmax(ekf.constraint[ekf.phase == 1]) > -0.1
    assert runs["headingless"].phase2_iterations.max() >= 1
    deviation = runs["deviation"]
    pushing = deviation.phase == 1
    # It drives at the rock and stops on its boundary grown by the estimate's
    # margin (0.05 m, eq. (4)'s default bound): 0.35 m from the centre.
    assert deviation.constraint_margin == 0.05
    closest = 0.3 * np.sqrt(1.0 - np.nanmax(deviation.constraint[pushing]))
    assert 0.345 < closest < 0.36


# --- unit level ------------------------------------------------------------


def random_pose(rng: np.random.Generator) -> np.ndarray:
    return rng.uniform([-5.0, -5.0, -4.0], [5.0, 5.0, 4.0])


def random_speed(rng: np.random.Generator) -> float:
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 5.0))


def test_placed_poles_are_the_closed_form_design(rng: np.random.Generator) -> None:
    """scipy's place_poles with the whole pose measured gives (I - L C) A = diag(poles)."""
    for _ in range(20):
        a = reference.state_jacobian(rng.uniform(-4, 4), random_speed(rng), rng.uniform(-3, 3), DT)
        poles = rng.uniform(0.0, 0.99, 3)
        gain = reference.observer_gain_matrix(a, np.ones(3), poles)
        np.testing.assert_allclose((np.eye(3) - gain) @ a, np.diag(poles), atol=1e-12)


@pytest.mark.parametrize("measured", SUBSETS, ids=["+".join(s) for s in SUBSETS])
@pytest.mark.parametrize("bounded", [False, True], ids=["phase-I", "phase-II"])
def test_observer_step_matches(
    measured: list[str], bounded: bool, rng: np.random.Generator
) -> None:
    mask = measurement_mask(measured)
    iterations_seen = 0
    for trial in range(30):
        estimate = random_pose(rng)
        # Some samples at rest: the heading is unobservable from positions then.
        v = 0.0 if trial % 10 == 0 else random_speed(rng)
        omega = float(rng.uniform(-3, 3))
        measurement = estimate + rng.normal(0.0, 0.3, 3)
        poles = rng.uniform(0.0, 0.99, 3)
        floor = float(rng.choice([0.0, 0.05]))  # 0.05 m/sample: above some speeds
        lower = -rng.uniform(0.01, 0.1, 3)
        upper = rng.uniform(0.01, 0.1, 3)
        results = []
        for step_function in (observer_step, reference.observer_step):
            state = estimate.copy()
            gain = np.zeros((3, 3))
            iterations = step_function(
                state, v, omega, DT, measurement,
                observer_tuning(mask, poles, floor, lower, upper, bounded, 10), gain, poles,
            )  # fmt: skip
            results.append((state, gain, iterations))
        (fast, fast_gain, fast_iterations), (slow, slow_gain, slow_iterations) = results
        np.testing.assert_allclose(fast, slow, rtol=0.0, atol=1e-9)
        np.testing.assert_allclose(fast_gain, slow_gain, rtol=0.0, atol=1e-9)
        assert fast_iterations == slow_iterations
        iterations_seen += slow_iterations
    assert (iterations_seen > 0) == bounded


def test_phase_two_puts_violated_outputs_on_their_bounds() -> None:
    estimate = np.array([1.0, 2.0, 0.5])
    measurement = np.array([1.5, 2.0, 0.5])
    state = estimate.copy()
    iterations = reference.observer_step(
        state, 0.0, 0.0, DT, measurement,
        observer_tuning(np.ones(3), np.full(3, 0.99), 0.0, np.full(3, -0.05), np.full(3, 0.05),
                        True, 10),
        np.zeros((3, 3)), np.full(3, 0.99),
    )  # fmt: skip
    assert iterations == 1
    assert measurement[0] - state[0] == pytest.approx(0.05)


@pytest.mark.parametrize("measured", SUBSETS, ids=["+".join(s) for s in SUBSETS])
def test_ekf_step_matches(measured: list[str], rng: np.random.Generator) -> None:
    mask = measurement_mask(measured)
    for _ in range(20):
        estimate = random_pose(rng)
        root = rng.normal(0.0, 0.5, (3, 3))
        covariance = root @ root.T + 0.01 * np.eye(3)
        v, omega = random_speed(rng), float(rng.uniform(-3, 3))
        measurement = estimate + rng.normal(0.0, 0.3, 3)
        process_var = rng.uniform(0.0, 1e-4, 3)
        measurement_var = rng.uniform(1e-6, 1e-2, 3)
        outputs = []
        for step_function in (ekf_step, reference.ekf_step):
            state, p = estimate.copy(), covariance.copy()
            step_function(
                state, p, v, omega, DT, measurement,
                ekf_tuning(mask, process_var, measurement_var), np.zeros((4, 3, 3)),
            )  # fmt: skip
            outputs.append((state, p))
        np.testing.assert_allclose(outputs[0][0], outputs[1][0], rtol=0.0, atol=1e-9)
        np.testing.assert_allclose(outputs[0][1], outputs[1][1], rtol=1e-9, atol=1e-12)


NO_LIMITS = np.full(4, math.inf)


def test_corrective_law_matches_for_one_and_two_rows(rng: np.random.Generator) -> None:
    for rows in (1, 2):
        for trial in range(50):
            v = 0.0 if trial % 10 == 0 else random_speed(rng)
            b = reference.input_jacobian(rng.uniform(-4, 4), v, rng.uniform(-3, 3), DT)
            d = rng.normal(0.0, 1.0, (rows, 3))
            eta = rng.normal(0.0, 0.1, rows)
            w, m = rng.uniform(1, 200, 3), rng.uniform(1, 200, 2)
            fast = corrective_input_array(d, eta, b, w, m)
            slow = reference.corrective_input(d, eta, b, w, m, NO_LIMITS)
            np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-12)
            # eq. (26): the linearised constraint is met (regularisation aside).
            if v != 0.0:
                np.testing.assert_allclose(d @ b @ slow, eta, rtol=1e-6, atol=1e-12)
            # Truncated to an input range: the same in both.
            limits = np.array([*rng.uniform(0.01, 2.0, 2), math.inf, math.inf])
            fast = corrective_input_array(d, eta, b, w, m, (limits[0], limits[1]))
            slow = reference.corrective_input(d, eta, b, w, m, limits)
            np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-12)


def test_corrective_law_at_rest_leaves_the_unreachable_part() -> None:
    """A lateral constraint cannot be moved at rest: no input, not NaN."""
    b = reference.input_jacobian(0.0, 0.0, 0.0, DT)
    du = reference.corrective_input(
        np.array([[0.0, 1.0, 0.0]]),
        np.array([0.5]),
        b,
        np.full(3, 100.0),
        np.full(2, 100.0),
        NO_LIMITS,
    )
    np.testing.assert_array_equal(du, np.zeros(2))


def random_limits(rng: np.random.Generator, rated: bool) -> np.ndarray:
    rates = rng.uniform(1.0, 50.0, 2) if rated else np.full(2, math.inf)
    return np.concatenate([rng.uniform(0.5, 10.0, 2), rates])


@pytest.mark.parametrize(
    ("look_ahead", "error_decay"), [(0.0, 0.0), (0.05, 0.0), (0.3, 0.0), (0.05, 0.9), (0.3, 0.9)]
)
@pytest.mark.parametrize("rated", [False, True], ids=["no-rate-limit", "rate-limit"])
def test_track_input_matches(
    look_ahead: float, error_decay: float, rated: bool, rng: np.random.Generator
) -> None:
    for _ in range(40):
        estimate = random_pose(rng)
        u_prev = np.array([random_speed(rng), rng.uniform(-3, 3)])
        angle = rng.uniform(-math.pi, math.pi)
        reference_point = np.concatenate(
            [estimate[:2] + rng.normal(0.0, 0.2, 2), [math.cos(angle), math.sin(angle)]]
        )
        angle = rng.uniform(-math.pi, math.pi)
        reference_now = np.concatenate(
            [estimate[:2] + rng.normal(0.0, 0.2, 2), [math.cos(angle), math.sin(angle)]]
        )
        w, m = rng.uniform(1, 200, 3), rng.uniform(1, 200, 2)
        limits = random_limits(rng, rated)
        fast, slow = np.zeros(2), np.zeros(2)
        controller = PaperTuning(
            look_ahead, error_decay, np.ones(3), np.ones(2), w, m, 0, 0.01, False
        )
        robot = Plant(DT, limits)
        track_input(
            estimate, u_prev, reference_now, reference_point, controller, robot, scratch(), fast
        )
        reference.track_input(
            estimate, u_prev, reference_now, reference_point, controller, robot, scratch(), slow
        )
        np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-9)


def violated_rows(
    rng: np.random.Generator, position: np.ndarray, violated: int, total: int = 4
) -> tuple[np.ndarray, np.ndarray]:
    """``total`` rows of mixed kinds, ``violated`` of them violated by far more
    than one sample's motion near ``position``."""
    kinds, params = [], []
    for i in range(total):
        is_violated = i < violated
        margin = rng.uniform(0.5, 2.0)
        choice = rng.integers(3)
        if choice == 0:  # half-plane through a point `margin` away
            angle = rng.uniform(-math.pi, math.pi)
            normal = np.array([math.cos(angle), math.sin(angle)])
            offset = normal @ position + (-margin if is_violated else margin)
            kinds.append(1)
            params.append([normal[0], normal[1], offset, 0.0, 0.0, 0.0])
        elif choice == 1:  # stay inside an ellipse (violated: the point is outside)
            axes = rng.uniform(0.3, 1.0, 2)
            center = position + (
                rng.choice([-1.0, 1.0], 2) * (axes + margin) if is_violated else 0.0
            )
            size = 1.0 if is_violated else 3.0 + margin
            kinds.append(0)
            params.append([*center, *(axes * size), rng.uniform(-3, 3), 1.0])
        else:  # stay outside an ellipse (violated: the point is inside)
            axes = rng.uniform(3.0, 5.0, 2)
            center = position if is_violated else position + 2.0 * axes + margin
            kinds.append(0)
            params.append([*center, *axes, rng.uniform(-3, 3), -1.0])
    order = rng.permutation(total)
    return np.array(kinds, dtype=np.int64)[order], np.array(params)[order]


FORMS = {"bearing": paper.BEARING, "deviation": paper.DEVIATION, "increment": paper.INCREMENT}


@pytest.mark.parametrize("violated", [0, 1, 2, 3])
@pytest.mark.parametrize("form", list(FORMS))
def test_regulate_input_matches(violated: int, form: str, rng: np.random.Generator) -> None:
    corrected = 0
    for trial in range(12):
        estimate = random_pose(rng)
        estimate_prev = estimate - rng.normal(0.0, 0.01, 3)
        target = estimate + rng.normal(0.0, 0.5 if trial % 3 else 0.005, 3)
        u_prev = np.array([random_speed(rng), rng.uniform(-2, 2)])
        kinds, params = violated_rows(rng, estimate[:2], violated)
        q, r = rng.uniform(0.1, 10, 3), rng.uniform(0.1, 10, 2)
        w, m = rng.uniform(1, 200, 3), rng.uniform(1, 200, 2)
        limits = random_limits(rng, bool(trial % 2))
        outputs = []
        for regulate in (regulate_input, reference.regulate_input):
            memory = np.zeros(paper.MEMORY_SIZE)
            memory[paper.ALIGNING] = float(trial % 2)
            u = np.zeros(2)
            controller = PaperTuning(0.0, 0.0, q, r, w, m, FORMS[form], 0.01, bool(trial % 4))
            regulate(
                estimate, estimate_prev, u_prev, target, kinds, params, controller,
                Plant(DT, limits), memory, scratch(), u,
            )  # fmt: skip
            outputs.append((u, memory))
        (fast, fast_memory), (slow, slow_memory) = outputs
        np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-9)
        assert fast_memory[paper.ALIGNING] == slow_memory[paper.ALIGNING]
        assert fast_memory[paper.CORRECTED] == slow_memory[paper.CORRECTED]
        corrected += int(slow_memory[paper.CORRECTED])
    assert corrected == (12 if violated else 0)


@pytest.mark.parametrize("barrier_rate", [1.0, 0.2])
def test_regulate_input_matches_with_a_zone_astride_the_braking_line(
    barrier_rate: float,
) -> None:
    """At 3 m/s and 1.5 m/s^2 the braking line runs 3 m on, through a circle
    1.5 m ahead to 1 m past it: the row is held on the whole line (its end
    is outside the circle), in the reference as in the compiled law. Held at
    the end alone, the reference corrected nothing."""
    from wmr_mission.geometry.regions import CircleRegion, constraint_rows

    kinds, params = constraint_rows(
        CircleRegion(type="circle", center=(1.5, 0.0), radius=0.5), "outside"
    )
    estimate = np.zeros(3)
    outputs = []
    for regulate in (regulate_input, reference.regulate_input):
        memory = np.zeros(paper.MEMORY_SIZE)
        u = np.zeros(2)
        controller = PaperTuning(
            0.0, 0.0, np.ones(3), np.ones(2), np.full(3, 100.0), np.full(2, 100.0),
            paper.DEVIATION, barrier_rate, False,
        )  # fmt: skip
        regulate(
            estimate, estimate, np.array([3.0, 0.0]), np.array([6.0, 0.0, 0.0]), kinds,
            params, controller, Plant(DT, np.array([4.0, 3.0, 1.5, 10.0])), memory,
            scratch(), u,
        )  # fmt: skip
        outputs.append((u, memory[paper.CORRECTED]))
    (fast, fast_corrected), (slow, slow_corrected) = outputs
    assert fast_corrected == slow_corrected == 1.0
    np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize(("acceleration", "v_prev"), [(math.inf, 0.0), (20.0, 0.4)])
def test_regulate_input_matches_where_it_moves_back_towards_the_regulators(
    acceleration: float, v_prev: float
) -> None:
    """By a pentagon's corner (tests/data/zones/park-by-a-corner.yaml at 8 s,
    where the robot stood before), the deviation form (the reference knows
    no way round a polygon): eq. (28) alone backs the robot off at 0.08 m/s
    where the barrier lets it on at 0.44; the input moves back towards the
    regulator's by the share at which the row still holds, in the reference
    as in the compiled law (controllers/paper.py, _share_kept). Under an
    acceleration limit the row held on the braking line is checked too (there
    it does not hold at eq. (28)'s input: no share)."""
    from wmr_mission.geometry.regions import PolygonRegion, constraint_rows

    corners = ((-3.262, 3.008), (-4.269, 2.03), (-3.738, 1.934), (-3.662, 1.954), (-3.275, 2.253))
    kinds, params = constraint_rows(PolygonRegion(type="polygon", vertices=corners), "outside")
    estimate = np.array([-3.21639750837, 3.0047873336, 2.89729358154])
    limits = np.array([5.871, 8.272, acceleration, math.inf])
    dt = 0.008
    outputs = []
    for regulate in (regulate_input, reference.regulate_input):
        memory = np.zeros(paper.MEMORY_SIZE)
        u = np.zeros(2)
        controller = PaperTuning(
            0.0, 0.0, np.ones(3), np.array([1.0, 0.1]), np.full(3, 100.0), np.full(2, 100.0),
            paper.DEVIATION, 0.05, True, barrier_rate=dt / paper.BARRIER_TIME,
        )  # fmt: skip
        regulate(
            estimate, estimate, np.array([v_prev, 0.0]), np.array([-7.241, 3.759, 0.346]),
            kinds, params,
            controller, Plant(dt, limits, constraint_margin=0.003), memory, scratch(), u,
        )  # fmt: skip
        outputs.append((u, memory[paper.CORRECTED]))
    (fast, fast_corrected), (slow, slow_corrected) = outputs
    assert fast_corrected == slow_corrected == 1.0
    np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-9)
    if v_prev == 0.0:
        assert fast[0] == pytest.approx(0.437, abs=0.005)  # eq. (28) alone: -0.082


@pytest.mark.parametrize(
    ("low", "high", "tolerance"),
    [
        (0.0, 0.0, 1e-9),  # at rest: the reachable-subspace solution
        (0.05, 10.0, 1e-9),
        # Near rest eq. (21) is ill-conditioned: scipy's solution has a relative
        # residual of ~1e-12 there (the doubling's ~1e-16), so the gains agree
        # to ~1e-8 only.
        (1e-5, 0.01, 2e-7),
    ],
)
def test_scheduled_gain_matches(
    low: float, high: float, tolerance: float, rng: np.random.Generator
) -> None:
    work = scratch()
    for _ in range(30):
        theta, omega = rng.uniform(-4, 4), rng.uniform(-3, 3)
        v = float(rng.choice([-1.0, 1.0]) * rng.uniform(low, high))
        q, r = rng.uniform(0.1, 10, 3), rng.uniform(0.1, 10, 2)
        paper.scheduled_gain(theta, v, omega, DT, q, r, np.zeros(paper.MEMORY_SIZE), work.gain)
        slow = reference.scheduled_gain(theta, v, omega, DT, q, r)
        scale = max(1.0, float(np.abs(slow).max()))
        np.testing.assert_allclose(work.gain, slow, rtol=0.0, atol=tolerance * scale)


def test_scheduled_gain_is_continuous_at_the_speed_floor() -> None:
    q, r = np.ones(3), np.ones(2)
    below = reference.scheduled_gain(0.3, MIN_SPEED * (1 - 1e-9), 0.5, DT, q, r)
    at = reference.scheduled_gain(0.3, MIN_SPEED, 0.5, DT, q, r)
    np.testing.assert_allclose(below, at, atol=1e-6)


@pytest.mark.parametrize("rated", [False, True])
def test_saturation_matches(rated: bool, rng: np.random.Generator) -> None:
    for _ in range(100):
        v, omega, v_prev, omega_prev = rng.normal(0.0, 10.0, 4)
        limits = random_limits(rng, rated)
        assert saturate(v, omega, v_prev, omega_prev, limits, DT) == pytest.approx(
            reference.saturate(v, omega, v_prev, omega_prev, limits, DT), abs=1e-12
        )


def test_wrap_angle_matches_the_kernels() -> None:
    from wmr_mission.kernels.model import wrap_angle

    for angle in (-7.0, -math.pi, -1.0, 0.0, 1.0, math.pi, 7.0, 1e3):
        assert reference.wrap_angle(angle) == wrap_angle(angle)
