"""The reference step: the estimator and controller equations written the
straightforward way, with numpy matrices and scipy's solvers.

Every function has the signature and the semantics of its compiled
counterpart (``wmr_mission.estimators.observer``, ``wmr_mission.estimators.ekf``,
``wmr_mission.controllers.paper``), so ``run_mission(mission, substitutes=REFERENCE)``
runs the same mission. It is the oracle the fast kernels are tested against
and the baseline ``wmr-mission bench`` measures them against. It is written
from the paper's equations, not from the kernels: matrices are built, scipy
places the observer poles (``place_poles``) and solves eq. (21)
(``solve_discrete_are``) at every sample.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.linalg import solve_discrete_are
from scipy.signal import place_poles

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.controllers import paper
from wmr_mission.controllers.paper import (
    ALIGNING,
    BEARING,
    CORRECTED,
    DOUBLINGS,
    INCREMENT,
    REVERSE_HYSTERESIS,
    REVERSING,
    ROUND_SIDE,
    SHARE_HALVINGS,
    TURN_SLEW,
    TURNABLE_SPEED,
    PaperTuning,
)
from wmr_mission.estimators import ekf, observer
from wmr_mission.estimators.ekf import EkfTuning
from wmr_mission.estimators.observer import BOUND_SLACK, MIN_HEADING_OBSERVABILITY, ObserverTuning
from wmr_mission.kernels.convex import polygon_distance
from wmr_mission.kernels.corrective import ELLIPSE_ROW, POLYGON_ROW, REGULARISATION
from wmr_mission.kernels.records import Plant, Scratch
from wmr_mission.kernels.riccati import MIN_SPEED


def wrap_angle(angle: float) -> float:
    """Angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


# --- the plant, eq. (1), and its linearisation, eqs. (7) and (16) ----------


def predict(state: FloatArray, v: float, omega: float, dt: float) -> FloatArray:
    """x_{k+1} = f(x_k, u_k) of eq. (1)."""
    x, y, theta = state
    c, s = math.cos(theta), math.sin(theta)
    h = 0.5 * dt * dt
    return np.array(
        [
            x + dt * v * c - h * v * omega * s,
            y + dt * v * s + h * v * omega * c,
            theta + dt * omega,
        ]
    )


def state_jacobian(theta: float, v: float, omega: float, dt: float) -> FloatArray:
    """A = df/dx of eq. (1), eq. (7)."""
    c, s = math.cos(theta), math.sin(theta)
    h = 0.5 * dt * dt
    return np.array(
        [
            [1.0, 0.0, -dt * v * s - h * v * omega * c],
            [0.0, 1.0, dt * v * c - h * v * omega * s],
            [0.0, 0.0, 1.0],
        ]
    )


def input_jacobian(theta: float, v: float, omega: float, dt: float) -> FloatArray:
    """B = df/du of eq. (1), eq. (16)."""
    c, s = math.cos(theta), math.sin(theta)
    h = 0.5 * dt * dt
    return np.array(
        [
            [dt * c - h * omega * s, -h * v * s],
            [dt * s + h * omega * c, h * v * c],
            [0.0, dt],
        ]
    )


# --- the estimator, eqs. (4)-(12) ------------------------------------------


def observer_gain_matrix(
    a: FloatArray, mask: FloatArray, poles: FloatArray, motion_floor: float = 0.0
) -> FloatArray:
    """The gain L of eq. (6), columns = innovations of x, y, theta.

    With the whole pose measured (C = I), scipy places the eigenvalues of
    (I - L C) A, the transpose of A^T - (C A)^T L^T, at the poles. With C A
    invertible the closed loop is the diagonal matrix of the poles in
    ascending order, so the states are ordered by pole first: each state's
    error then decays at its own pole. Other measurement sets follow the
    design stated in wmr_mission.estimators.observer (unmeasured, hence unobservable,
    directions keep eigenvalue 1).
    """
    measured = mask > 0.0
    if measured.all():
        order = np.argsort(poles, kind="stable")
        permute = np.eye(3)[order]
        c = np.eye(3)
        placed = place_poles(permute @ a.T @ permute.T, permute @ (c @ a).T, poles[order])
        return np.asarray((placed.gain_matrix @ permute).T)
    if measured[2]:
        # (I - L C) A = diag(p_x or 1, p_y or 1, p_theta).
        decay = np.where(measured, poles, 1.0)
        return np.asarray((np.eye(3) - np.diag(decay) @ np.linalg.inv(a)) @ np.diag(mask))
    gain = np.zeros((3, 3))
    if not measured[:2].any():
        return gain
    p_pos = float(poles[:2] @ mask[:2]) / float(mask[:2].sum())
    select = np.diag(mask[:2])
    # The heading is seen through the measured positions along c.
    c = select @ a[:2, 2]
    n2 = float(c @ c)
    if n2 <= MIN_HEADING_OBSERVABILITY**2:
        gain[:2, :2] = (1.0 - p_pos) * select
        return gain
    # Moving less than motion_floor per sample: the heading pole relaxes to 1.
    p_theta = float(poles[2])
    if n2 < motion_floor**2:
        p_theta = 1.0 - (1.0 - p_theta) * n2 / motion_floor**2
    p_along = p_theta * p_pos
    along = np.outer(c, c) / n2
    remaining = p_pos * (np.eye(2) - along) + p_along * along
    gain[:2, :2] = select @ (np.eye(2) - remaining) @ select
    gain[2, :2] = (1.0 - p_theta) * (1.0 - p_pos) / n2 * c
    return gain


