"""The baseline controllers, pure pursuit and Kanayama's law: each law
against its formula written independently, closed-loop tracking, and
regulation delegated to the paper's regulator."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from wmr_mission.api import mission_from_text, run_mission
from wmr_mission.controllers import kanayama, pure_pursuit
from wmr_mission.kernels.records import Plant, scratch

DT = 0.01
PLANT = Plant(dt=DT, limits=np.array([100.0, 100.0, math.inf, math.inf]))
TRACKING = SimpleNamespace(tracking=True)


def _circle_aims(radius: float, rate: float, phase: float) -> tuple[np.ndarray, np.ndarray]:
    """The loop's aim points of a circle about the origin at t_k (angle
    ``phase``) and t_{k+1}: x, y, unit tangent."""

    def at(angle: float) -> np.ndarray:
        return np.array(
            [radius * math.cos(angle), radius * math.sin(angle), -math.sin(angle), math.cos(angle)]
        )

    return at(phase), at(phase + rate * DT)


def _step(module: object, tuning: object, aims: tuple[np.ndarray, np.ndarray],
          estimate: np.ndarray, u_prev: np.ndarray) -> np.ndarray:  # fmt: skip
    u = np.zeros(2)
    module.next_input(  # type: ignore[attr-defined]
        tuning, TRACKING, aims[0], aims[1], estimate, estimate.copy(), u_prev, PLANT,
        np.zeros(module.CONTROLLER.memory_size), scratch(), u,  # type: ignore[attr-defined]
    )  # fmt: skip
    return u


def test_kanayama_is_its_formula(rng: np.random.Generator) -> None:
    """v = v_r cos e_theta + k_x e_x, omega = omega_r + v_r (k_y e_y + k_theta
    sin e_theta), the errors in the robot's frame (Kanayama et al. 1990)."""
    settings = kanayama.KanayamaController(
        type="kanayama", gains={"x": 3.0, "y": 20.0, "theta": 5.0}
    )
    tuning = kanayama.tuning_of(settings, PLANT)
    for _ in range(50):
        radius, rate, phase = rng.uniform(1, 5), rng.uniform(0.2, 2), rng.uniform(-3, 3)
        aims = _circle_aims(radius, rate, phase)
        estimate = aims[0][:3] + rng.normal(0, 0.3, 3)
        estimate[2] = phase + math.pi / 2 + rng.normal(0, 0.5)
        u = _step(kanayama, tuning, aims, estimate, np.zeros(2))
        # The reference independently: the circle's pose and motion.
        x_r, y_r = radius * math.cos(phase), radius * math.sin(phase)
        theta_r = phase + math.pi / 2
        v_r = 2 * radius * math.sin(rate * DT / 2) / DT  # the chord over one sample
        omega_r = rate
        theta = estimate[2]
        e_x = math.cos(theta) * (x_r - estimate[0]) + math.sin(theta) * (y_r - estimate[1])
        e_y = -math.sin(theta) * (x_r - estimate[0]) + math.cos(theta) * (y_r - estimate[1])
        e_theta = math.atan2(math.sin(theta_r - theta), math.cos(theta_r - theta))
        v = v_r * math.cos(e_theta) + 3.0 * e_x
        omega = omega_r + v_r * (20.0 * e_y + 5.0 * math.sin(e_theta))
        np.testing.assert_allclose(u, [v, omega], rtol=1e-9, atol=1e-9)


