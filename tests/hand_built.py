"""Missions built directly as MissionPlan, independent of the YAML front-end:
the numerical core is tested on its own with these."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from wmr_mission.controllers import paper
from wmr_mission.controllers.paper import PaperTuning
from wmr_mission.estimators import observer
from wmr_mission.estimators.observer import observer_tuning
from wmr_mission.geometry.paths import Trajectory
from wmr_mission.kernels.records import Plant
from wmr_mission.sim.plan import Conditions, MissionPlan, PhasePlan

RATE = 0.4 * math.pi  # eqs. (30)-(32)
ELLIPSE_ROWS = (np.array([0]), np.array([[0.0, 0.0, 5.5, 3.0, 0.0, 1.0]]))


class Curve:
    def __init__(self, position: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]) -> None:
        self.position = position

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        h = 1e-6
        x, y = self.position(t)
        x1, y1 = self.position(t + h)
        x0, y0 = self.position(t - h)
        return x, y, (x1 - x0) / (2 * h), (y1 - y0) / (2 * h)


def spiral(pose: tuple[float, float, float]) -> Trajectory:  # eq. (30)
    return Curve(
        lambda t: (2 * np.exp(0.5 * t) * np.cos(RATE * t), 2 * np.exp(0.5 * t) * np.sin(RATE * t))
    )


def _phase_on_ellipse(pose: tuple[float, float, float]) -> float:
    return math.atan2(pose[1] / 3, pose[0] / 5.5)


def ellipse(pose: tuple[float, float, float]) -> Trajectory:  # eq. (31), from the robot
    p = _phase_on_ellipse(pose)
    return Curve(lambda t: (5.5 * np.cos(RATE * t + p), 3 * np.sin(RATE * t + p)))


def elliptical_spiral(pose: tuple[float, float, float]) -> Trajectory:  # eq. (32)
    p = _phase_on_ellipse(pose)
    return Curve(
        lambda t: (
            5.5 * np.exp(-0.2 * t) * np.cos(RATE * t + p),
            3 * np.exp(-0.2 * t) * np.sin(RATE * t + p),
        )
    )


def mission(
    phases: list[PhasePlan],
    *,
    look_ahead: float = 0.1,
    error_decay: float = math.exp(-0.1),  # the default law at dt = 0.01: 0.1 m, 0.1 s
    form: int = 0,
    measure: tuple[float, float, float] = (1.0, 1.0, 1.0),
    initial_estimate: tuple[float, float, float] = (1.0, 1.0, 0.0),
    initial_state: tuple[float, float, float] = (0.0, 0.0, 0.0),
    limits: tuple[float, float] = (10.0, 20.0),
    bounds: float = 0.05,
) -> MissionPlan:
    mask = np.array(measure)
    plant = Plant(0.01, np.array([limits[0], limits[1], np.inf, np.inf]))
    return MissionPlan(
        name="hand-built",
        plant=plant,
        initial_state=np.array(initial_state),
        initial_estimate=np.array(initial_estimate),
        measured=mask,
        noise_std=np.zeros(3),
        seed=0,
        estimator=observer.ESTIMATOR,
        estimator_tuning=observer_tuning(
            mask, np.full(3, 0.9), 0.0, np.full(3, -bounds), np.full(3, bounds), True, 10
        ),
        controller=paper.CONTROLLER,
        controller_tuning=PaperTuning(
            look_ahead=look_ahead,
            error_decay=error_decay,
            q=np.ones(3),
            r=np.ones(2),
            w=np.full(3, 100.0),
            m=np.full(2, 100.0),
            form=form,
            align_radius=0.01,
            reverse=True,
        ),
        phases=tuple(phases),
        regions={
            "ellipse": {"type": "ellipse", "center": [0, 0], "semi_axes": [5.5, 3], "rotation": 0}
        },
        max_samples=20_000,
    )


def spiral_then_ellipse(seconds_on_ellipse: float = 20.0) -> list[PhasePlan]:
    return [
        PhasePlan(
            "spiral",
            "track",
            Conditions(reaches="ellipse", reaches_rows=ELLIPSE_ROWS),
            1000,
            True,
            spiral,
        ),
        PhasePlan(
            "ellipse",
            "track",
            Conditions(elapsed_samples=round(seconds_on_ellipse * 100)),
            None,
            True,
            ellipse,
        ),
    ]


def case1(**options: object) -> MissionPlan:
    phases = [
        *spiral_then_ellipse(),
        PhasePlan(
            "elliptical-spiral",
            "track",
            Conditions(near=(0.0, 0.0, 0.02)),
            6000,
            True,
            elliptical_spiral,
        ),
        PhasePlan(
            "park",
            "regulate",
            Conditions(settled=(0.02, 0.005, 0.01)),
            3000,
            True,
            None,
            (0.0, 0.0, 0.0),
        ),
    ]
    return mission(phases, **options)  # type: ignore[arg-type]


def case2(**options: object) -> MissionPlan:
    phases = [
        *spiral_then_ellipse(),
        PhasePlan(
            "return", "regulate", Conditions(settled=(0.01, 0.01, 0.01)), 12000, True, None,
            (0.0, 0.0, 0.0), ELLIPSE_ROWS, (("ellipse", "inside"),),
        ),
    ]  # fmt: skip
    return mission(phases, **options)  # type: ignore[arg-type]


def regulate_only(
    target: tuple[float, float, float],
    seconds: float,
    initial_state: tuple[float, float, float],
    **options: object,
) -> MissionPlan:
    phases = [
        PhasePlan(
            "regulate",
            "regulate",
            Conditions(elapsed_samples=round(seconds * 100)),
            None,
            True,
            None,
            target,
        )
    ]
    return mission(phases, initial_state=initial_state, initial_estimate=initial_state, **options)  # type: ignore[arg-type]