def observer_step(
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    params: ObserverTuning,
    gain: FloatArray,
    poles: FloatArray,
) -> int:
    """Advance ``estimate`` in place (x_{k|k} -> x_{k+1|k+1}); writes L for the
    eigenvalues ``poles`` into ``gain``; returns the number of phase-II
    iterations run."""
    mask, motion_floor = params.mask, params.motion_floor
    lower, upper = params.lower, params.upper
    a = state_jacobian(float(estimate[2]), v, omega, dt)  # eq. (7)
    gain[:, :] = observer_gain_matrix(a, mask, poles, motion_floor)
    predicted = predict(estimate, v, omega, dt)  # eq. (5)
    c = np.diag(mask)
    innovation = measurement - predicted
    innovation[2] = wrap_angle(float(innovation[2]))
    estimate[:] = predicted + gain @ c @ innovation  # eq. (6)
    if not params.use_bounds:
        return 0
    measured = mask > 0.0
    iterations = 0
    while iterations < params.max_iterations:
        error = measurement - estimate
        error[2] = wrap_angle(float(error[2]))
        # An output left exactly on its bound by the previous iteration may
        # round to just beyond it: that is not a violation.
        above = measured & (error > upper + BOUND_SLACK)
        below = measured & (error < lower - BOUND_SLACK)
        violated = above | below
        if not violated.any():
            break
        # eqs. (9)-(11): the violated outputs saturated to their bounds are
        # a new measurement; D selects them and H = D^T.
        d = np.eye(3)[violated]
        bound = np.where(above, upper, lower)
        estimate += d.T @ (error[violated] - bound[violated])
        iterations += 1
    return iterations


def ekf_step(
    estimate: FloatArray,
    covariance: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    params: EkfTuning,
    work: FloatArray,
    gate: float = math.inf,
) -> bool:
    """Extended Kalman filter step, in place, Joseph-form covariance update;
    True when the measurement is gated (r^T S^-1 r above ``gate``)."""
    mask, process_var, measurement_var = params.mask, params.process_var, params.measurement_var
    a = state_jacobian(float(estimate[2]), v, omega, dt)
    predicted = predict(estimate, v, omega, dt)
    p = a @ covariance @ a.T + np.diag(process_var)
    measured = mask > 0.0
    c = np.eye(3)[measured]
    noise = np.diag(measurement_var[measured])
    s = c @ p @ c.T + noise
    k = np.linalg.solve(s, c @ p).T  # P C^T S^-1 (P and S symmetric)
    residual = measurement - predicted
    residual[2] = wrap_angle(float(residual[2]))
    innovation = c @ residual
    if float(innovation @ np.linalg.solve(s, innovation)) > gate:
        estimate[:] = predicted  # gated: the prediction alone
        covariance[:, :] = p
        return True
    estimate[:] = predicted + k @ innovation
    i_kc = np.eye(3) - k @ c
    p = i_kc @ p @ i_kc.T + k @ noise @ k.T
    covariance[:, :] = 0.5 * (p + p.T)
    return False


# --- the controller, section III.C ------------------------------------------


def saturate(
    v: float, omega: float, v_prev: float, omega_prev: float, limits: FloatArray, dt: float
) -> tuple[float, float]:
    """Rate limits (limits[2], limits[3] per second), then magnitude limits."""
    v = float(np.clip(v, v_prev - limits[2] * dt, v_prev + limits[2] * dt))
    omega = float(np.clip(omega, omega_prev - limits[3] * dt, omega_prev + limits[3] * dt))
    return float(np.clip(v, -limits[0], limits[0])), float(np.clip(omega, -limits[1], limits[1]))