def test_pure_pursuit_steers_onto_the_arc_through_the_goal_point(rng: np.random.Generator) -> None:
    """On a circle path the goal point is the path ``L`` further along its arc;
    the input turns the robot onto the circle through its axle and the goal
    point tangent to its heading, at the speed that keeps it on time."""
    look_ahead, speed_gain = 0.4, 0.1
    settings = pure_pursuit.PurePursuitController(
        type="pure-pursuit", look_ahead=look_ahead, speed_gain=speed_gain
    )
    tuning = pure_pursuit.tuning_of(settings, PLANT)
    for _ in range(50):
        radius, rate, phase = rng.uniform(2, 5), rng.uniform(0.2, 1), rng.uniform(-3, 3)
        aims = _circle_aims(radius, rate, phase)
        estimate = aims[0][:3] + rng.normal(0, 0.1, 3)
        estimate[2] = phase + math.pi / 2 + rng.normal(0, 0.2)
        u_prev = np.array([rng.uniform(0, 2), 0.0])
        v, omega = _step(pure_pursuit, tuning, aims, estimate, u_prev)
        distance = look_ahead + speed_gain * u_prev[0]
        goal = radius * np.array([math.cos(phase + distance / radius),
                                  math.sin(phase + distance / radius)])  # fmt: skip
        # The arc of curvature omega / v from the robot's pose passes through the goal.
        curvature = omega / v
        heading = estimate[2]
        normal = np.array([-math.sin(heading), math.cos(heading)])
        centre = estimate[:2] + normal / curvature
        assert np.hypot(*(goal - centre)) == pytest.approx(abs(1 / curvature), rel=1e-4)
        # On time: the goal as far ahead of the robot (along the path) as of the reference.
        tangent = aims[0][2:]
        v_r = 2 * radius * math.sin(rate * DT / 2) / DT
        ahead = (goal - estimate[:2]) @ tangent
        assert v == pytest.approx(v_r * ahead / (radius * math.sin(distance / radius)), rel=1e-4)


TRACK = """\
version: 1
name: baseline
robot: {{dt: 0.01, initial_state: {{x: 0.1, y: -0.1, theta: 0.5}}, limits: {{v: 5, omega: 10}}}}
sensors: {{noise_std: {{x: 0.005, y: 0.005, theta: 0.005}}, seed: 3}}
controller: {controller}
phases:
  - name: eight
    track: {{path: {{type: expression, x: "3*sin(0.5*t)", y: "3*sin(0.5*t)*cos(0.5*t)"}}}}
    until: {{elapsed: 12.56}}
  - name: park
    regulate: {{target: {{x: 0, y: 0, theta: 0}}}}
    until: {{settled: {{position: 0.01, heading: 0.01}}}}
    timeout: 20
    on_timeout: fail
expect: {{tracking_error_rms: {{max: 0.01}}, final_position_error: {{max: 0.02}}}}
"""


@pytest.mark.parametrize("controller", ["pure-pursuit", "kanayama"])
def test_a_baseline_tracks_the_figure_eight_and_parks(controller: str) -> None:
    result = run_mission(mission_from_text(TRACK.format(controller=f"{{type: {controller}}}")))
    assert result.outcome.value == "success", result.message
    eight = result.summary()["phases"][0]
    assert eight["tracking_error"]["rms"] < 0.005
    assert eight["tracking_error"]["max"] < 0.02


REGULATE = """\
version: 1
name: park
robot: {{dt: 0.01, initial_state: {{x: 1, y: 0.5, theta: 2.0}}, limits: {{v: 2, omega: 4}}}}
sensors: {{noise_std: {{x: 0.01, y: 0.01, theta: 0.01}}, seed: 5}}
# written: the estimator's default poles follow the controller's noise budget
estimator: {{poles: {{x: 0.9, y: 0.9, theta: 0.9}}}}
controller: {controller}
regions: {{pen: {{type: circle, center: [0.5, 0.2], radius: 1.2}}}}
phases:
  - name: park
    regulate: {{target: {{x: 0, y: 0, theta: 0}}}}
    constraints: [{{stay_inside: pen}}]
    until: {{elapsed: 6}}
"""


def test_the_baselines_regulate_with_the_paper_regulator() -> None:
    """A regulate phase runs the paper's regulator with its default weights:
    the same bytes as ``type: paper`` with nothing else written."""
    runs = {
        name: run_mission(mission_from_text(REGULATE.format(controller=f"{{type: {name}}}")))
        for name in ("paper", "pure-pursuit", "kanayama")
    }
    paper = runs["paper"]
    assert paper.outcome.value == "success"
    assert np.abs(paper.v).max() > 0.1  # it moved
    for name in ("pure-pursuit", "kanayama"):
        for column in ("x", "y", "theta", "v", "omega"):
            assert getattr(runs[name], column).tobytes() == getattr(paper, column).tobytes(), name
