"""The control laws of section III.C on the paper's case studies, built by hand
(independent of the YAML front-end)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry import distance_to_ellipse
from hand_built import ELLIPSE_ROWS, case1, case2, mission, regulate_only, spiral

from wmr_mission.controllers.paper import BEARING, DEVIATION, INCREMENT, PaperTuning, track_input
from wmr_mission.kernels.model import saturate, step
from wmr_mission.kernels.records import Plant, scratch
from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome
from wmr_mission.sim.plan import Conditions, PhasePlan
from wmr_mission.sim.runner import run_mission


def wrap(a: np.ndarray | float) -> np.ndarray | float:
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def test_literal_axle_law_diverges_from_the_paper_start_and_is_detected() -> None:
    # Eq. (27) on the axle centre, no actuator limits, from x0 = 0, estimate [1, 1, 0].
    phases = [PhasePlan("spiral", "track", Conditions(elapsed_samples=500), None, True, spiral)]
    result = run_mission(mission(phases, look_ahead=0.0, error_decay=0.0, limits=(1e12, 1e12)))
    assert result.outcome is Outcome.diverged
    assert "diverged in phase 'spiral'" in result.message
    assert result.samples < 500
    # The turn rate passes 1e3 rad/s (the runaway bound) at the 6th sample,
    # where the run stops; left running it passes 1e4 at the 9th.
    assert result.samples == 6
    assert abs(result.omega[-1]) > 1e3
    assert "the input ran away" in result.message


def test_default_look_ahead_law_converges_from_the_paper_start() -> None:
    phases = [PhasePlan("spiral", "track", Conditions(elapsed_samples=90), None, True, spiral)]
    result = run_mission(mission(phases))
    assert result.outcome is Outcome.success
    error = np.hypot(result.x - result.x_ref, result.y - result.y_ref)
    assert error[0] == pytest.approx(2.0)  # the spiral starts 2 m away
    assert error[-2] < 0.01  # the last row is the end of the mission: no reference


def test_literal_axle_law_on_the_path_tracks_but_its_heading_dynamics_are_unstable() -> None:
    # Started on the spiral with its heading, speed and turn rate and an exact
    # estimate, the literal law holds the axle on the path to 1e-6 m for a
    # second: its failure from the paper's start is not a bug in eq. (27). But
    # the heading, which the law does not constrain, drifts away geometrically
    # (the zero dynamics of the one-sample law are unstable).
    dt = 0.01
    t = np.arange(0, 2, dt)
    x, y, dx, dy = spiral((0.0, 0.0, 0.0)).sample(t)
    speed = np.hypot(dx, dy)
    turn_rate = (dx * np.gradient(dy, dt) - dy * np.gradient(dx, dt)) / speed**2
    state = np.array([x[0], y[0], math.atan2(dy[0], dx[0])])
    u = np.array([speed[0], turn_rate[0]])
    out = np.zeros(2)
    work = scratch()
    robot = Plant(dt, np.array([1e12, 1e12, np.inf, np.inf]))
    controller = PaperTuning(
        0.0,
        0.0,
        np.ones(3),
        np.ones(2),
        np.full(3, 100.0),
        np.full(2, 100.0),
        BEARING,
        0.01,
        False,
    )
    position_error, turn_rate_error = [], []
    for k in range(150):
        reference = np.array(
            [x[k + 1], y[k + 1], dx[k + 1] / speed[k + 1], dy[k + 1] / speed[k + 1]]
        )
        track_input(state, u, reference, reference, controller, robot, work, out)
        u = out.copy()
        state = np.array(step(*state, u[0], u[1], dt))
        position_error.append(math.hypot(state[0] - x[k + 1], state[1] - y[k + 1]))
        turn_rate_error.append(abs(u[1] - turn_rate[k + 2]))
    assert max(position_error[:100]) < 1e-6
    assert max(turn_rate_error[120:]) > 10 * max(turn_rate_error[20:40])


def test_case_1_end_to_end() -> None:
    result = run_mission(case1())
    assert result.outcome is Outcome.success, result.message
    order = [t.to_phase for t in result.transitions]
    assert order == ["ellipse", "elliptical-spiral", "park", None]
    assert math.hypot(result.x[-1], result.y[-1]) < 0.02
    assert abs(wrap(result.theta[-1])) < 0.01
    on_ellipse = result.phase == 1
    start = result.t[on_ellipse][0]
    later = on_ellipse & (result.t >= start + 1.0)
    rms = math.sqrt(np.mean(distance_to_ellipse(result.x[later], result.y[later]) ** 2))
    assert rms <= 0.005  # the acceptance bound
    assert rms <= 1e-5  # what the look-ahead law achieves (1e-6 m measured)


def test_case_2_end_to_end() -> None:
    result = run_mission(case2())
    assert result.outcome is Outcome.success, result.message
    assert math.hypot(result.x[-1], result.y[-1]) < 0.05
    after = result.phase == 2
    g = (result.x[after] / 5.5) ** 2 + (result.y[after] / 3) ** 2
    assert g.max() <= 1.001
    errors = np.abs(
        np.column_stack(
            [
                result.x - result.x_est,
                result.y - result.y_est,
                wrap(result.theta - result.theta_est),
            ]
        )
    )
    assert errors[result.t >= 1.0].max() < 0.05


def _path_length(result: RunResult) -> float:
    return float(np.sum(np.hypot(np.diff(result.x), np.diff(result.y))))


def test_increment_form_of_eq_19_brings_the_robot_to_rest_not_to_the_target() -> None:
    # From rest with an exact estimate the state increment is zero and the
    # literal law never starts; with the estimate off, as in section IV, the
    # estimator's transient moves the robot, then it comes to rest, not at the
    # target: 1.0 m travelled, at rest 1.28 m from it.
    start = (2.0, 1.0, 0.5)
    still = run_mission(regulate_only((0.0, 0.0, 0.0), 20.0, start, form=INCREMENT))
    assert _path_length(still) == 0.0
    phases = [
        PhasePlan(
            "regulate", "regulate", Conditions(elapsed_samples=2000), None, True, None,
            (0.0, 0.0, 0.0),
        )
    ]  # fmt: skip
    result = run_mission(
        mission(phases, initial_state=start, initial_estimate=(1.0, 1.0, 0.0), form=INCREMENT)
    )
    assert _path_length(result) > 0.5
    assert abs(result.v[-1]) < 1e-3
    assert abs(result.omega[-1]) < 1e-3
    assert math.hypot(result.x[-1], result.y[-1]) > 1.0


def test_deviation_form_stalls_short_of_the_target() -> None:
    # Brockett: a smooth static feedback cannot park a unicycle. From a start
    # with a lateral error only it never moves (at rest the gain has no
    # lateral term); from (2, 1, 0.5) it drives 3.3 m and is still 0.22 m
    # from the target after 60 s (0.16 m after 120 s), creeping.
    still = run_mission(regulate_only((0.0, 0.0, 0.0), 5.0, (0.0, 0.5, 0.0), form=DEVIATION))
    assert _path_length(still) == 0.0
    result = run_mission(regulate_only((0.0, 0.0, 0.0), 60.0, (2.0, 1.0, 0.5), form=DEVIATION))
    assert _path_length(result) > 2.0
    assert math.hypot(result.x[-1], result.y[-1]) > 0.1


@pytest.mark.parametrize("start", [(0.0, 0.5, 0.0), (3.0, -2.0, 2.0), (-1.0, 0.2, -3.0)])
def test_bearing_form_parks_position_and_heading(start: tuple[float, float, float]) -> None:
    result = run_mission(regulate_only((0.0, 0.0, 0.0), 30.0, start, form=BEARING))
    assert math.hypot(result.x[-1], result.y[-1]) < 0.02
    assert abs(wrap(result.theta[-1])) < 0.02


def test_constraint_rows_keep_the_robot_inside_while_regulating() -> None:
    # A target outside the ellipse: the robot must stop on the boundary.
    phases = [
        PhasePlan(
            "out", "regulate", Conditions(elapsed_samples=1500), None, True, None,
            (8.0, 0.0, 0.0), ELLIPSE_ROWS, (("ellipse", "inside"),),
        )
    ]  # fmt: skip
    result = run_mission(mission(phases, initial_estimate=(0.0, 0.0, 0.0)))
    g = (result.x / 5.5) ** 2 + (result.y / 3) ** 2
    assert g.max() <= 1.001
    assert g[-1] > 0.99  # it went as far as it was allowed


def test_saturation_applies_magnitude_and_rate_limits() -> None:
    limits = np.array([1.0, 2.0, 10.0, 100.0])
    assert saturate(5.0, -5.0, 0.0, 0.0, limits, 0.01) == (pytest.approx(0.1), pytest.approx(-1.0))
    assert saturate(5.0, -5.0, 0.95, -1.99, limits, 0.01) == (1.0, -2.0)


def test_scheduled_gain_is_nearly_constant_but_for_the_heading_gain() -> None:
    # docs/paper-notes.md: the default regulator turns towards the target with
    # LQR-derived gains; over 0..10 m/s (Q = R = I, dt = 0.01) the longitudinal
    # and lateral gains stay near 0.995 while the heading gain grows from
    # 0.995 at rest to 4.53 at 10 m/s.
    from wmr_mission.controllers.paper import MEMORY_SIZE, scheduled_gain

    work = scratch()
    heading_gains = []
    for v in (0.0, 0.01, 0.1, 1.0, 3.0, 10.0, -10.0):
        memory = np.zeros(MEMORY_SIZE)
        scheduled_gain(0.0, v, 0.0, 0.01, np.ones(3), np.ones(2), memory, work.gain)
        gain = work.gain
        assert gain[0, 0] == pytest.approx(0.995, abs=1e-3)  # speed from distance along
        if v != 0.0:
            assert 0.97 < abs(gain[1, 1]) < 0.996  # turn rate from lateral error
        heading_gains.append(gain[1, 2])
    assert heading_gains[0] == pytest.approx(0.995, abs=1e-3)
    assert heading_gains[-2] == pytest.approx(4.53, abs=0.01)
    assert heading_gains[-1] == pytest.approx(heading_gains[-2])


@pytest.mark.parametrize(
    ("kinds", "params", "looked_for"),
    [
        ([1], [[1.0, 0.0, 3.0, 0.0, 0.0, 0.0]], False),  # a fence (half-plane)
        ([0], [[0.0, 0.0, 5.5, 3.0, 0.0, 1.0]], False),  # keep inside an ellipse
        ([1, 0], [[1.0, 0.0, 3.0, 0.0, 0.0, 0.0], [3.0, 0.2, 0.8, 0.8, 0.0, -1.0]], True),
    ],
)
def test_the_regulator_pays_for_no_way_round_and_no_braking_it_cannot_use(
    monkeypatch: pytest.MonkeyPatch, kinds: list[int], params: list[list[float]], looked_for: bool
) -> None:
    # docs/performance.md, "The regulator's cost against cbfd8d8": the compiled
    # way-round lookup takes the cosine and sine of the bearing ahead of its
    # loop, library calls, whatever the rows (with its call, 3 % of fence's
    # compiled and library time), and a braking plan the error's length. The
    # way round is looked for only past a keep-out ellipse, the braking
    # planned only under a limit.
    from wmr_mission.controllers import paper

    calls: list[str] = []
    for name in ("_bearing_round_zones", "stopping_speed"):
        function = getattr(paper, name)
        monkeypatch.setattr(paper, name, lambda *a, f=function, n=name: calls.append(n) or f(*a))
    estimate = np.array([0.0, 0.0, 0.3])
    for limits, planned in (([2.0, 3.0, math.inf, math.inf], False), ([2.0, 3.0, 1.0, 5.0], True)):
        calls.clear()
        paper.regulate_input(
            estimate, estimate, np.zeros(2), np.array([6.0, 1.0, 0.0]), np.array(kinds),
            np.array(params), PaperTuning(0.0, 0.0, np.ones(3), np.ones(2), np.full(3, 100.0),
            np.full(2, 100.0), BEARING, 0.01, True), Plant(0.01, np.array(limits)),
            np.zeros(paper.MEMORY_SIZE), scratch(), np.zeros(2),
        )  # fmt: skip
        assert calls.count("_bearing_round_zones") == int(looked_for)
        assert calls.count("stopping_speed") == 2 * int(planned)