def corrective_input(
    d: FloatArray, eta: FloatArray, b: FloatArray, w: FloatArray, m: FloatArray, limits: FloatArray
) -> FloatArray:
    """Eqs. (27)/(28): du = Rw^-1 (D B)^T S^-1 eta, S = D B Rw^-1 (D B)^T.

    When S is singular to rounding, or du leaves the inputs' span (2 limits),
    S^-1 becomes the pseudo-inverse truncated to the inputs: each
    eigen-direction's change is scaled down to fit |dv| <= 2 limits[0],
    |domega| <= 2 limits[1]; eigenvalues below REGULARISATION times the
    largest are dropped.
    """
    rw = b.T @ np.diag(w) @ b + np.diag(m)
    rw_inv = np.linalg.inv(rw)
    db = d @ b
    s = db @ rw_inv @ db.T
    span = 2.0 * limits[:2]
    values, vectors = np.linalg.eigh(s)
    largest = values.max()
    if not largest > 0.0:
        return np.zeros(2)
    if values.min() > REGULARISATION * largest:
        du = rw_inv @ db.T @ np.linalg.solve(s, eta)
        if np.all(np.abs(du) <= span):
            return np.asarray(du)
    du = np.zeros(2)
    for value, vector in zip(values, vectors.T, strict=True):
        if value <= REGULARISATION * largest:
            continue
        part = rw_inv @ db.T @ vector * (vector @ eta) / value
        du += part / max(1.0, float(np.max(np.abs(part) / span)))
    return du


def track_input(
    estimate: FloatArray,
    u_prev: FloatArray,
    reference_now: FloatArray,
    reference: FloatArray,
    controller: PaperTuning,
    robot: Plant,
    work: Scratch,
    u_out: FloatArray,
    path_turn: float = 0.0,
) -> None:
    """Case 2: u_k = u_{k-1} + du2_k, du2 of eq. (27) on the look-ahead point,
    aimed so that ``error_decay`` of the output's error at k is left at k+1;
    under a turn-rate acceleration limit the turn stopped relative to the
    path's own, ``path_turn``."""
    look_ahead, error_decay = controller.look_ahead, controller.error_decay
    w, m = controller.w, controller.m
    limits, dt = robot.limits, robot.dt
    v_prev, omega_prev = float(u_prev[0]), float(u_prev[1])

    def output(pose: FloatArray) -> FloatArray:  # eq. (26): position + look_ahead * heading
        return np.asarray(pose[:2] + look_ahead * np.array([math.cos(pose[2]), math.sin(pose[2])]))

    error_now = reference_now[:2] + look_ahead * reference_now[2:4] - output(estimate)
    predicted = predict(estimate, v_prev, omega_prev, dt)  # x_{k+1|k}, u_{k-1} held
    normal = np.array([-math.sin(predicted[2]), math.cos(predicted[2])])
    d = np.column_stack([np.eye(2), look_ahead * normal])  # D = dG/dx
    left = error_decay * error_now
    distance = float(np.hypot(error_now[0], error_now[1]))
    kept = error_decay
    if distance > controller.error_reach:  # at most error_reach's share closed
        closed = (1.0 - error_decay) * controller.error_reach
        # along the heading, up to what the speed limit leaves over the path's
        # step (no faster than the robot stops within the error), the part
        # across it no more than the bound's
        along = float(error_now @ [math.cos(estimate[2]), math.sin(estimate[2])]) / distance
        if along > 0.0:
            top = min(float(limits[0]), stopping_speed(distance, float(limits[2]), dt))
            step = float(np.hypot(*(reference[:2] - reference_now[:2])))
            spare = along * (top * dt - step)
            across = math.sqrt(max(1.0 - along * along, 0.0))
            if across * spare > closed:
                spare = closed / across
            closed = min(max(closed, spare), (1.0 - error_decay) * distance)
        kept = 1.0 - closed / distance
        left = kept * error_now
    if math.isfinite(controller.turn_acceleration) and distance > 0.0:
        # under a turn-rate acceleration limit, a time constant of at least
        # cbrt(e / (a v)): the heading e / (v tau) it asks, turned within tau
        speed = float(np.hypot(*(reference[:2] - reference_now[:2]))) / dt
        speed = max(speed, TURNABLE_SPEED * float(limits[0]))
        pace = math.pow(distance / (controller.turn_acceleration * speed), 1.0 / 3.0)
        if 1.0 - dt / pace > kept:
            left = (1.0 - dt / pace) * error_now
    target = reference[:2] + look_ahead * reference[2:4] - left
    b = input_jacobian(float(estimate[2]), v_prev, omega_prev, dt)  # eq. (24)
    du = corrective_input(d, target - output(predicted), b, w, m, limits)
    v, omega = v_prev + du[0], omega_prev + du[1]
    # the output misses its aim by the linearisation's second-order terms:
    # where that costs the turn rate more than LINEAR_SHARE of its limit,
    # eq. (27) solved again at the input asked for (not the one-sample laws)
    miss = 0.5 * dt * (abs(du[0] * du[1]) + look_ahead * du[1] ** 2)
    if error_decay > 0.0 and miss > paper.LINEAR_SHARE * limits[1] * look_ahead:
        v, omega = saturate(v, omega, v_prev, omega_prev, limits, dt)
        predicted = predict(estimate, v, omega, dt)
        normal = np.array([-math.sin(predicted[2]), math.cos(predicted[2])])
        d = np.column_stack([np.eye(2), look_ahead * normal])
        b = input_jacobian(float(estimate[2]), v, omega, dt)
        du = corrective_input(d, target - output(predicted), b, w, m, limits)
        v, omega = v + du[0], omega + du[1]
    planned = math.isfinite(limits[3])
    if planned or abs(omega) >= limits[1]:
        # The turn planned: towards the heading of the output's move this
        # sample (reversed backwards), no faster than the limit stops it there.
        move = target - output(estimate)
        if v < 0.0:
            move = -move
        turn = wrap_angle(math.atan2(move[1], move[0]) - float(estimate[2]))
        # And the speed along the way the output must move: the robot turns
        # before it drives, under acceleration limits or while it turns
        # towards that way at its limit (wmr_mission.controllers.paper.track_input).
        # The law's speed counted no higher than the limit over cos
        # FULL_SPEED_TURN, but in the one-sample laws.
        if planned or omega * turn > 0.0:
            if error_decay > 0.0:
                top = float(limits[0]) / math.cos(paper.FULL_SPEED_TURN)
                v = math.copysign(min(abs(v), top), v)
            v *= max(math.cos(turn), 0.0)
        if planned and (omega - path_turn) * turn > 0.0:
            reach = stopping_speed(abs(turn), float(limits[3]), dt)
            omega = path_turn + float(np.clip(omega - path_turn, -reach, reach))
    u_out[0], u_out[1] = saturate(v, omega, v_prev, omega_prev, limits, dt)


