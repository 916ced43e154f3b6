"""The paper's two-phase constrained estimator, eqs. (4)-(12).

Phase I (eqs. (5)-(7)) predicts with the nonlinear model and corrects with a
gain ``L`` that puts the eigenvalues of ``(I - L C) A`` at configured poles.
The gain is in closed form, exploiting ``A = I + a e3^T`` (eq. (1) couples the
states only through the heading), so no pole placement runs per sample:

* heading measured: each measured state's error decays at its own pole and
  the heading innovation removes the heading-to-position coupling, so
  ``(I - L C) A = diag(p_x or 1, p_y or 1, p_theta)`` exactly (1 for an
  unmeasured, hence unobservable, position);
* heading not measured: the heading is observed through the measured
  positions along ``c = (a13, a23)`` (masked) while the robot moves; the
  heading/along-``c`` pair gets the poles ``(p_theta, p_pos)`` and the
  position error across ``c`` decays at ``p_pos`` (``p_pos`` the mean of the
  measured positions' poles). At rest the heading is unobservable: its
  eigenvalue is 1 and no heading correction is made. Between the two, when
  the robot moves less per sample than ``motion_floor`` (the position noise),
  one sample says little about the heading: its pole moves from ``p_theta``
  towards 1 as ``1 - (1 - p_theta) |c|^2 / motion_floor^2``, so the heading
  correction per metre of innovation stays below ``1 / motion_floor`` instead
  of growing as ``1 / |c|``.

Phase II (eqs. (8)-(12)) saturates each output estimation error that left its
bounds of eq. (4) to the violated bound. The measurement is a selection of
states, so ``D`` of eq. (12) selects the violated outputs and ``H = D^T`` makes
``I - H D`` zero on them: the iteration of eq. (10) lands on the bound in one
step, and ``(I - H D) A_c`` is contracting because it only removes directions.
The loop still checks and counts, up to ``max_iterations``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wmr_mission.kernels.jit import inlined, kernel
from wmr_mission.kernels.model import jacobian_terms, step, wrap_angle
from wmr_mission.kernels.records import Estimator

FloatArray = NDArray[np.float64]

# Below this |c| (metres moved per sample along the measured positions) the
# heading is treated as unobservable at that sample: no heading correction.
MIN_HEADING_OBSERVABILITY = 1e-12
# Output errors within this of a bound count as on it (phase II).
BOUND_SLACK = 1e-12


@kernel
def observer_gain(
    a13: float,
    a23: float,
    mask: FloatArray,
    poles: FloatArray,
    motion_floor: float,
    gain: FloatArray,
) -> None:
    """Write the 3x3 gain ``L`` of eq. (6) into ``gain``.

    Columns are the innovations of x, y, theta; columns of unmeasured states
    are zero. ``mask`` holds 1.0 for measured states, ``poles`` the configured
    eigenvalues of ``(I - L C) A`` for x, y, theta; ``motion_floor`` [m] the
    motion per sample below which the heading pole relaxes towards 1 (heading
    unmeasured only).
    """
    for i in range(3):
        for j in range(3):
            gain[i, j] = 0.0
    mx = mask[0]
    my = mask[1]
    if mask[2] > 0.0:
        gain[2, 2] = 1.0 - poles[2]
        # Measured position i: error decays at p_i; the heading innovation
        # carries p_i * a_i3 to cancel the coupling term of A.
        # Unmeasured position i: only the coupling is cancelled (eigenvalue 1).
        if mx > 0.0:
            gain[0, 0] = 1.0 - poles[0]
            gain[0, 2] = poles[0] * a13
        else:
            gain[0, 2] = a13
        if my > 0.0:
            gain[1, 1] = 1.0 - poles[1]
            gain[1, 2] = poles[1] * a23
        else:
            gain[1, 2] = a23
        return
    if mx + my == 0.0:
        return
    p_pos = (poles[0] * mx + poles[1] * my) / (mx + my)
    cx = a13 * mx
    cy = a23 * my
    n2 = cx * cx + cy * cy
    if n2 <= MIN_HEADING_OBSERVABILITY * MIN_HEADING_OBSERVABILITY:
        gain[0, 0] = (1.0 - p_pos) * mx
        gain[1, 1] = (1.0 - p_pos) * my
        return
    # Along c the pair (position, heading) has the 2x2 error matrix
    # [[p_s, p_s n], [-k n, 1 - k n^2]]: det = p_s, trace = p_s + 1 - k n^2.
    # Poles (p_theta, p_pos) need p_s = p_theta p_pos, k n^2 = (1-p_theta)(1-p_pos).
    p_theta = poles[2]
    floor2 = motion_floor * motion_floor
    if n2 < floor2:
        p_theta = 1.0 - (1.0 - p_theta) * n2 / floor2
    p_along = p_theta * p_pos
    k = (1.0 - p_theta) * (1.0 - p_pos) / n2
    # L_pos = I - P with P = p_pos (I - c c^T / n2) + p_along c c^T / n2, masked.
    d = (p_pos - p_along) / n2
    gain[0, 0] = (1.0 - p_pos + d * cx * cx) * mx
    gain[0, 1] = d * cx * cy * mx * my
    gain[1, 0] = d * cx * cy * mx * my
    gain[1, 1] = (1.0 - p_pos + d * cy * cy) * my
    gain[2, 0] = k * cx
    gain[2, 1] = k * cy


@inlined
def observer_step(
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    params: Estimator,
    gain: FloatArray,
) -> int:
    """Advance ``estimate`` (x_{k|k} -> x_{k+1|k+1}) in place with input u_k and
    measurement xi_{k+1}; ``gain`` receives L. Returns the number of phase-II
    iterations run."""
    mask = params.mask
    # Read once: the writes to ``gain`` below could alias ``estimate`` for the
    # compiler, which would then read the heading again and recompute its sine.
    x, y, theta = estimate[0], estimate[1], estimate[2]
    # Phase I. eq. (7): A at the filtered estimate x_{k|k}.
    a13, a23, _, _, _, _ = jacobian_terms(theta, v, omega, dt)
    observer_gain(a13, a23, mask, params.poles, params.motion_floor, gain)
    # eq. (5): prediction.
    px, py, pth = step(x, y, theta, v, omega, dt)
    # eq. (6): innovation of the measured outputs (heading residual wrapped).
    rx = (measurement[0] - px) * mask[0]
    ry = (measurement[1] - py) * mask[1]
    rth = wrap_angle(measurement[2] - pth) * mask[2]
    estimate[0] = px + gain[0, 0] * rx + gain[0, 1] * ry + gain[0, 2] * rth
    estimate[1] = py + gain[1, 0] * rx + gain[1, 1] * ry + gain[1, 2] * rth
    estimate[2] = pth + gain[2, 0] * rx + gain[2, 1] * ry + gain[2, 2] * rth
    if not params.use_bounds:
        return 0
    lower = params.lower
    upper = params.upper
    # Phase II, eqs. (8)-(11): iterate on the outputs whose error left eq. (4).
    iterations = 0
    while iterations < params.max_iterations:
        violated = False
        for i in range(3):
            if mask[i] == 0.0:
                continue
            error = measurement[i] - estimate[i]
            if i == 2:
                error = wrap_angle(error)
            # Rounding of the previous update must not count as a violation.
            if error > upper[i] + BOUND_SLACK:
                # z - h'(x) with z saturated to the upper bound, H = D^T.
                estimate[i] += error - upper[i]
                violated = True
            elif error < lower[i] - BOUND_SLACK:
                estimate[i] += error - lower[i]
                violated = True
        if not violated:
            break
        iterations += 1
    return iterations


@kernel
def observer_predict(estimate: FloatArray, v: float, omega: float, dt: float) -> int:
    """A sample without a measurement (between periods, or lost): eq. (5)
    alone, no innovation and no phase II. Returns 0 phase-II iterations."""
    estimate[0], estimate[1], estimate[2] = step(
        estimate[0], estimate[1], estimate[2], v, omega, dt
    )
    return 0


def error_matrix(
    state: FloatArray,
    u: FloatArray,
    dt: float,
    mask: FloatArray,
    poles: FloatArray,
    motion_floor: float = 0.0,
) -> FloatArray:
    """``(I - L C) A`` of eq. (7) at (state, u): the phase-I error dynamics."""
    a13, a23, *_ = jacobian_terms(state[2], u[0], u[1], dt)
    gain = np.zeros((3, 3))
    observer_gain(a13, a23, mask, poles, motion_floor, gain)
    a = np.array([[1.0, 0.0, a13], [0.0, 1.0, a23], [0.0, 0.0, 1.0]])
    return np.asarray((np.eye(3) - gain @ np.diag(mask)) @ a)
