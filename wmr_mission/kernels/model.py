"""The plant: the discrete-time unicycle of eq. (1) and its Jacobians.

Names: ``v`` is the linear speed [m/s] (the paper's ``w``), ``omega`` the turn
rate [rad/s] (the paper's ``v``). The heading is never wrapped here; angles are
wrapped only where they are compared (:func:`wrap_angle`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import inlined, kernel


@kernel
def step(
    x: float, y: float, theta: float, v: float, omega: float, dt: float
) -> tuple[float, float, float]:
    """One sample of eq. (1): the pose at k+1 from the pose and input at k."""
    c = math.cos(theta)
    s = math.sin(theta)
    half_dt2_v_omega = 0.5 * dt * dt * v * omega
    return (
        x + dt * v * c - half_dt2_v_omega * s,
        y + dt * v * s + half_dt2_v_omega * c,
        theta + dt * omega,
    )


@kernel
def jacobian_terms(
    theta: float, v: float, omega: float, dt: float
) -> tuple[float, float, float, float, float, float]:
    """The non-trivial entries of A = df/dx and B = df/du of eq. (1).

    A = [[1, 0, a13], [0, 1, a23], [0, 0, 1]],
    B = [[b11, b12], [b21, b22], [0, dt]].
    Returned as (a13, a23, b11, b12, b21, b22).
    """
    c = math.cos(theta)
    s = math.sin(theta)
    h = 0.5 * dt * dt
    return (
        -dt * v * s - h * v * omega * c,
        dt * v * c - h * v * omega * s,
        dt * c - h * omega * s,
        -h * v * s,
        dt * s + h * omega * c,
        h * v * c,
    )


TWO_PI = 2.0 * math.pi


@kernel
def wrap_angle(angle: float) -> float:
    """Angle in [-pi, pi)."""
    shifted = angle + math.pi
    # Already in [0, 2 pi): the remainder is ``shifted`` itself, to the bit, and
    # the floating-point remainder (a library call) is the slow part.
    if 0.0 <= shifted < TWO_PI:
        return shifted - math.pi
    return shifted % TWO_PI - math.pi


@kernel
def hypot(x: float, y: float) -> float:
    """sqrt(x^2 + y^2) without overflow, in IEEE arithmetic alone.

    ``math.hypot`` is the C library's in compiled code but CPython's own
    algorithm as plain Python; they differ in the last bit about once in 500
    calls, and the plain-Python build must give the compiled build's bytes."""
    big, small = abs(x), abs(y)
    if big < small:
        big, small = small, big
    if big == 0.0 or big == math.inf:  # (0, 0), or an infinite side (NaN goes on to NaN)
        return big
    ratio = small / big
    return big * math.sqrt(1.0 + ratio * ratio)


@kernel
def saturate(
    v: float, omega: float, v_prev: float, omega_prev: float, limits: FloatArray, dt: float
) -> tuple[float, float]:
    """Actuator limits: |v| <= limits[0], |omega| <= limits[1], and rate limits
    limits[2] [m/s^2], limits[3] [rad/s^2] (inf when absent)."""
    dv = limits[2] * dt
    dw = limits[3] * dt
    v = min(max(v, v_prev - dv), v_prev + dv)
    omega = min(max(omega, omega_prev - dw), omega_prev + dw)
    v = min(max(v, -limits[0]), limits[0])
    omega = min(max(omega, -limits[1]), limits[1])
    return v, omega


@kernel
def stopping_speed(distance: float, acceleration: float, dt: float) -> float:
    """[m/s or rad/s] The largest speed from which a rate limit ``acceleration``
    still stops the robot within ``distance``, one sample at a time: the speeds
    v, v - a dt, ..., a dt cover ``v^2 / (2 a) + v dt / 2`` (inf without a limit)."""
    if acceleration == math.inf:
        return math.inf
    half_step = 0.5 * acceleration * dt
    return math.sqrt(half_step * half_step + 2.0 * acceleration * distance) - half_step


# The share of the time from rest to the turn-rate limit at the turn-rate
# acceleration limit that a path's turn is previewed by at most
# (preview_rows): half, the ramp to the limit centred on a step.
PREVIEW_SHARE = 0.5


def preview_rows(limits: FloatArray, dt: float) -> int:
    """How many samples ahead (and behind) a path's turn is averaged over
    at most under a turn-rate acceleration limit ``a``: PREVIEW_SHARE of
    ``omega_max / a``, so that a step of the turn rate to its limit is ramped
    at ``a``; each row's own window follows the path's turn rate
    (sim.runner.turn_windows); 0 without such a limit (docs/paper-notes.md,
    eq. (27), "The path's turn previewed")."""
    if not math.isfinite(float(limits[3])):
        return 0
    return round(PREVIEW_SHARE * float(limits[1]) / float(limits[3]) / float(dt))


@kernel
def braking_distance(v: float, acceleration: float, dt: float) -> float:
    """[m] Signed distance covered after the next sample while braking from
    ``v`` at ``acceleration`` (the speeds v - a dt, v - 2 a dt, ..., the
    sample's own v dt not counted: about v^2 / (2 a))."""
    distance = max(0.5 * v * v / acceleration - 0.5 * abs(v) * dt, 0.0)
    return math.copysign(distance, v)


@kernel
def input_jacobian_into(theta: float, v: float, omega: float, dt: float, b: FloatArray) -> None:
    _, _, b11, b12, b21, b22 = jacobian_terms(theta, v, omega, dt)
    b[0, 0] = b11
    b[0, 1] = b12
    b[1, 0] = b21
    b[1, 1] = b22
    b[2, 0] = 0.0
    b[2, 1] = dt


# Array forms with the project-wide argument order f(state, input, dt): for
# tests, the reference step and notebooks. The per-sample loop uses the scalar
# kernels above.


def f(state: FloatArray, u: FloatArray, dt: float) -> FloatArray:
    """Eq. (1) on arrays: ``state = [x, y, theta]``, ``u = [v, omega]``."""
    return np.array(step(state[0], state[1], state[2], u[0], u[1], dt))


def state_jacobian(state: FloatArray, u: FloatArray, dt: float) -> FloatArray:
    """A = df/dx at (state, u), eq. (7)."""
    a13, a23, *_ = jacobian_terms(state[2], u[0], u[1], dt)
    return np.array([[1.0, 0.0, a13], [0.0, 1.0, a23], [0.0, 0.0, 1.0]])


def input_jacobian(state: FloatArray, u: FloatArray, dt: float) -> FloatArray:
    """B = df/du at (state, u), eq. (16)."""
    _, _, b11, b12, b21, b22 = jacobian_terms(state[2], u[0], u[1], dt)
    return np.array([[b11, b12], [b21, b22], [0.0, dt]])


@inlined
def is_number(value: Any) -> bool:
    """Whether a value a plug-in's step returned is a number: text is not,
    though ``float("1")`` would read it."""
    return not isinstance(value, (str, bytes))