def turns_sooner(speed: float, turn: float, limits: FloatArray) -> bool:
    """Whether turning by ``turn`` at the turn-rate limits (up to the rate
    limit and down again) takes less time than stopping from ``speed`` (> 0
    along the direction of travel) and regaining it the other way."""
    v_acceleration, rate, acceleration = (float(limits[i]) for i in (2, 1, 3))
    if speed <= 0.0 or not math.isfinite(v_acceleration):
        return False
    if turn >= rate * rate / acceleration:
        turning = turn / rate + rate / acceleration
    else:
        turning = 2.0 * math.sqrt(turn / acceleration)
    return turning < 2.0 * speed / v_acceleration


def stopping_speed(distance: float, acceleration: float, dt: float) -> float:
    """The largest speed the speeds v, v - a dt, ... bring to rest within
    ``distance``: v^2 / (2 a) + v dt / 2 = distance, solved for v."""
    if not math.isfinite(acceleration):
        return math.inf
    return float(
        -acceleration * dt / 2
        + math.sqrt((acceleration * dt / 2) ** 2 + 2 * acceleration * distance)
    )


# As many points of the braking line as the compiled law holds a polygon
# row at (constrained_tracking.BRAKING_STEPS), evenly spaced to its end.
BRAKING_STEPS = 16


