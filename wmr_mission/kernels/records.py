"""The parameter records the kernels take: plain named tuples of numbers and
arrays, built once per run by :func:`records` and passed whole, so a kernel
reads ``controller.w`` instead of its seventh positional argument.

Named tuples are what numba passes into compiled code without copying; the
same records serve the single-run loop (wmr_mission.kernels.loop) and any batch of
runs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from wmr_mission.sim.plan import RUNAWAY_DISTANCE, RUNAWAY_INPUT

if TYPE_CHECKING:
    from wmr_mission.sim.plan import CompiledMission

FloatArray = NDArray[np.float64]


class Robot(NamedTuple):
    """The plant and its actuators."""

    dt: float  # [s] sampling period
    limits: FloatArray  # |v|, |omega|, then rate limits [m/s^2, rad/s^2] (inf when absent)
    # |x| or |y| [m], |v| or |omega| [m/s, rad/s] beyond which the run has diverged.
    runaway_position: float = RUNAWAY_DISTANCE
    runaway_input: float = RUNAWAY_INPUT


class Estimator(NamedTuple):
    """The estimator: the paper's constrained observer or the EKF."""

    ekf: bool
    mask: FloatArray  # 1.0 for each measured state (x, y, theta)
    poles: FloatArray  # eigenvalues of (I - L C) A per state (observer)
    motion_floor: float  # [m] motion per sample below which the heading pole relaxes
    lower: FloatArray  # output-error bounds of eq. (4) (observer, phase II)
    upper: FloatArray
    use_bounds: bool
    max_iterations: int
    process_var: FloatArray  # diagonals of the EKF's noise covariances
    measurement_var: FloatArray
    innovation_gate: float  # EKF: largest accepted r^T S^-1 r (inf: no gating)


class Controller(NamedTuple):
    """Both control laws of section III.C."""

    look_ahead: float  # [m] tracked point ahead of the axle (0: eq. (27) literally)
    error_decay: float  # fraction of the tracked output's error left after one sample
    q: FloatArray  # diagonal of Q-hat, eq. (17)
    r: FloatArray  # diagonal of R-hat, eq. (17)
    w: FloatArray  # diagonal of W, eq. (22)
    m: FloatArray  # diagonal of M, eq. (22)
    form: int  # regulation form (wmr_mission.controllers.paper.BEARING, ...)
    align_radius: float  # [m]
    reverse: bool


class Scratch(NamedTuple):
    """Scratch arrays of the control kernels, allocated once per run."""

    d: FloatArray  # (2, 3) constraint Jacobian D of eq. (26)
    eta: FloatArray  # (2,) constraint residual of eq. (26)
    b: FloatArray  # (3, 2) input Jacobian B of eq. (24)
    aim_now: FloatArray  # (4,) path point and unit tangent at t_k (tracking)
    aim: FloatArray  # (4,) path point and unit tangent at t_{k+1} the tracking law aims at
    gain: FloatArray  # (2, 3) regulator gain T of eq. (20)
    measured: FloatArray  # (3,) the measurement recorded with a sample (NaN where none)
    h: FloatArray  # (2, 2) weight of the tracking output's motion (constrained tracking)


def scratch() -> Scratch:
    return Scratch(
        d=np.zeros((2, 3)),
        eta=np.zeros(2),
        b=np.zeros((3, 2)),
        aim_now=np.zeros(4),
        aim=np.zeros(4),
        gain=np.zeros((2, 3)),
        measured=np.zeros(3),
        h=np.zeros((2, 2)),
    )


def records(m: CompiledMission) -> tuple[Robot, Estimator, Controller]:
    """The records of a compiled mission."""
    robot = Robot(m.dt, m.limits, m.runaway_position, m.runaway_input)
    estimator = Estimator(
        m.estimator == "ekf",
        m.measure_mask,
        m.poles,
        m.heading_motion_floor,
        m.lower_bounds,
        m.upper_bounds,
        m.use_bounds,
        m.max_iterations,
        m.ekf_process_var,
        m.ekf_measurement_var,
        m.ekf_innovation_gate,
    )
    controller = Controller(
        m.look_ahead,
        m.error_decay,
        m.q,
        m.r,
        m.w,
        m.m,
        m.regulation_form,
        m.align_radius,
        m.reverse,
    )
    return robot, estimator, controller


def observer_params(
    mask: FloatArray,
    poles: FloatArray,
    motion_floor: float = 0.0,
    lower: FloatArray | None = None,
    upper: FloatArray | None = None,
    use_bounds: bool = False,
    max_iterations: int = 0,
) -> Estimator:
    """The paper's observer: for tests and notebooks."""
    return Estimator(
        False,
        mask,
        poles,
        motion_floor,
        np.full(3, -np.inf) if lower is None else lower,
        np.full(3, np.inf) if upper is None else upper,
        use_bounds,
        max_iterations,
        np.zeros(3),
        np.ones(3),
        np.inf,
    )


def ekf_params(
    mask: FloatArray,
    process_var: FloatArray,
    measurement_var: FloatArray,
    innovation_gate: float = np.inf,
) -> Estimator:
    """The EKF: for tests and notebooks."""
    return Estimator(
        True, mask, np.full(3, 0.9), 0.0, np.full(3, -np.inf), np.full(3, np.inf), False, 0,
        process_var, measurement_var, innovation_gate,
    )  # fmt: skip