def largest_on_braking_line(
    row_kinds: IntArray,
    rows: FloatArray,
    margin: float,
    position: FloatArray,
    heading: float,
    v: float,
    acceleration: float,
    dt: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Each row's largest value over the line braking from ``v`` at
    ``acceleration`` takes beyond ``position`` along ``heading`` (v^2 / (2 a)
    on): the values, their gradients, the sensitivity of the point where it
    is to (v, omega) (rows x 4: x by v, x by omega, y by v, y by omega) and
    whether that point is inside the line. A half-plane or ellipse row is
    quadratic along the line: its largest is at the vertex of a keep-out
    ellipse's value where that is inside the line, else at an end; a polygon
    row is taken at the BRAKING_STEPS points to the end. The sensitivity to
    v is the end's motion where the largest is at the end and the row rises
    towards it; inside the line it is 0 and the gradient the component
    across the line (the largest value over the line does not move as its
    points slide along it). Omega turns the line about its start. At the
    start (stopped within the next sample: the line is its start), none."""
    ahead = math.copysign(max(v * v / (2 * acceleration) - abs(v) * dt / 2, 0.0), v)
    direction = np.array([math.cos(heading), math.sin(heading)])
    count = row_kinds.shape[0]
    largest = np.zeros(count)
    gradients = np.zeros((count, 2))
    distance = np.zeros(count)
    for row in range(count):
        one_kind, one_row = row_kinds[row : row + 1], rows[row : row + 1]

        def at(
            on: float, kind: IntArray = one_kind, row: FloatArray = one_row
        ) -> tuple[float, FloatArray]:
            value, gradient = constraint_values(kind, row, position + on * direction, margin)
            return float(value[0]), gradient[0]

        if row_kinds[row] == POLYGON_ROW:
            points = [ahead * i / BRAKING_STEPS for i in range(1, BRAKING_STEPS + 1)]
            taken = [at(on) for on in (points if ahead != 0.0 else [0.0])]
            best = int(np.argmax([value for value, _ in taken]))  # the first of equals
            largest[row], gradients[row] = taken[best]
            distance[row] = points[best] if ahead != 0.0 else 0.0
            continue
        start, end = at(0.0), at(ahead)
        largest[row], gradients[row] = start
        if ahead == 0.0:
            continue
        curvature = 0.0
        if row_kinds[row] == ELLIPSE_ROW:
            p = one_row[0]
            cos_phi, sin_phi = math.cos(p[4]), math.sin(p[4])
            local = np.array([[cos_phi, sin_phi], [-sin_phi, cos_phi]]) @ direction
            curvature = 2.0 * p[5] * float(local @ (local / p[2:4] ** 2))
        if curvature < 0.0:
            peak = -float(start[1] @ direction) / curvature
            if min(0.0, ahead) < peak < max(0.0, ahead):
                largest[row], gradients[row] = at(peak)
                distance[row] = peak
                continue
        if end[0] > start[0]:
            largest[row], gradients[row] = end
            distance[row] = ahead
    sensitivity = np.zeros((count, 4))
    sensitivity[:, 1] = -distance * dt * direction[1]
    sensitivity[:, 3] = distance * dt * direction[0]
    inner = (distance != 0.0) & ((distance != ahead) | ((gradients @ direction) * ahead <= 0.0))
    across = gradients[:, 1] * direction[0] - gradients[:, 0] * direction[1]
    gradients[inner] = np.column_stack([-across * direction[1], across * direction[0]])[inner]
    at_end = (distance != 0.0) & ~inner
    along = abs(v) / acceleration - dt / 2  # d(v^2 / (2 a) - |v| dt / 2) / dv
    sensitivity[at_end, 0] = along * direction[0]
    sensitivity[at_end, 2] = along * direction[1]
    return largest, gradients, sensitivity, inner


def round_ellipses_on(
    position: FloatArray,
    bearing: float,
    distance: float,
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    held: float,
    skip: int,
) -> tuple[float, float, int]:
    """The bearing form's heading round the first keep-out ellipse (grown by
    ``margin``) but row ``skip`` that the straight way to the target
    crosses: along its tangent, on the side the way passes its centre (left
    when head-on) or on the side ``held`` (1 the left, -1 the right) where it
    is not 0; (the heading, the side, the row; 0 and -1 where it crosses none)."""
    way = distance * np.array([math.cos(bearing), math.sin(bearing)])
    best, heading, chosen, rounded = 1.0, bearing, 0.0, -1
    for i, (kind, p) in enumerate(zip(row_kinds, row_params, strict=True)):
        if i == skip or kind != ELLIPSE_ROW or p[5] > 0.0:
            continue
        rotation = np.array([[math.cos(p[4]), -math.sin(p[4])], [math.sin(p[4]), math.cos(p[4])]])
        scale = np.array([p[2] + margin, p[3] + margin])
        q = (rotation.T @ (position - p[:2])) / scale  # the unit circle's frame
        d = (rotation.T @ way) / scale
        if -(q @ d) <= 0.0:
            continue
        along = min(-(q @ d) / (d @ d), 1.0)
        if along >= best or np.hypot(*(q + along * d)) ** 2 >= 1.0:
            continue
        best, rounded = along, i
        # here -1 the left, 1 the right
        side = -1.0 if d[0] * q[1] - d[1] * q[0] >= 0.0 else 1.0
        if held != 0.0:
            side = -held
        chosen = -side
        tangent = side * np.array([-q[1], q[0]]) - math.sqrt(max(q @ q - 1.0, 0.0)) * q
        world = rotation @ (scale * tangent)
        heading = math.atan2(world[1], world[0])
    return heading, chosen, rounded


def gone_round(
    position: FloatArray,
    bearing: float,
    distance: float,
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    held: float,
    travel: float,
) -> tuple[float, float]:
    """:func:`round_ellipses_on`, and round each further zone its way round
    crosses, on the same side, while that turns no more than a quarter turn
    off the direction of travel ``travel``: (the heading, the side)."""
    heading, side, rounded = round_ellipses_on(
        position, bearing, distance, row_kinds, row_params, margin, held, -1
    )
    for _ in range(len(row_kinds) - 1):
        if rounded < 0:
            break
        further, _, rounded = round_ellipses_on(
            position, heading, distance, row_kinds, row_params, margin, side, rounded
        )
        # not round one the robot would turn back for, a quarter turn off its travel
        if rounded < 0 or abs(wrap_angle(further - travel)) > 0.5 * math.pi:
            break
        heading = further
    return heading, side


def way_round_zones(
    position: FloatArray,
    bearing: float,
    distance: float,
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    held: float,
    travel: float,
) -> tuple[float, float]:
    """The bearing form's heading round the keep-out ellipses and its side:
    the side ``held`` from the sample before where it is not 0, else the one
    the way passes the first ellipse's centre on; where the held side's way
    round turns more than a quarter turn off the straight way, the one whose
    way round turns less off ``travel``, the heading the robot drives along."""
    heading, side = gone_round(
        position, bearing, distance, row_kinds, row_params, margin, held, travel
    )
    if held != 0.0 and abs(wrap_angle(heading - bearing)) > 0.5 * math.pi:
        other, other_side = gone_round(
            position, bearing, distance, row_kinds, row_params, margin, -held, travel
        )
        if abs(wrap_angle(other - travel)) < abs(wrap_angle(heading - travel)):
            return other, other_side
    return heading, side


def riccati_gain(
    theta: float, v: float, omega: float, dt: float, q: FloatArray, r: FloatArray
) -> FloatArray:
    """Eqs. (20)-(21) at the linearisation (theta, v, omega).

    At rest only the speed input moves the robot, along ``u = B[:2, 0]``; the
    lateral direction is unreachable and eq. (21) has no solution on the whole
    pose. There it is solved on the reachable subspace (along ``u``, heading)
    with the weight of Q-hat along ``u``: the lateral error is not weighted.
    """
    a = state_jacobian(theta, v, omega, dt)
    b = input_jacobian(theta, v, omega, dt)
    q_hat, r_hat = np.diag(q), np.diag(r)
    if v == 0.0:
        along = b[:2, 0] / np.linalg.norm(b[:2, 0])
        basis = np.array([[along[0], 0.0], [along[1], 0.0], [0.0, 1.0]])
        reduced = solve_discrete_are(
            basis.T @ a @ basis, basis.T @ b, basis.T @ q_hat @ basis, r_hat
        )
        pi = basis @ reduced @ basis.T
    else:
        pi = solve_discrete_are(a, b, q_hat, r_hat)  # eq. (21)
    return np.asarray(np.linalg.solve(r_hat + b.T @ pi @ b, b.T @ pi @ a))  # eq. (20)


def scheduled_gain(
    theta: float, v: float, omega: float, dt: float, q: FloatArray, r: FloatArray
) -> FloatArray:
    """The regulator gain T at (theta, v, omega). Below MIN_SPEED it is blended
    linearly between the at-rest gain and the gain at +-MIN_SPEED, so that it
    is continuous in v (see wmr_mission.kernels.riccati)."""
    if abs(v) >= MIN_SPEED:
        return riccati_gain(theta, v, omega, dt, q, r)
    at_rest = riccati_gain(theta, 0.0, omega, dt, q, r)
    if v == 0.0:
        return at_rest
    edge = riccati_gain(theta, MIN_SPEED if v > 0.0 else -MIN_SPEED, omega, dt, q, r)
    share = abs(v) / MIN_SPEED
    return (1.0 - share) * at_rest + share * edge


def constraint_values(
    row_kinds: IntArray, row_params: FloatArray, position: FloatArray, margin: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """Each constraint row's value (violated when > 0) and gradient in (x, y);
    a polygon row's allowed side shrunk by ``margin`` (:func:`shrunk` moves the
    others)."""
    values = np.zeros(row_kinds.shape[0])
    gradients = np.zeros((row_kinds.shape[0], 2))
    for i, (kind, p) in enumerate(zip(row_kinds, row_params, strict=True)):
        if kind == POLYGON_ROW:  # minus the signed distance, kernels.convex
            distance, gx, gy = polygon_distance(p, float(position[0]), float(position[1]))
            values[i] = margin - distance
            gradients[i] = -gx, -gy
        elif kind == ELLIPSE_ROW:
            cos_phi, sin_phi = math.cos(p[4]), math.sin(p[4])
            rotation = np.array([[cos_phi, -sin_phi], [sin_phi, cos_phi]])
            local = rotation.T @ (position - p[:2])
            scale = 1.0 / p[2:4] ** 2
            values[i] = p[5] * (local @ (scale * local) - 1.0)
            gradients[i] = p[5] * rotation @ (2.0 * scale * local)
        else:
            values[i] = p[:2] @ position - p[2]
            gradients[i] = p[:2]
    return values, gradients


def shrunk(row_params: FloatArray, row_kinds: IntArray, margin: float) -> FloatArray:
    """The rows with their allowed side shrunk by ``margin`` [m]: a half-plane's
    offset, an ellipse's semi-axes (grown for a keep-out one); a polygon row
    as it is (:func:`constraint_values` takes its margin)."""
    params = row_params.copy()
    for i, kind in enumerate(row_kinds):
        if kind == ELLIPSE_ROW:
            params[i, 2:4] = np.maximum(params[i, 2:4] - params[i, 5] * margin, 1e-9)
        elif kind != POLYGON_ROW:
            params[i, 2] -= margin
    return params


def regulate_input(
    estimate: FloatArray,
    estimate_prev: FloatArray,
    u_prev: FloatArray,
    target: FloatArray,
    row_kinds: IntArray,
    row_params: FloatArray,
    controller: PaperTuning,
    robot: Plant,
    memory: FloatArray,
    work: Scratch,
    u_out: FloatArray,
) -> None:
    """Case 1: the gain-scheduled regulator, eq. (19), plus eq. (28) where the
    prediction violates a constraint row; then the limits."""
    form, align_radius, reverse = controller.form, controller.align_radius, controller.reverse
    q, r, w, m = controller.q, controller.r, controller.w, controller.m
    limits, dt = robot.limits, robot.dt
    v_prev, omega_prev = float(u_prev[0]), float(u_prev[1])
    # scipy's solver reports no iteration count.
    memory[DOUBLINGS] = 0.0
    if form == INCREMENT:
        # eq. (19) literally: u_k = u_{k-1} - T_{k-1} (x_{k|k} - x_{k-1|k-1}).
        gain = scheduled_gain(float(estimate_prev[2]), v_prev, omega_prev, dt, q, r)
        u = u_prev - gain @ (estimate - estimate_prev)
    else:
        speed = v_prev
        deviation = estimate - target
        deviation[2] = wrap_angle(float(deviation[2]))
        if form == BEARING:
            distance = float(np.hypot(deviation[0], deviation[1]))
            if distance < align_radius:
                memory[ALIGNING] = 1.0
            elif distance > 2.0 * align_radius:
                memory[ALIGNING] = 0.0
            if memory[ALIGNING] == 0.0:
                # Far from the target: head for it (or back onto it).
                bearing = math.atan2(-deviation[1], -deviation[0])
                if row_kinds.shape[0]:  # round a keep-out zone on the way
                    way, memory[ROUND_SIDE] = way_round_zones(
                        estimate[:2], bearing, distance, row_kinds, row_params,
                        robot.constraint_margin, float(memory[ROUND_SIDE]),
                        estimate[2] + math.pi * memory[REVERSING],
                    )  # fmt: skip
                    if way != bearing:
                        bearing = way
                        deviation[:2] = -distance * np.array([math.cos(way), math.sin(way)])
                deviation[2] = wrap_angle(float(estimate[2]) - bearing)
                if reverse:  # backwards past abeam, with hysteresis; at speed under
                    # acceleration limits, on where turning round is sooner
                    off = abs(float(deviation[2]))
                    behind = off > 0.5 * math.pi + REVERSE_HYSTERESIS
                    in_front = off < 0.5 * math.pi - REVERSE_HYSTERESIS
                    if behind and not turns_sooner(v_prev, off, limits):
                        memory[REVERSING] = 1.0
                    elif in_front and not turns_sooner(-v_prev, math.pi - off, limits):
                        memory[REVERSING] = 0.0
                    if memory[REVERSING]:
                        deviation[2] = wrap_angle(float(deviation[2]) - math.pi)
                # eq. (20) linearised at a speed of the direction chosen
                speed = min(v_prev, 0.0) if memory[REVERSING] else max(v_prev, 0.0)
            else:
                memory[ROUND_SIDE] = 0.0  # the way round chosen afresh after
                # At the target: keep the position error along the heading only.
                facing = np.array([math.cos(estimate[2]), math.sin(estimate[2])])
                deviation[:2] = (deviation[:2] @ facing) * facing
        gain = scheduled_gain(float(estimate[2]), speed, omega_prev, dt, q, r)
        u = -gain @ deviation
        if form == BEARING and not memory[ALIGNING]:
            # no speed against the direction chosen: the robot turns first
            u[0] = min(u[0], 0.0) if memory[REVERSING] else max(u[0], 0.0)
        # the deceleration planned: stopped within the error left
        reach = stopping_speed(float(np.hypot(deviation[0], deviation[1])), float(limits[2]), dt)
        turn = stopping_speed(abs(float(deviation[2])), float(limits[3]), dt)
        u = np.array([np.clip(u[0], -reach, reach), np.clip(u[1], -turn, turn)])
    # the turn rate moves by at most TURN_SLEW of its limit a sample
    slew = TURN_SLEW * float(limits[1])
    u[1] = min(max(float(u[1]), omega_prev - slew), omega_prev + slew)
    v, omega = saturate(float(u[0]), float(u[1]), v_prev, omega_prev, limits, dt)
    u_out[0], u_out[1] = v, omega
    memory[CORRECTED] = 0.0
    if row_kinds.shape[0] == 0:
        return
    # eq. (28): the rows the prediction violates, at most the two worst.
    margin = robot.constraint_margin
    rows = shrunk(row_params, row_kinds, margin)
    rate = float(limits[2])

    def held(v: float, omega: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The rows' barrier values with the input (v, omega), their
        gradients, whether each is held on the braking line, and that line's
        points' sensitivities."""
        predicted = predict(estimate, v, omega, dt)
        values, gradients = constraint_values(row_kinds, rows, predicted[:2], margin)
        if controller.barrier_rate < 1.0:  # the barrier c(k+1) <= (1 - gamma) c(k)
            now, _ = constraint_values(row_kinds, rows, estimate[:2], margin)
            values = values - (1.0 - controller.barrier_rate) * now
        braked = np.zeros(values.size, dtype=bool)
        moves = np.zeros((values.size, 4))
        if math.isfinite(rate):
            # also on the whole line braking from v takes (from v_{k-1} now), at
            # its point furthest in, whichever is further in
            on_line, line_gradients, moves, _ = largest_on_braking_line(
                row_kinds, rows, margin, predicted[:2], float(predicted[2]), v, rate, dt
            )
            if controller.barrier_rate < 1.0:
                then, _, _, _ = largest_on_braking_line(
                    row_kinds, rows, margin, estimate[:2], float(estimate[2]), v_prev, rate, dt
                )
                on_line = on_line - (1.0 - controller.barrier_rate) * then
            braked = ~(on_line <= values)
            values = np.where(braked, on_line, values)
            gradients = np.where(braked[:, None], line_gradients, gradients)
        return values, gradients, braked, moves

    values, gradients, braked, moves = held(v, omega)
    violated = np.flatnonzero(~(values <= 0.0))
    if violated.size == 0:
        return
    worst = violated[np.argsort(-values[violated], kind="stable")][:2]
    d = np.column_stack([gradients[worst], np.zeros(worst.size)])
    b = input_jacobian(float(estimate[2]), v, omega, dt)
    if braked[worst[0]]:  # the braking line's point's own sensitivity, the worst row's
        b[:2, :] += moves[worst[0]].reshape(2, 2)
    du = corrective_input(d, -values[worst], b, w, m, limits)
    memory[CORRECTED] = 1.0
    corrected = np.array(saturate(v + du[0], omega + du[1], v_prev, omega_prev, limits, dt))
    # eq. (28) is first order: back towards the regulator's input (v, omega)
    # by the largest share, halved SHARE_HALVINGS times, at which the rows
    # hold, if they hold at the corrected input at all
    wanted = np.array([v, omega])
    if np.all(held(*corrected)[0] <= 0.0):
        low, high = 0.0, 1.0
        for _ in range(SHARE_HALVINGS):
            middle = 0.5 * (low + high)
            if np.all(held(*(corrected + middle * (wanted - corrected)))[0] <= 0.0):
                low = middle
            else:
                high = middle
        if low > 0.0:
            corrected = corrected + low * (wanted - corrected)
    u_out[0], u_out[1] = corrected


# The fast kernels and their reference forms: ``run_mission(mission,
# substitutes=REFERENCE)`` runs the loop as plain Python with these in place.
REFERENCE: dict[Any, Callable[..., Any]] = {
    observer.observer_step: observer_step,
    ekf.ekf_step: ekf_step,
    paper.track_input: track_input,
    paper.regulate_input: regulate_input,
}
