"""Section III.C: the Case 1 and Case 2 control laws, per sample.

Case 2 (``track`` phases): only the corrective action of eq. (27) on the
equality constraint "tracking output = reference at k+1":
``u_k = u_{k-1} + du2_k``.

Case 1 (``regulate`` and ``hold`` phases): the gain-scheduled regulator of
eqs. (19)-(21), plus the corrective action of eq. (28) at the samples where
the prediction violates an inequality constraint.

Both end with the actuator limits (magnitude, then optional rate).
docs/paper-notes.md gives the evidence for each choice below.
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import numpy as np
from pydantic import Field

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.controllers.constrained_tracking import (
    aim_gap,
    aim_round_zones,
    aimed_from_its_place,
    held_where_braking_ends,
    keep_constraints,
    ramped_offset,
    zone_between,
)
from wmr_mission.controllers.registry import ControllerSettings, ControllerType
from wmr_mission.fields import Flag, Model, NonNegative, Positive
from wmr_mission.kernels.convex import HEADER, PER_VERTEX, polygon_distance
from wmr_mission.kernels.corrective import (
    ELLIPSE_ROW,
    POLYGON_ROW,
    corrective_input,
    kept_row_slot,
    polygon_value,
    row_value_with_margin,
)
from wmr_mission.kernels.jit import inlined, kernel
from wmr_mission.kernels.loop import EnteredPhase
from wmr_mission.kernels.model import (
    hypot,
    input_jacobian_into,
    jacobian_terms,
    preview_rows,
    saturate,
    step,
    stopping_speed,
    wrap_angle,
)
from wmr_mission.kernels.records import Plant, Scratch, scratch
from wmr_mission.kernels.riccati import (
    MIN_SPEED,
    Mat3,
    newton_riccati,
    regulator_gain,
    scalar_solution,
    solve_riccati,
)

# --- settings: the mission's `controller: {type: paper, ...}` -----------------

# [m] the smallest default look-ahead distance (the tracked point ahead of the axle).
MIN_LOOK_AHEAD = 0.05
# [s] time constant of a zone's barrier: a zone's value may shrink by dt / BARRIER_TIME
# of itself per sample (the tracking error's time constant, Tracking.time_constant).
BARRIER_TIME = 0.1
# Largest fraction of the bearing error the tracked output turns by per sample.
HEADING_STEP = 0.3
# The largest change of the regulator's turn rate in one sample, as a share of
# its limit: half the verdict's bound on a jump (turn_rate_jump_max).
TURN_SLEW = 0.5
# The share of the turn-rate limit the position estimate's noise may take as
# jitter through the tracking law (docs/paper-notes.md, eqs. (6)-(7) under noise).
JITTER_SHARE = 0.01
# The share of each input's range the tracking law's error dynamics follow as
# designed under the robot's acceleration limits (attainable_time_constant).
ATTAINABLE_SHARE = 0.2
# Under a turn-rate acceleration limit a_omega an output error e is taken out
# no faster than at the time constant cbrt(e / (TURNABLE_SHARE a_omega v)),
# v the path's speed (turn_acceleration): the heading it asks is one the turn
# reaches in that time (docs/paper-notes.md, eq. (27) under acceleration limits).
TURNABLE_SHARE = 0.7
# The least path speed, as a share of limits.v, that pace is figured at.
TURNABLE_SPEED = 0.1
# [rad] Within this angle of the way its tracked point must move, a robot
# turning at its turn-rate limit keeps the speed its limit leaves; beyond it
# that speed is cut by the cosine, none at a right angle (track_input). Cut
# from the limit itself, a start turning 0.4 rad at the limit left the limit
# with a jump of 1.12 rad/s, 1.04 before (docs/paper-notes.md, eq. (27),
# "The speed while the turn is at its limit").
FULL_SPEED_TURN = 0.3
# The share of the turn-rate limit the linearisation of eq. (24) may cost the
# tracking law's turn rate before eq. (27) is solved again at the input it
# asks for: the look-ahead point off its aim by e turns it by about e / (l dt)
# (track_input).
LINEAR_SHARE = 0.01


class Tracking(Model):
    """Case 2 law: which point of the robot follows the path."""

    output: Literal["look-ahead", "axle"] = Field(
        default="look-ahead",
        description="look-ahead: a point ahead of the axle; axle: the literal eq. (27).",
    )
    look_ahead: Positive | None = Field(
        default=None,
        description=(
            "Distance of the look-ahead point ahead of the axle [m]; "
            "null = max(0.05, robot.limits.v * robot.dt), where the law is well conditioned "
            "at every speed the limits allow."
        ),
    )
    time_constant: NonNegative = Field(
        default=0.1,
        description=(
            "Time constant of the tracking error [s]: each sample leaves exp(-dt / "
            "time_constant) of the output's error, the path's own motion fed forward; "
            "0 = close the whole error in one sample (the literal eq. 27; always so for "
            "output: axle). Under acceleration limits the law uses at least a fifth of the "
            "time to full speed and to full turn rate, what the limits follow, and closes a "
            "larger error no faster than its heading can be turned at the turn-rate "
            "acceleration; the verdicts keep this value."
        ),
    )


class Regulation(Model):
    """Case 1 law: how a target pose is approached."""

    form: Literal["bearing", "deviation", "increment"] = Field(
        default="bearing",
        description=(
            "bearing: drive to the point then turn (parks); deviation: LQR on the pose "
            "error; increment: the literal eq. (19)."
        ),
    )
    align_radius: Positive = Field(
        default=0.01, description="Within this distance the bearing form turns to the target [m]."
    )
    reverse: Flag = Field(default=True, description="The bearing form may drive backwards.")


class PaperController(ControllerSettings):
    """The two-component controller: gain-scheduled LQR and corrective control."""

    type: Literal["paper"] = Field(
        default="paper", description="Controller kind (the default): the paper's."
    )

    Q: tuple[NonNegative, NonNegative, NonNegative] = Field(
        default=(4.0, 4.0, 4.0),
        description=(
            "Eq. (17) state weights (diagonal), >= 0. The case studies' are [1, 1, 1]: the "
            "regulator then closes its error with a time constant of about 1 s, 0.5 s with "
            "the default."
        ),
    )
    R: tuple[Positive, Positive] = Field(
        default=(1.0, 1.0), description="Eq. (17) input weights (diagonal), > 0."
    )
    W: tuple[Positive, Positive, Positive] = Field(
        default=(100.0, 100.0, 100.0), description="Eq. (22) constraint weights (diagonal), > 0."
    )
    M: tuple[Positive, Positive] = Field(
        default=(100.0, 100.0), description="Eq. (22) input weights (diagonal), > 0."
    )
    tracking: Tracking = Field(
        default_factory=lambda: Tracking.defaults(), description="Path tracking output."
    )
    regulation: Regulation = Field(
        default_factory=lambda: Regulation.defaults(), description="Regulation form."
    )

    def position_noise_budget(self, dt: float, speed_limit: float, turn_limit: float) -> float:
        """A lateral error ``e`` of the look-ahead point closed within the time
        constant ``tau`` turns the robot at about ``e / (l tau)``: the position
        estimate's noise may be ``JITTER_SHARE turn_limit l tau``. inf for the
        axle law (no look-ahead to scale by)."""
        distance = look_ahead(self, dt, speed_limit)
        if distance == 0.0:
            return math.inf
        tau = max(float(self.tracking.time_constant), float(dt))
        return JITTER_SHARE * float(turn_limit) * distance * tau


# --- the kernels ---------------------------------------------------------------


class PaperTuning(NamedTuple):
    """What the control laws of section III.C read."""

    look_ahead: float  # [m] tracked point ahead of the axle (0: eq. (27) literally)
    error_decay: float  # fraction of the tracked output's error left after one sample
    q: FloatArray  # diagonal of Q-hat, eq. (17)
    r: FloatArray  # diagonal of R-hat, eq. (17)
    w: FloatArray  # diagonal of W, eq. (22)
    m: FloatArray  # diagonal of M, eq. (22)
    form: int  # regulation form (BEARING, ...)
    align_radius: float  # [m]
    reverse: bool
    # Fraction of a zone's value the prediction must shed per sample, gamma of
    # the discrete-time barrier c(k+1) <= (1 - gamma) c(k): 1 puts a violated
    # prediction straight onto the bound (the one-sample eq. (28)).
    barrier_rate: float = 1.0
    # [m] the largest error of the tracked output closed at error_decay's pace;
    # a larger one is closed as this one is (inf: no such bound).
    error_reach: float = math.inf
    # [rad/s^2] TURNABLE_SHARE of the turn-rate acceleration limit the error
    # closed per sample follows (inf: no such limit, or a one-sample law).
    turn_acceleration: float = math.inf
    # [s] how far ahead, in the path's time, the aim's offset round the zones
    # is taken: the lag of an aim moving at the law's time constant.
    aim_lead: float = 0.0
    # [s] how far ahead the path's turns are previewed under a turn-rate
    # acceleration limit (0: none; kernels.model.preview_rows, anticipated).
    preview: float = 0.0
    # [m] how far ahead of the axle a track phase's zones are held
    # (rows_ahead; inf: at the tracked output itself)
    rows_ahead: float = math.inf


# Regulation forms (controller.regulation.form).
BEARING = 0  # default: regulate to the target, heading reference = bearing to it
DEVIATION = 1  # u = -T (x - x_ss): stalls short of the target (Brockett)
INCREMENT = 2  # literal eq. (19): u_k = u_{k-1} - T dx_{k-1}: brings the robot to rest

# Fields of the per-phase controller memory (``memory`` array), zeroed at
# phase entry (wmr_mission.sim.runner).
ALIGNING = 0  # 1.0 once within align_radius of the target (bearing form)
CORRECTED = 1  # 1.0 if the corrective action acted at this sample
DOUBLINGS = 2  # doubling steps of this sample's Riccati solve (0: none)
NEWTON = 3  # Newton steps of this sample's Riccati solve (0: none)
# The last solution of eq. (21) for |v| >= MIN_SPEED and the last at +-MIN_SPEED:
# the speed it was solved at (0.0: none yet), then pi in the body frame,
# (0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2), then its change from the
# solution before (0.0 after a cold start).
WARM_MOVING = 4
WARM_EDGE = 17
SYSTEM = 30  # scratch: the linear system of a Newton step, 6 rows of 7
REVERSING = 72  # 1.0 while the bearing form drives backwards to its target
# The aim's offset round the zones at the sample before, x then y (track phases).
AIM_OFFSET = 73
# The path's step at the sample before, and 1.0 if it turned in place there
# (track phases, hold_across_at_a_stop).
PATH_STEP = 75
TURNED_IN_PLACE = 76
# A track phase's direction of travel, decided at its first sample: 0.0 not
# yet, 1.0 forwards, -1.0 backwards (drives_backwards).
DIRECTION = 77
# The mirrored robot the law tracks with while driving backwards: its pose,
# then its previous input (mirrored_track_input).
MIRRORED = 78
# 1.0 while the robot, stopped at a keep-out zone with its aim beyond it,
# goes round from where it is (aimed_from_its_place).
HELD_AT_ZONE = 83
# The side the bearing form goes round its keep-out zones on, held while the
# straight way to the target crosses one (_bearing_round_zones): 1.0 the
# left of that way, -1.0 the right, 0.0 while it crosses none.
ROUND_SIDE = 84
MEMORY_SIZE = 85
# A robot slower than this share of its path's speed has stopped.
STOPPED_SHARE = 0.1
# [rad] how far past abeam (pi/2) the target must be to change the direction
# of travel of the bearing form.
REVERSE_HYSTERESIS = 0.2


@kernel
def _solved_again(
    estimate: FloatArray,
    u_prev: FloatArray,
    v: float,
    omega: float,
    aim_x: float,
    aim_y: float,
    controller: PaperTuning,
    robot: Plant,
    work: Scratch,
) -> tuple[float, float]:
    """Eq. (27) for the look-ahead point aimed at (aim_x, aim_y), linearised
    at the input (v, omega) within the limits instead of at u_{k-1}
    (track_input): that input plus the change the linearisation there asks
    for. Its own kernel: the tracking law rarely calls it."""
    look_ahead = controller.look_ahead
    dt = robot.dt
    x, y, theta = estimate[0], estimate[1], estimate[2]
    v, omega = saturate(v, omega, u_prev[0], u_prev[1], robot.limits, dt)
    d, eta, b = work.d, work.eta, work.b
    px, py, pth = step(x, y, theta, v, omega, dt)
    c = math.cos(pth)
    s = math.sin(pth)
    d[0, 2] = -look_ahead * s
    d[1, 2] = look_ahead * c
    eta[0] = aim_x - (px + look_ahead * c)
    eta[1] = aim_y - (py + look_ahead * s)
    input_jacobian_into(theta, v, omega, dt, b)
    both = int(np.int64(2))  # not the literal 2: one compiled corrective_input for all
    dv, dw = corrective_input(d, eta, both, b, controller.w, controller.m, robot.limits)
    return v + dv, omega + dw


@inlined
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
    """Case 2: ``u_k = u_{k-1} + du2_k`` with du2 of eq. (27), then the limits.

    ``reference_now`` and ``reference`` = (x, y, unit tangent x, unit tangent
    y) of the path at t_k and t_{k+1}. The tracked output is the point
    ``look_ahead`` ahead of the axle centre, aimed at the reference shifted by
    ``look_ahead`` along the path's tangent; ``look_ahead = 0`` is the literal
    eq. (27) on the axle centre.

    The constraint of eq. (27) is met at k+1 for the output's error left after
    one sample, ``error_decay`` times its error at k: the target is the path
    at t_{k+1} (its own motion, fed forward) minus that remaining error.
    ``error_decay = 0`` closes the whole error in one sample, the paper's form.

    ``path_turn`` [rad/s]: the path's turn rate as previewed, which a turn
    under a turn-rate acceleration limit is stopped relative to (0: stopped
    absolutely, as without the preview and while joining the path).
    """
    dt = robot.dt
    look_ahead = controller.look_ahead
    error_decay = controller.error_decay
    v_prev = u_prev[0]
    omega_prev = u_prev[1]
    # Read once: after the writes to the scratch arrays below the compiler
    # would read the heading again and recompute its sine and cosine.
    x, y, theta = estimate[0], estimate[1], estimate[2]
    c = math.cos(theta)
    s = math.sin(theta)
    # The output's error at k: shifted reference minus G(x_{k|k}).
    error_x = reference_now[0] + look_ahead * reference_now[2] - (x + look_ahead * c)
    error_y = reference_now[1] + look_ahead * reference_now[3] - (y + look_ahead * s)
    # x_{k+1|k} with the previous input held (section III.D).
    px, py, pth = step(x, y, theta, v_prev, omega_prev, dt)
    c = math.cos(pth)
    s = math.sin(pth)
    d, eta, b = work.d, work.eta, work.b
    # eq. (26): the tracked output G(x_{k+1}) and its Jacobian D.
    d[0, 0] = 1.0
    d[0, 1] = 0.0
    d[0, 2] = -look_ahead * s
    d[1, 0] = 0.0
    d[1, 1] = 1.0
    d[1, 2] = look_ahead * c
    # The error left at k+1. Far from the path, closing the same fraction of
    # a larger error turns the output's heading by more than a sample can
    # follow (it overshoots and turns back at the limit): the error closed
    # per sample is at most what error_reach leaves.
    left_x = error_decay * error_x
    left_y = error_decay * error_y
    distance = hypot(error_x, error_y)
    kept = error_decay
    if distance > controller.error_reach:
        # What the bound closes per sample, HEADING_STEP l; along the
        # heading, where closing turns nothing, up to what the speed limit
        # leaves over the path's own speed, the part across the heading
        # kept to HEADING_STEP l: behind a reference resting at a corner the
        # robot crawled at 0.3 of its speed limit, and the path moved on
        # while it was 0.6 m short, so it cut the corner (gen-188-polyline).
        # No faster than the speed acceleration limit stops it within the
        # error: the reference may rest where it is (gen-069-polyline ran
        # past a route's planned stop).
        closed = (1.0 - error_decay) * controller.error_reach
        along = (error_x * math.cos(theta) + error_y * math.sin(theta)) / distance
        if along > 0.0:
            top = min(robot.limits[0], stopping_speed(distance, robot.limits[2], dt))
            path_step = hypot(reference[0] - reference_now[0], reference[1] - reference_now[1])
            spare = along * (top * dt - path_step)
            across = math.sqrt(max(1.0 - along * along, 0.0))
            if across * spare > closed:
                spare = closed / across
            closed = min(max(closed, spare), (1.0 - error_decay) * distance)
        kept = 1.0 - closed / distance
        left_x = kept * error_x
        left_y = kept * error_y
    if controller.turn_acceleration != math.inf and distance > 0.0:
        # Under a turn-rate acceleration limit: closing an error e at the
        # time constant tau asks the heading about e / (v tau) off the path,
        # and beyond what the turn reaches and stops at within tau the turn
        # rate swings from one acceleration limit to the other and the robot
        # weaves about its path for good (a line 0.1 m beside it, 0.17 m
        # about it). tau at least cbrt(e / (a v)), the time that turn takes.
        speed = hypot(reference[0] - reference_now[0], reference[1] - reference_now[1]) / dt
        speed = max(speed, TURNABLE_SPEED * robot.limits[0])
        pace = math.pow(distance / (controller.turn_acceleration * speed), 1.0 / 3.0)
        if 1.0 - dt / pace > kept:
            kept = 1.0 - dt / pace
            left_x = kept * error_x
            left_y = kept * error_y
    aim_x = reference[0] + look_ahead * reference[2] - left_x
    aim_y = reference[1] + look_ahead * reference[3] - left_y
    eta[0] = aim_x - (px + look_ahead * c)
    eta[1] = aim_y - (py + look_ahead * s)
    # eq. (24): the sensitivity of x_{k+1} to u_k, at (x_{k|k}, u_{k-1}).
    input_jacobian_into(theta, v_prev, omega_prev, dt, b)
    both = int(np.int64(2))  # not the literal 2: one compiled corrective_input for all
    dv, dw = corrective_input(d, eta, both, b, controller.w, controller.m, robot.limits)
    v = v_prev + dv
    omega = omega_prev + dw
    # Eq. (24) is linear about u_{k-1}; the output at k+1 is not: it misses
    # its aim by about dt^2 (|dv dw| + l dw^2) / 2. After a large change (the
    # input before came from an estimate not yet converged: -3 m/s, -20 rad/s
    # against a law that then asks +8 m/s) the miss turned the rate to +19.5
    # rad/s where about +3 met the aim, and back to -6 at the next sample, a kick
    # (case2-headings run 287). Where the miss costs the turn rate more than
    # LINEAR_SHARE of its limit, eq. (27) is solved once more, linearised at
    # the input the first solve asks for, within the limits (the input the
    # robot can take); not in the one-sample laws (error_decay 0), the
    # paper's eq. (27) as it is solved there.
    miss = 0.5 * dt * (abs(dv * dw) + look_ahead * dw * dw)
    if error_decay > 0.0 and miss > LINEAR_SHARE * robot.limits[1] * look_ahead:
        v, omega = _solved_again(estimate, u_prev, v, omega, aim_x, aim_y, controller, robot, work)
    planned = robot.limits[3] != math.inf
    if planned or abs(omega) >= robot.limits[1]:
        # The turn planned: eq. (27) turns the output towards its aim at a
        # rate the turn-rate acceleration cannot take back in time, and the
        # heading swings past it and back, for good (a line entered 0.5 rad
        # off wove 1.06 m about it). Turning towards the heading the output's
        # move asks for (reversed when driving backwards), no faster than
        # the acceleration limit stops the turn there.
        move_x = aim_x - x - look_ahead * math.cos(theta)
        move_y = aim_y - y - look_ahead * math.sin(theta)
        if v < 0.0:
            move_x = -move_x
            move_y = -move_y
        turn = wrap_angle(math.atan2(move_y, move_x) - theta)
        # And the speed along the way the output must move: a robot facing
        # away from it turns before it drives, not while (it drove off
        # sideways at full turn rate and swung back round at the limits).
        # Without acceleration limits only while it turns towards that way
        # at its turn-rate limit, where it cannot turn faster to follow: it
        # drove on at full speed and turned more than half a turn at the
        # limit to come back (gen-198-line: 3.3 rad in 1.3 s for a line
        # 2.5 rad off). Below the limit the law coordinates the two inputs
        # itself, and case 1's spiral in keeps its end (docs/paper-notes.md,
        # eq. (27), "The speed while the turn is at its limit").
        # The speed cut is the law's, counted no higher than the limit over
        # cos FULL_SPEED_TURN: a robot behind its reference asks more than
        # it can have, and cut from there it drove off at its limit while it
        # turned (put down 2.8 rad off a line, 3.2 rad at the limit in one
        # stretch). Not in the one-sample laws (error_decay 0), whose speed
        # is beyond the limit at every sample (the paper's eq. (27)).
        if planned or omega * turn > 0.0:
            if error_decay > 0.0:
                top = robot.limits[0] / math.cos(FULL_SPEED_TURN)
                v = math.copysign(min(abs(v), top), v)
            v *= max(math.cos(turn), 0.0)
        # Stopped relative to the path's own turn (as previewed, ramped at the
        # acceleration limit) once on it: the way the output must move turns
        # with the path, and a turn stopped absolutely left the heading
        # lagging it by omega^2 / (2 a) on an arc, the robot 0.12 m wide of a
        # spiral (gen-021-elliptical-spiral; docs/paper-notes.md, eq. (27),
        # "The path's turn previewed over its own turn rate").
        if planned:
            ahead = omega - path_turn
            if ahead * turn > 0.0:
                reach = stopping_speed(abs(turn), robot.limits[3], dt)
                omega = path_turn + min(max(ahead, -reach), reach)
    u_out[0], u_out[1] = saturate(v, omega, v_prev, omega_prev, robot.limits, dt)


@kernel
def path_turn_rate(reference_now: FloatArray, reference: FloatArray, dt: float) -> float:
    """[rad/s] The path's turn rate from t_k to t_{k+1}: the angle between its
    unit tangents over dt; 0 where it rests (no tangent)."""
    cross = reference_now[2] * reference[3] - reference_now[3] * reference[2]
    dot = reference_now[2] * reference[2] + reference_now[3] * reference[3]
    rate: float = math.atan2(cross, dot) / dt
    if math.isnan(rate):
        return 0.0
    return rate


Gain = tuple[float, float, float, float, float, float]  # T of eq. (20), 2x3 row by row


@kernel
def _input_weight(b: Gain, r0: float, r1: float, i: int, j: int) -> float:
    """(B R^-1 B^T)[i, j] for B (3x2) row by row, R = diag(r0, r1)."""
    weight: float = b[2 * i] * b[2 * j] / r0 + b[2 * i + 1] * b[2 * j + 1] / r1
    return weight


@kernel
def _gain_at_rest(omega: float, dt: float, qb: Mat3, r: FloatArray) -> Gain:
    """T of eqs. (20)-(21) at v = 0 on the reachable subspace, in closed form,
    in the body frame (``qb`` is Q-hat seen from it).

    At rest A = I and B = [[b11, 0], [b21, 0], [0, dt]]: the speed input moves
    the robot along u = (b11, b21) / |(b11, b21)|, the turn rate turns it, and
    the lateral direction is unreachable. With the state weight kept along u
    only, Q_xy -> (u^T Q_xy u) u u^T, eq. (21) splits into two scalar
    equations with a = 1 (riccati.scalar_solution)."""
    _, _, b11, _, b21, _ = jacobian_terms(0.0, 0.0, omega, dt)
    norm = hypot(b11, b21)
    ux = b11 / norm
    uy = b21 / norm
    along = scalar_solution(qb[0] * ux * ux + 2.0 * qb[1] * ux * uy + qb[4] * uy * uy, norm, r[0])
    turn = scalar_solution(qb[8], dt, r[1])
    pi = (along * ux * ux, along * ux * uy, 0.0, along * ux * uy, along * uy * uy, 0.0, 0.0, 0.0,
          turn)  # fmt: skip
    identity = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    return regulator_gain(identity, (b11, 0.0, b21, 0.0, 0.0, dt), r, pi)


@kernel
def _solve_gain(
    v: float,
    omega: float,
    dt: float,
    qb: Mat3,
    r: FloatArray,
    memory: FloatArray,
    slot: int,
) -> Gain:
    """T of eqs. (20)-(21) at (v != 0, omega) in the body frame (``qb`` is
    Q-hat seen from it). By Newton's method from the solutions the previous
    two samples left in ``memory[slot:]``, extrapolated, when there are any
    at a speed of the same sign; else, or if Newton gives up, by doubling.
    Writes the new solution there and the steps taken to ``memory[NEWTON]``
    and ``memory[DOUBLINGS]``."""
    a13, a23, b11, b12, b21, b22 = jacobian_terms(0.0, v, omega, dt)
    a = (1.0, 0.0, a13, 0.0, 1.0, a23, 0.0, 0.0, 1.0)
    b = (b11, b12, b21, b22, 0.0, dt)
    m = memory
    warm = m[slot] * v > 0.0  # solved at a speed of the same sign
    steps = -1
    if warm:
        # The last solution plus its last change (0 after a cold start).
        p0 = m[slot + 1] + m[slot + 7]
        p1 = m[slot + 2] + m[slot + 8]
        p2 = m[slot + 3] + m[slot + 9]
        p4 = m[slot + 4] + m[slot + 10]
        p5 = m[slot + 5] + m[slot + 11]
        p8 = m[slot + 6] + m[slot + 12]
        pi, steps = newton_riccati(
            a, b, r, qb, (p0, p1, p2, p1, p4, p5, p2, p5, p8), memory, SYSTEM
        )
        memory[NEWTON] = abs(steps)
    if steps < 0:
        r0 = float(r[0])
        r1 = float(r[1])
        g = (
            _input_weight(b, r0, r1, 0, 0),
            _input_weight(b, r0, r1, 0, 1),
            _input_weight(b, r0, r1, 0, 2),
            _input_weight(b, r0, r1, 1, 0),
            _input_weight(b, r0, r1, 1, 1),
            _input_weight(b, r0, r1, 1, 2),
            _input_weight(b, r0, r1, 2, 0),
            _input_weight(b, r0, r1, 2, 1),
            _input_weight(b, r0, r1, 2, 2),
        )
        pi, doublings = solve_riccati(a, g, qb)
        memory[DOUBLINGS] = doublings
    stored = (pi[0], pi[1], pi[2], pi[4], pi[5], pi[8])
    for n in range(6):
        m[slot + 7 + n] = stored[n] - m[slot + 1 + n] if warm else 0.0
        m[slot + 1 + n] = stored[n]
    m[slot] = v
    return regulator_gain(a, b, r, pi)


@kernel
def scheduled_gain(
    theta: float,
    v: float,
    omega: float,
    dt: float,
    q: FloatArray,
    r: FloatArray,
    memory: FloatArray,
    out: FloatArray,
) -> None:
    """:func:`scheduled_gain_facing` at the heading ``theta``."""
    scheduled_gain_facing(math.cos(theta), math.sin(theta), v, omega, dt, q, r, memory, out)


@kernel
def scheduled_gain_facing(
    c: float,
    s: float,
    v: float,
    omega: float,
    dt: float,
    q: FloatArray,
    r: FloatArray,
    memory: FloatArray,
    out: FloatArray,
) -> None:
    """Eqs. (20)-(21) for the linearisation at (theta, v, omega), the heading
    theta given by its cosine ``c`` and sine ``s`` (the regulator has them
    already, for its prediction: each is a library call): writes T
    (2x3) into ``out``, and the Riccati steps taken into ``memory[NEWTON]`` and
    ``memory[DOUBLINGS]``.

    Eq. (1) turns with the heading: A(theta) = Rot A(0) Rot^T and
    B(theta) = Rot B(0) with Rot the rotation by theta of (x, y), so eq. (21)
    is solved in the body frame, where only Q-hat turns (not at all when it
    weighs x and y alike), and T(theta) = T_body Rot^T.

    For |v| < MIN_SPEED the gain is blended linearly between the at-rest gain
    and the gain at +-MIN_SPEED (see wmr_mission.kernels.riccati), so it is
    continuous in v. ``memory`` keeps the solutions for |v| >= MIN_SPEED and
    at +-MIN_SPEED from sample to sample: the next sample's warm starts."""
    if memory.shape[0] < MEMORY_SIZE:  # compiled code checks no bounds
        raise ValueError("the controller memory holds MEMORY_SIZE numbers")
    memory[NEWTON] = 0.0
    memory[DOUBLINGS] = 0.0
    v = float(v)
    omega = float(omega)
    q0 = float(q[0])
    q1 = float(q[1])
    cross = (q1 - q0) * c * s
    # Rot^T Q Rot on (x, y).
    qb = (q0 * c * c + q1 * s * s, cross, 0.0, cross, q0 * s * s + q1 * c * c, 0.0, 0.0, 0.0,
          float(q[2]))  # fmt: skip
    if abs(v) >= MIN_SPEED:
        gain = _solve_gain(v, omega, dt, qb, r, memory, WARM_MOVING)
    else:
        gain = _gain_at_rest(omega, dt, qb, r)
        if v != 0.0:
            edge = MIN_SPEED if v > 0.0 else -MIN_SPEED
            at_edge = _solve_gain(edge, omega, dt, qb, r, memory, WARM_EDGE)
            alpha = abs(v) / MIN_SPEED
            gain = (
                (1.0 - alpha) * gain[0] + alpha * at_edge[0],
                (1.0 - alpha) * gain[1] + alpha * at_edge[1],
                (1.0 - alpha) * gain[2] + alpha * at_edge[2],
                (1.0 - alpha) * gain[3] + alpha * at_edge[3],
                (1.0 - alpha) * gain[4] + alpha * at_edge[4],
                (1.0 - alpha) * gain[5] + alpha * at_edge[5],
            )
    out[0, 0], out[0, 1], out[0, 2] = gain[0] * c - gain[1] * s, gain[0] * s + gain[1] * c, gain[2]
    out[1, 0], out[1, 1], out[1, 2] = gain[3] * c - gain[4] * s, gain[3] * s + gain[4] * c, gain[5]


@inlined
def _keeps_out_of_a_zone(row_kinds: IntArray, row_params: FloatArray) -> bool:
    """Whether a row keeps the robot out of an ellipse, a box or a polygon:
    one the bearing form may go round (:func:`_bearing_round_zones`), which
    is not called without one: the compiler computes the cosine and sine of
    the bearing it takes ahead of its loop, library calls each, whatever the
    rows."""
    for i in range(row_kinds.shape[0]):
        if row_kinds[i] == POLYGON_ROW:
            return True
        if row_kinds[i] == ELLIPSE_ROW and not row_params[i, 5] > 0.0:
            return True
    return False


@kernel
def _polygon_tangent(
    p: FloatArray, margin: float, x: float, y: float, wx: float, wy: float, held: float
) -> tuple[float, float, float]:
    """Where the straight way from (x, y) to (x + wx, y + wy) crosses the
    keep-out polygon row ``p`` grown by ``margin`` (its Minkowski sum with a
    disc of that radius): (the share of the way to the point of it nearest
    the polygon's centre, the heading along the tangent to the grown polygon
    on the side the way passes its centre, the left when head-on, or on the
    side ``held`` where it is not 0 (1 the left, -1 the right), that side);
    (inf, 0, 0) where it does not cross (zone_between: its edges moved out
    by the margin). On the grown polygon's edge the tangent is the edge's
    own direction, on that side."""
    reach = wx * wx + wy * wy
    if reach == 0.0:
        return math.inf, 0.0, 0.0
    # The way's point nearest the disc about the vertices that holds them.
    along = min(max(((p[1] - x) * wx + (p[2] - y) * wy) / reach, 0.0), 1.0)
    here, gx, gy = polygon_distance(p, x, y)
    if here <= margin:  # on the grown edge: crossed where the way leads in
        if gx * wx + gy * wy >= 0.0:
            return math.inf, 0.0, 0.0
    elif not zone_between(POLYGON_ROW, p, margin, x, y, x + wx, y + wy):
        return math.inf, 0.0, 0.0
    # the side the way passes the centre on: round by the other one (1 the
    # left, -1 the right; the left when head-on), or the side held
    side = -1.0 if wx * (p[2] - y) - wy * (p[1] - x) > 0.0 else 1.0
    if held != 0.0:
        side = held
    if here <= margin:  # on the grown edge: along it, the zone on the other side
        return along, math.atan2(-side * gx, side * gy), side
    # the tangent from (x, y) to the discs about the vertices on that side,
    # twice the margin wide (on the margin's own the robot met the barrier
    # of eq. (28) heading a hair into it, and stalled there for good): the
    # one turned furthest that way from the way's own bearing
    clear = 2.0 * margin
    bearing = math.atan2(wy, wx)
    best = -math.inf
    heading = bearing
    for i in range(int(p[0])):
        k = HEADER + PER_VERTEX * i
        vx = p[k] - x
        vy = p[k + 1] - y
        angle = math.atan2(vy, vx) + side * math.asin(min(clear / math.hypot(vx, vy), 1.0))
        turn = side * wrap_angle(angle - bearing)
        if turn > best:
            best = turn
            heading = angle
    return along, heading, side


@kernel
def _round_zones_on(
    x: float,
    y: float,
    bearing: float,
    distance: float,
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    held: float,
    skip: int,
) -> tuple[float, float, int]:
    """The bearing the bearing form heads along from (x, y) to a target
    ``distance`` away at ``bearing``, the side it goes round on (1 the left
    of the way, -1 the right, 0 none) and the row it goes round (-1 none):
    that bearing, or where the straight way crosses a keep-out ellipse
    (grown by ``margin``) or polygon (:func:`_polygon_tangent`), along the
    tangent to the first one it crosses but row ``skip``, on the side the
    way passes its centre (the left when head-on), or on the side ``held``
    where it is not 0. Heading into the zone, eq. (28) stopped the robot at
    its edge for good (a target behind the zone: a saddle); along the
    tangent it goes round, and on the edge the tangent is the edge's own
    direction.

    In the ellipse's frame scaled to a unit circle straight lines stay
    straight and tangents tangent: from a point q outside the unit circle
    the tangents run along ``side q_perp - sqrt(|q|^2 - 1) q``, q_perp = q
    turned by +90 degrees."""
    first = 1.0
    heading = bearing
    chosen = 0.0
    rounded = -1
    for i in range(row_kinds.shape[0]):
        if i == skip:
            continue
        p = row_params[i]
        if row_kinds[i] == POLYGON_ROW:
            along, way, side = _polygon_tangent(
                p, margin, x, y, distance * math.cos(bearing), distance * math.sin(bearing), held
            )
            if along < first:
                first = along
                heading = way
                chosen = side
                rounded = i
            continue
        if row_kinds[i] != ELLIPSE_ROW or p[5] > 0.0:
            continue
        a = p[2] + margin
        b = p[3] + margin
        c = math.cos(p[4])
        s = math.sin(p[4])
        qx = (c * (x - p[0]) + s * (y - p[1])) / a
        qy = (-s * (x - p[0]) + c * (y - p[1])) / b
        wx = distance * math.cos(bearing)
        wy = distance * math.sin(bearing)
        dx = (c * wx + s * wy) / a
        dy = (-s * wx + c * wy) / b
        reach = dx * dx + dy * dy
        inwards = -(qx * dx + qy * dy)
        if inwards <= 0.0:
            continue  # the way leads away from the centre
        # the way's point nearest the centre, and whether it is inside
        along = min(inwards / reach, 1.0)
        if along >= first:
            continue
        nearest_x = qx + along * dx
        nearest_y = qy + along * dy
        if nearest_x * nearest_x + nearest_y * nearest_y >= 1.0:
            continue
        first = along
        # the side the way passes the centre on (here -1 the left, 1 the
        # right; the left when head-on), or the side held
        side = -1.0 if dx * qy - dy * qx >= 0.0 else 1.0
        if held != 0.0:
            side = -held
        chosen = -side
        rounded = i
        # on the edge (or within the margin, where eq. (28) holds the robot)
        # the edge's own direction
        root = math.sqrt(max(qx * qx + qy * qy - 1.0, 0.0))
        ux = -side * qy - root * qx
        uy = side * qx - root * qy
        heading = math.atan2(s * a * ux + c * b * uy, c * a * ux - s * b * uy)
    return heading, chosen, rounded


@kernel
def _gone_round(
    x: float,
    y: float,
    bearing: float,
    distance: float,
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    held: float,
    travel: float,
) -> tuple[float, float]:
    """:func:`_round_zones_on`, and where the way round its zone crosses
    another one, round that one too on the same side, and so on while that
    turns no more than a quarter turn off ``travel``, the heading the robot
    drives along (its heading, or its reverse while it backs): (the heading,
    the side)."""
    heading, side, rounded = _round_zones_on(
        x, y, bearing, distance, row_kinds, row_params, margin, held, -1
    )
    for _ in range(row_kinds.shape[0] - 1):
        if rounded < 0:
            break
        further, _, rounded = _round_zones_on(
            x, y, heading, distance, row_kinds, row_params, margin, side, rounded
        )
        # not round a zone the robot would turn back for, more than a quarter
        # turn off its travel: round one 1.5 rad off the straight way, a
        # target ahead became one behind, the robot backed out of the way
        # round and drove on into it by turns (park-381's box and circle)
        if rounded < 0 or abs(wrap_angle(further - travel)) > 0.5 * math.pi:
            break
        heading = further
    return heading, side


@kernel
def _bearing_round_zones(
    x: float,
    y: float,
    bearing: float,
    distance: float,
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    held: float,
    travel: float,
) -> tuple[float, float]:
    """The heading round the zones (:func:`_gone_round`) and its side: the
    side ``held`` from the sample before where it is not 0, else the side
    the way passes the first zone's centre; where the held side's way round
    turns more than a quarter turn off the straight way, the side whose way
    round turns less off ``travel``, the heading the robot drives along.

    Chosen afresh at each sample for the zone crossed first, the way round
    one side of a zone led into a zone next to it, closer than the robot
    passes, whose way round on its other side led back into the first: the
    robot drove forwards and backwards by turns, every sample, until its
    timeout (docs/paper-notes.md, eq. (28), "The side round the zones
    held")."""
    heading, side = _gone_round(
        x, y, bearing, distance, row_kinds, row_params, margin, held, travel
    )
    # Held while it turned on past a quarter turn off the straight way, the
    # way round one box led the robot away from its target, to a stop at the
    # box's edge for good (park-134 of parks_across_zones.py's seed 1, 1.78
    # rad off): past that the side the robot turns less for is taken.
    if held != 0.0 and abs(wrap_angle(heading - bearing)) > 0.5 * math.pi:
        other, other_side = _gone_round(
            x, y, bearing, distance, row_kinds, row_params, margin, -held, travel
        )
        if abs(wrap_angle(other - travel)) < abs(wrap_angle(heading - travel)):
            return other, other_side
    return heading, side


@kernel
def turn_time(angle: float, limits: FloatArray) -> float:
    """[s] The shortest turn through ``angle`` >= 0 from rest to rest at the
    turn-rate limit and its acceleration limit (inf without one: at the rate)."""
    rate = float(limits[1])
    acceleration = float(limits[3])
    if acceleration == math.inf:
        return angle / rate
    if angle >= rate * rate / acceleration:
        return angle / rate + rate / acceleration
    return 2.0 * math.sqrt(angle / acceleration)


@kernel
def _turns_sooner(speed: float, turn: float, limits: FloatArray) -> bool:
    """Whether a robot at ``speed`` (> 0: along its direction of travel)
    turns by ``turn`` sooner, at the turn-rate limits, than it stops and
    regains that speed the other way at its speed acceleration limit."""
    if speed <= 0.0 or limits[2] == math.inf:
        return False
    return bool(turn_time(turn, limits) < 2.0 * speed / limits[2])


@kernel
def _row_held(
    kind: int,
    p: FloatArray,
    margin: float,
    keep: float,
    now: tuple[float, float, float, float],
    next_: tuple[float, float, float, float, float],
    rate: float,
    dt: float,
) -> tuple[float, float, float, float, float, float, float]:
    """A row's barrier value of eq. (28), ``c(k+1) - (1 - gamma) c(k)`` with
    ``keep`` = 1 - gamma, the row shrunk by ``margin``, at the point ``next_``
    (x, y, heading at k+1, v, omega) from ``now`` (x, y, heading, v at k),
    and under an acceleration limit ``rate`` (inf: none) on the line braking
    from v takes where further in: the value, its gradient and the sensitivity
    of its point to (v, omega) beyond x_{k+1}'s (2x2 row by row)."""
    x, y = now[0], now[1]
    px, py = next_[0], next_[1]
    if kind == POLYGON_ROW:  # a keep-out box or polygon: its signed distance
        value, gx, gy = polygon_value(p, margin, px, py)
        if keep > 0.0:
            value -= keep * polygon_value(p, margin, x, y)[0]
    else:
        value, gx, gy = row_value_with_margin(kind, p, margin, px, py)
        if keep > 0.0:
            value -= keep * row_value_with_margin(kind, p, margin, x, y)[0]
    if rate == math.inf:
        return value, gx, gy, 0.0, 0.0, 0.0, 0.0
    held, gx, gy, e00, e01, e10, e11, _ = held_where_braking_ends(
        kind, p, margin, keep, value, gx, gy, now, next_, (0.0, 0.0, 0.0, 0.0), rate, dt
    )
    return held, gx, gy, e00, e01, e10, e11


# Halvings of the way back from eq. (28)'s input to the regulator's
# (_share_kept): the share found to 1/1024 of the way.
SHARE_HALVINGS = 10


@kernel
def _rows_hold(
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    keep: float,
    now: tuple[float, float, float, float],
    v: float,
    omega: float,
    rate: float,
    dt: float,
) -> bool:
    """Whether every row's barrier value (:func:`_row_held`) is at most 0
    with the input (v, omega) from ``now`` (x, y, heading, v_{k-1})."""
    px, py, pth = step(now[0], now[1], now[2], v, omega, dt)
    for i in range(row_kinds.shape[0]):
        held = _row_held(
            row_kinds[i], row_params[i], margin, keep, now, (px, py, pth, v, omega), rate, dt
        )[0]
        if not held <= 0.0:
            return False
    return True


@kernel
def _share_kept(
    row_kinds: IntArray,
    row_params: FloatArray,
    margin: float,
    keep: float,
    now: tuple[float, float, float, float],
    inputs: tuple[float, float, float, float],
    rate: float,
    dt: float,
) -> float:
    """The largest share (to 2^-SHARE_HALVINGS) of the way from eq. (28)'s
    input (inputs[0], inputs[1]) to the regulator's (inputs[2], inputs[3])
    at which every row still holds (:func:`_rows_hold`); 0 where eq. (28)'s
    input itself does not keep them (its first order fell short), or where
    none further on found does. Between two inputs within the limits every
    input on the way is within them (the limits are a box)."""
    v2, omega2, v1, omega1 = inputs
    if not _rows_hold(row_kinds, row_params, margin, keep, now, v2, omega2, rate, dt):
        return 0.0
    low = 0.0
    high = 1.0
    for _ in range(SHARE_HALVINGS):
        middle = 0.5 * (low + high)
        v = v2 + middle * (v1 - v2)
        omega = omega2 + middle * (omega1 - omega2)
        if _rows_hold(row_kinds, row_params, margin, keep, now, v, omega, rate, dt):
            low = middle
        else:
            high = middle
    return low


@inlined
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
    """Case 1: the gain-scheduled regulator plus, where the prediction violates a
    constraint row, the corrective action of eq. (28); then the limits.

    ``target`` is the pose x_ss to park at; ``row_kinds``/``row_params`` the
    phase's inequality constraints (possibly none); ``memory`` the phase's
    controller memory (MEMORY_SIZE fields: ALIGNING, CORRECTED, ...).
    """
    dt = robot.dt
    q, r, form = controller.q, controller.r, controller.form
    v_prev = u_prev[0]
    omega_prev = u_prev[1]
    gain = work.gain
    # Read once: after the writes to the memory and the gain below the compiler
    # would read the heading again and recompute its sine and cosine (a library
    # call each) for the gain, the prediction and its input Jacobian.
    x, y, theta = estimate[0], estimate[1], estimate[2]
    c = math.cos(theta)
    s = math.sin(theta)
    if form == INCREMENT:
        # Literal eqs. (14), (19), (29-a): T_{k-1} at (x_{k-1|k-1}, u_{k-1}),
        # applied to the state increment x_{k|k} - x_{k-1|k-1}.
        scheduled_gain(estimate_prev[2], v_prev, omega_prev, dt, q, r, memory, gain)
        ex = x - estimate_prev[0]
        ey = y - estimate_prev[1]
        eth = theta - estimate_prev[2]
        v1 = v_prev - (gain[0, 0] * ex + gain[0, 1] * ey + gain[0, 2] * eth)
        omega1 = omega_prev - (gain[1, 0] * ex + gain[1, 1] * ey + gain[1, 2] * eth)
    else:
        speed = v_prev  # where eq. (1) is linearised
        ex = x - target[0]
        ey = y - target[1]
        eth = wrap_angle(theta - target[2])
        if form == BEARING:
            distance = hypot(ex, ey)
            if distance < controller.align_radius:
                memory[ALIGNING] = 1.0
            elif distance > 2.0 * controller.align_radius:
                memory[ALIGNING] = 0.0
            if memory[ALIGNING] == 0.0:
                # Far: the heading reference is the bearing to the target (or its
                # reverse), so the lateral error the robot cannot reach at rest
                # is turned into a heading error it can.
                bearing = math.atan2(-ey, -ex)
                if _keeps_out_of_a_zone(row_kinds, row_params):
                    way, side = _bearing_round_zones(
                        x, y, bearing, distance, row_kinds, row_params, robot.constraint_margin,
                        memory[ROUND_SIDE], theta + math.pi * memory[REVERSING],
                    )  # fmt: skip
                    memory[ROUND_SIDE] = side
                    if way != bearing:
                        # round the zone: the error as far, along the way round
                        bearing = way
                        ex = -distance * math.cos(way)
                        ey = -distance * math.sin(way)
                eth = wrap_angle(theta - bearing)
                if controller.reverse:
                    # Backwards when the target is behind, with hysteresis: a
                    # target abeam (|eth| = pi/2) chose forwards and backwards
                    # by turns, every sample, for good (a limit cycle).
                    # Under acceleration limits a robot driving on keeps its
                    # direction where turning round is quicker than braking and
                    # regaining its speed the other way: it braked from 1.12
                    # m/s, 0.6 m further away, and made no progress for 2 s
                    # (gen-085-line).
                    if memory[REVERSING] == 0.0:
                        if abs(eth) > 0.5 * math.pi + REVERSE_HYSTERESIS and not _turns_sooner(
                            v_prev, abs(eth), robot.limits
                        ):
                            memory[REVERSING] = 1.0
                    elif abs(eth) < 0.5 * math.pi - REVERSE_HYSTERESIS and not _turns_sooner(
                        -v_prev, math.pi - abs(eth), robot.limits
                    ):
                        memory[REVERSING] = 0.0
                    if memory[REVERSING] != 0.0:
                        eth = wrap_angle(eth - math.pi)
                # Linearised at a speed of the direction of travel chosen: at
                # the other's, the lateral terms of T turn against the heading
                # error, and a target abeam (91-101 degrees) was approached
                # at a crawl the wrong way round, never turned to.
                speed = min(v_prev, 0.0) if memory[REVERSING] != 0.0 else max(v_prev, 0.0)
            else:
                memory[ROUND_SIDE] = 0.0  # the side chosen afresh once it leaves
                # Aligning at the target: keep the reachable (longitudinal)
                # part of the position error, turn to the target heading.
                along = ex * c + ey * s
                ex = along * c
                ey = along * s
        scheduled_gain_facing(c, s, speed, omega_prev, dt, q, r, memory, gain)
        # eq. (19) with dx the deviation from the target.
        v1 = -(gain[0, 0] * ex + gain[0, 1] * ey + gain[0, 2] * eth)
        omega1 = -(gain[1, 0] * ex + gain[1, 1] * ey + gain[1, 2] * eth)
        if form == BEARING and memory[ALIGNING] == 0.0:
            # No speed against the direction of travel chosen: with the target
            # more than abeam (within the hysteresis) the error along the
            # heading is behind, and eq. (19) backed while the robot turned,
            # then drove on: +0.57, -0.70, +0.51 m/s in three samples
            # (gen-170-ellipse's park). The robot turns first.
            v1 = min(v1, 0.0) if memory[REVERSING] != 0.0 else max(v1, 0.0)
        # The deceleration planned: eq. (19) knows no acceleration limit and
        # asks for speed until the target is reached, too late to stop there.
        # No faster than the limits can stop within the error left (without
        # a limit any speed stops: the error's length is not even taken).
        if robot.limits[2] != math.inf:
            reach = stopping_speed(hypot(ex, ey), robot.limits[2], dt)
            v1 = min(max(v1, -reach), reach)
        if robot.limits[3] != math.inf:
            turn = stopping_speed(abs(eth), robot.limits[3], dt)
            omega1 = min(max(omega1, -turn), turn)
    # The turn rate moves from the input before by at most half its limit a
    # sample: eq. (19)'s heading reference jumps where the phase takes over
    # from a track phase and where aligning begins (the bearing to the
    # target's own heading), and the law answered with its whole range in
    # one sample (docs/paper-notes.md, eq. (19), "The regulator's turn from
    # the input before").
    slew = TURN_SLEW * robot.limits[1]
    omega1 = min(max(omega1, omega_prev - slew), omega_prev + slew)
    v1, omega1 = saturate(v1, omega1, v_prev, omega_prev, robot.limits, dt)
    u_out[0] = v1
    u_out[1] = omega1
    memory[CORRECTED] = 0.0
    if row_kinds.shape[0] == 0:
        return
    # eq. (28): predict with the regulator's input, find the rows it breaks:
    # each row shrunk by the estimate's margin, and held as a discrete-time
    # barrier, c(k+1) <= (1 - gamma) c(k): a row is approached, and left when
    # broken, by a fraction gamma of its value per sample, not in one jump.
    px, py, pth = step(x, y, theta, v1, omega1, dt)
    # Under an acceleration limit the robot stops only beyond x_{k+1}: the rows
    # are held at x_{k+1} and also on the line braking from v1 takes, the
    # braking distance v^2 / (2 a) on (constrained_tracking.held_where_braking_ends).
    rate = robot.limits[2]
    d, eta, b = work.d, work.eta, work.b
    margin = robot.constraint_margin
    keep = 1.0 - controller.barrier_rate
    # A typed zero, not the literal 0: numba compiles a kernel once per literal it gets.
    count = int(np.int64(0))
    # The braking line's point's sensitivity to the input beyond x_{k+1}'s,
    # where the most violated row is held there (one B for the rows: that row's).
    extra = (0.0, 0.0, 0.0, 0.0)
    worst = 0.0
    for i in range(row_kinds.shape[0]):
        value, gx, gy, e00, e01, e10, e11 = _row_held(
            row_kinds[i], row_params[i], margin, keep, (x, y, theta, v_prev),
            (px, py, pth, v1, omega1), rate, dt,
        )  # fmt: skip
        if rate != math.inf and value > worst:
            worst = value
            extra = (e00, e01, e10, e11)
        if value <= 0.0:
            continue
        slot, count = kept_row_slot(value, count, eta)
        if slot < 0:
            continue
        d[slot, 0] = gx
        d[slot, 1] = gy
        d[slot, 2] = 0.0
        eta[slot] = -value  # E - m(x): saturate to the barrier's bound
    if count == 0:
        return
    input_jacobian_into(theta, v1, omega1, dt, b)
    if rate != math.inf:
        b[0, 0] += extra[0]
        b[0, 1] += extra[1]
        b[1, 0] += extra[2]
        b[1, 1] += extra[3]
    dv, dw = corrective_input(d, eta, count, b, controller.w, controller.m, robot.limits)
    memory[CORRECTED] = 1.0
    v2, omega2 = saturate(v1 + dv, omega1 + dw, v_prev, omega_prev, robot.limits, dt)
    # Eq. (28) is first order, at the point the regulator's input reaches: by
    # a box's or a polygon's corner (a row that bends as the distance to one
    # point) it stopped the robot where the rows let it on, for good, or
    # turned it back (docs/paper-notes.md, eq. (28), "Back towards the
    # regulator's input"): move back towards that input as far as the rows
    # still hold.
    share = _share_kept(
        row_kinds, row_params, margin, keep, (x, y, theta, v_prev),
        (v2, omega2, v1, omega1), rate, dt,
    )  # fmt: skip
    if share > 0.0:
        v2 += share * (v1 - v2)
        omega2 += share * (omega1 - omega2)
    u_out[0] = v2
    u_out[1] = omega2


@kernel
def distance_from_rest(time: float, limits: FloatArray) -> float:
    """[m] How far a robot from rest drives in ``time`` >= 0 at its speed
    acceleration limit up to its speed limit."""
    top = float(limits[0])
    acceleration = float(limits[2])
    if acceleration == math.inf:
        return top * time
    rising = top / acceleration
    if time <= rising:
        return 0.5 * acceleration * time * time
    return top * (time - 0.5 * rising)


# How many of the law's time constants of the path's travel a robot turned
# round may end a track phase behind its reference before the phase is
# driven backwards instead: the law leaves exp(-3) (5 %) of an error after
# three (drives_backwards).
JOINING_TIME_CONSTANTS = 3.0


@kernel
def drives_backwards(
    heading: float,
    tangent_x: float,
    tangent_y: float,
    speed: float,
    duration: float,
    time_constant: float,
    limits: FloatArray,
) -> bool:
    """Whether a track phase is driven backwards: its path starts more than
    pi/2 behind the robot's heading and, turned round first (turn_time,
    standing) and then driving after its reference from rest at the limits,
    the robot would still be more than JOINING_TIME_CONSTANTS of the law's
    ``time_constant`` of the path's travel behind it when the phase's
    ``duration`` ends (inf: no known end, never). Backwards its direction of
    travel is less than pi/2 off the path (docs/paper-notes.md, "Eq. (27)
    driving backwards")."""
    if duration == math.inf:
        return False
    off = abs(wrap_angle(math.atan2(tangent_y, tangent_x) - heading))
    if not off > 0.5 * math.pi:  # NaN too: a resting path
        return False
    driving = max(duration - turn_time(off, limits), 0.0)
    behind = speed * duration - distance_from_rest(driving, limits)
    return behind > JOINING_TIME_CONSTANTS * time_constant * speed


@inlined
def mirrored(estimate: FloatArray, u_prev: FloatArray, memory: FloatArray) -> None:
    """The mirrored robot eq. (27) tracks with while driving backwards, into
    ``memory[MIRRORED:]``: heading theta + pi and speed -v, the same motion
    by eq. (1), whose output ``look_ahead`` ahead of its axle is the point
    that far behind the robot's."""
    memory[MIRRORED] = estimate[0]
    memory[MIRRORED + 1] = estimate[1]
    memory[MIRRORED + 2] = wrap_angle(estimate[2] + math.pi)
    memory[MIRRORED + 3] = -u_prev[0]
    memory[MIRRORED + 4] = u_prev[1]


# --- the controller as the loop runs it ----------------------------------------

# Regulation forms by name (controller.regulation.form).
FORMS = {"bearing": BEARING, "deviation": DEVIATION, "increment": INCREMENT}


@inlined
def hold_across_at_a_stop(
    aim_now: FloatArray,
    aim: FloatArray,
    path_step: float,
    estimate: FloatArray,
    tuning: PaperTuning,
    robot: Plant,
    memory: FloatArray,
) -> None:
    """Where a route's reference stops at a corner, turns in place and moves
    off again behind a detour's offset, aim the output where it stands across
    the path, in the path's frame (``aim_now``, ``aim``: the aims at t_k and
    t_{k+1}, moved in place; ``path_step``: the path's own step between them,
    before any zone offset).

    The law closes an error across the path by steering while the path moves;
    at a stop only by turning the output round the axle, at most ``l omega
    dt`` a sample. Behind a detour's offset, 0.087 m across the path of a
    corner that turns 0.04 rad, the robot turned at its limit towards the
    offset while the reference stood, 0.28 rad off the path, and swung to
    the other limit as it moved off (a kick of 13.9 rad/s, then 0.15 m off the
    path, gen-072-polyline). Held, the offset is closed by steering once the
    path moves at its speed again: on the sample the path slows to under half
    its step before, while it turns in place (its point standing, its own
    tangent turning with the output held on it) and on the sample it moves
    off. The robot's own step along its heading is kept across at t_{k+1}.
    Only in a phase with zones (called from there: a stop with no detour's
    offset closes its error as before, as at a route's first point, where the
    route joins from the robot's estimate), within ``error_reach`` (a robot
    still joining its path closes its error as before) and where turning the
    offset closed at the law's pace asks more than LINEAR_SHARE of the
    turn-rate limit (a robot on its path runs as before, to the bit)
    (docs/paper-notes.md, "Eq. (27) at a corner's stop: the offset across
    held")."""
    turning = path_step == 0.0 and (aim_now[2] != aim[2] or aim_now[3] != aim[3])
    arriving = path_step < 0.5 * memory[PATH_STEP]
    leaving = path_step > 0.0 and memory[TURNED_IN_PLACE] == 1.0
    memory[PATH_STEP] = path_step
    memory[TURNED_IN_PLACE] = 0.0
    look_ahead = tuning.look_ahead
    if not (turning or arriving or leaving) or look_ahead == 0.0:
        return  # most samples; and the axle law has no output to turn round the axle
    c = math.cos(estimate[2])  # only past the test above: it runs every sample
    s = math.sin(estimate[2])
    # A path resting since its phase began has the robot's heading there for
    # its tangent (kernels.loop.path_point); a tangent changing to or from it
    # is no turn.
    if turning and ((aim_now[2] == c and aim_now[3] == s) or (aim[2] == c and aim[3] == s)):
        turning = False
        if not (arriving or leaving):
            return
    memory[TURNED_IN_PLACE] = 1.0 if turning else 0.0
    out_x = estimate[0] + look_ahead * c - aim_now[0]
    out_y = estimate[1] + look_ahead * s - aim_now[1]
    if hypot(out_x - look_ahead * aim_now[2], out_y - look_ahead * aim_now[3]) > tuning.error_reach:
        return
    across = aim_now[2] * out_y - aim_now[3] * out_x
    turn_rate = (1.0 - tuning.error_decay) * abs(across) / (look_ahead * robot.dt)
    if turn_rate <= LINEAR_SHARE * robot.limits[1]:
        return
    aim_now[0] -= across * aim_now[3]
    aim_now[1] += across * aim_now[2]
    across += path_step * (aim_now[2] * s - aim_now[3] * c)
    aim[0] -= across * aim[3]
    aim[1] += across * aim[2]


@kernel
def joined_share(gap: float, reach: float) -> float:
    """How far the robot has joined its path, ``gap`` from its path's point:
    wholly within ``reach`` of it, not at all beyond twice it."""
    share: float = min(max(2.0 - gap / reach, 0.0), 1.0)
    return share


@kernel
def anticipated(aim_now: FloatArray, aim: FloatArray, share: float) -> None:
    """The path at t_k and t_{k+1} as previewed (aim_now[4:8], aim[4:8]; the
    runner's previewed): its turns begun early at the pace the turn-rate
    acceleration limit follows, ``share`` of the way (joined_share): not
    while joining the path (a robot 0.5 m behind its reference on a coverage
    lane's end arc, turning to its early point, cut inside the arc,
    gen-012-coverage; docs/paper-notes.md, eq. (27), "The path's turn
    previewed")."""
    for point in (aim_now, aim):
        for i in range(4):
            point[i] += share * (point[4 + i] - point[i])
        norm = hypot(point[2], point[3])
        if norm > 0.0:
            point[2] /= norm
            point[3] /= norm


def rows_ahead(look_ahead: float, dt: float, speed_limit: float) -> float:
    """[m] How far ahead of the axle a track phase's zones are held
    (constrained_tracking.keep_constraints): at the tracking output, but no
    further ahead than the default look-ahead (``max(0.05, limits.v * dt)``,
    where the point's one-sample sensitivity is well conditioned, look_ahead).
    A row held ``l`` ahead is shrunk by ``l``, and with the robot heading
    along a zone's edge keeps it up to ``2 l`` further off than the row asks:
    at a look-ahead of 0.3 m an aisle 1.17 m wide beside a box, where a body
    of 0.3 m needed 0.70 m, had no place for the output, and the robot stood
    at the box's corner reversing until its timeout (docs/paper-notes.md,
    eq. (28), "The rows held no further ahead than the default look-ahead")."""
    return min(look_ahead, max(MIN_LOOK_AHEAD, speed_limit * dt))


@inlined
def next_input(
    tuning: PaperTuning,
    phase: EnteredPhase,
    aim_now: FloatArray,
    aim: FloatArray,
    estimate: FloatArray,
    estimate_prev: FloatArray,
    u_prev: FloatArray,
    plant: Plant,
    memory: FloatArray,
    scratch: Scratch,
    u: FloatArray,
) -> None:
    """u_k from x_{k|k}: Case 2 along a path, the zones of the phase first
    (eq. (28) with priority); Case 1 to a pose."""
    kinds = phase.constraint_kinds
    params = phase.constraint_params
    if phase.tracking:
        path_turn = 0.0
        joined = 0.0
        if kinds.shape[0] and tuning.turn_acceleration != math.inf:
            # Within error_reach of its path's point along the path (behind
            # it or ahead), twice that the edge: joining its path, the robot
            # meets its zones on their ramps, not on the climbs a turn-rate
            # acceleration limit asks for (constrained_tracking.aim_round_zones),
            # as it tracks its path's turns previewed only once on it (anticipated).
            along = aim_now[2] * (aim_now[0] - estimate[0]) + aim_now[3] * (
                aim_now[1] - estimate[1]
            )
            joined = joined_share(abs(along), tuning.error_reach)
        if tuning.preview > 0.0:
            # the path as previewed followed within error_reach of its point
            distance = hypot(aim_now[0] - estimate[0], aim_now[1] - estimate[1])
            share = joined_share(distance, tuning.error_reach)
            anticipated(aim_now, aim, share)
            if share == 1.0:  # the path as previewed wholly: the robot is on it
                path_turn = path_turn_rate(aim_now, aim, plant.dt)
        path_x = aim_now[0]
        path_y = aim_now[1]
        if kinds.shape[0]:
            margin = plant.constraint_margin
            gap = aim_gap(tuning.look_ahead, plant.limits[2], margin - plant.body)
            # The way round a keep-out zone where the path will be a time
            # constant on (aim_lead): the law closes the aim's move as an
            # error, that late, and where a path met its zone at a corner the
            # filter took the output off its late aim, by turns (turn-rate
            # jitter 0.040 rad/s where 0.033 is allowed, gen-130-polyline).
            path_step = hypot(aim[0] - path_x, aim[1] - path_y)
            lead = tuning.aim_lead * path_step / plant.dt
            aim_round_zones(
                aim_now, kinds, params, phase.ways_round, tuning.look_ahead, margin, gap, lead,
                tuning.turn_acceleration, joined,
            )  # fmt: skip
            # Aimed round a zone the path crosses: the path's own motion fed
            # forward, the aim's move closed as an error, at the law's pace
            # (its kinks at the zone's edge are no jumps of the input). The
            # offset moves by at most OFFSET_SLOPE of the path's step: on a
            # curve or at a corner the path's tangent swings the ramp's wedge
            # across a zone, and the offset leapt to a side and back within
            # two samples (constrained_tracking.ramped_offset).
            before_x = memory[AIM_OFFSET]
            before_y = memory[AIM_OFFSET + 1]
            if memory[DIRECTION] == 0.0:
                # The phase's first sample: the offset its zones ask for, not
                # ramped up from none. A lap of a repeat entered mid-detour
                # had its aim pulled back towards the zone it was going
                # round: the robot crept up to it, stopped and reversed, its
                # turn rate jumping 2.39 rad/s where 2 was allowed.
                before_x = aim_now[0] - path_x
                before_y = aim_now[1] - path_y
            offset_x, offset_y = ramped_offset(
                aim_now[0] - path_x, aim_now[1] - path_y, before_x, before_y, path_step
            )
            memory[AIM_OFFSET] = offset_x
            memory[AIM_OFFSET + 1] = offset_y
            aim_now[0] = path_x + offset_x
            aim_now[1] = path_y + offset_y
            aim[0] += offset_x
            aim[1] += offset_y
            if plant.limits[2] != math.inf:
                # Under a speed acceleration limit the law's pace is slower
                # than the setting's time constant (attainable_time_constant,
                # the turn's pace), and closed as an error the aim's move
                # lagged: 0.15 m inside a ramp at 0.8 m/s, where the robot
                # met the corner of its box and stopped (1.29 m behind).
                # The move is fed forward with the path's, its step of this
                # sample taken again for the next.
                aim[0] += offset_x - before_x
                aim[1] += offset_y - before_y
            hold_across_at_a_stop(aim_now, aim, path_step, estimate, tuning, plant, memory)
            # A robot stopped at a zone's edge with its aim beyond the zone
            # goes round from where it is, until the way to its aim is clear.
            held = memory[HELD_AT_ZONE] != 0.0
            if held or abs(u_prev[0]) * plant.dt <= STOPPED_SHARE * path_step:
                held = aimed_from_its_place(
                    aim_now, aim, path_x, path_y, estimate, kinds, params, phase.ways_round,
                    tuning.look_ahead, margin, gap, lead,
                )  # fmt: skip
            memory[HELD_AT_ZONE] = 1.0 if held else 0.0
        if memory[DIRECTION] == 0.0:
            duration = math.inf
            if phase.elapsed_samples >= 0 and kinds.shape[0] == 0:
                duration = phase.elapsed_samples * plant.dt
            speed = hypot(aim[0] - aim_now[0], aim[1] - aim_now[1]) / plant.dt
            decay = tuning.error_decay
            time_constant = -plant.dt / math.log(decay) if 0.0 < decay < 1.0 else 0.0
            backwards = drives_backwards(
                estimate[2], aim_now[2], aim_now[3], speed, duration, time_constant,
                plant.limits,
            )  # fmt: skip
            memory[DIRECTION] = -1.0 if backwards else 1.0
        # Backwards: the forward law for the mirrored robot, its speed
        # negated back (one call of track_input, compiled inline once).
        pose = estimate
        before = u_prev
        backwards = memory[DIRECTION] < 0.0
        if backwards:
            mirrored(estimate, u_prev, memory)
            pose = memory[MIRRORED : MIRRORED + 3]
            before = memory[MIRRORED + 3 : MIRRORED + 5]
        track_input(pose, before, aim_now, aim, tuning, plant, scratch, u, path_turn)
        if backwards:
            u[0] = -u[0]
        # The filter after the tracking law: zones win over tracking
        # (wmr_mission.controllers.constrained_tracking).
        if kinds.shape[0]:
            keep_constraints(
                estimate, u_prev, kinds, params, tuning.look_ahead, plant, scratch, u,
                tuning.barrier_rate, tuning.rows_ahead,
            )  # fmt: skip
    else:
        regulate_input(
            estimate, estimate_prev, u_prev, phase.target, kinds, params, tuning, plant, memory,
            scratch, u,
        )  # fmt: skip


def look_ahead(settings: PaperController, dt: float, speed_limit: float) -> float:
    """The tracked point's distance ahead of the axle [m]; 0 for the literal axle law.

    Unset, it is tied to the limits: ``max(0.05, limits.v * dt)``. The
    one-sample input sensitivity of the point has determinant
    ``dt^2 (l + v dt / 2)``, zero at ``v = -2 l / dt``; with ``l >= limits.v * dt``
    it stays within a factor 3 of ``l dt^2`` at every speed the limits allow
    (docs/paper-notes.md, eq. (27))."""
    tracking = settings.tracking
    if tracking.output == "axle":
        return 0.0
    if tracking.look_ahead is not None:
        return float(tracking.look_ahead)
    return max(MIN_LOOK_AHEAD, float(speed_limit) * float(dt))


def error_decay(settings: PaperController, dt: float, limits: FloatArray | None = None) -> float:
    """Fraction of the tracked output's error left after one sample: 0 for the
    one-sample laws (``time_constant: 0``, and the literal axle law)."""
    tracking = settings.tracking
    if tracking.output == "axle" or tracking.time_constant == 0:
        return 0.0
    tau = float(tracking.time_constant)
    if limits is not None:
        tau = attainable_time_constant(tau, limits)
    return math.exp(-float(dt) / tau)


def attainable_time_constant(tau: float, limits: FloatArray) -> float:
    """[s] The tracking error's time constant the acceleration limits can follow.

    Taking an input ``u`` out as ``exp(-t / tau)`` asks ``u / tau`` of its
    acceleration: under a limit ``a`` the design holds for inputs up to
    ``a tau`` and beyond that the input lags its law, overshoots and the robot
    weaves about its path at the limits for good. ``tau`` is lengthened until
    ATTAINABLE_SHARE of each input's range is followed as designed
    (docs/paper-notes.md, eq. (27) under acceleration limits); without
    acceleration limits it is the setting's."""
    speed_time = float(limits[0]) / float(limits[2])
    turn_time = float(limits[1]) / float(limits[3])
    return max(tau, ATTAINABLE_SHARE * speed_time, ATTAINABLE_SHARE * turn_time)


def error_reach(
    settings: PaperController, dt: float, speed_limit: float, limits: FloatArray | None = None
) -> float:
    """[m] The largest output error closed at ``error_decay``'s pace.

    The look-ahead point moves sideways by ``l omega dt`` per sample, so
    closing ``1 - decay`` of a sideways error ``e`` turns the heading by
    ``(1 - decay) e / l``: beyond about one radian per sample's worth the
    heading overshoots and the turn rate swings from limit to limit. Errors
    larger than ``HEADING_STEP l / (1 - decay)`` are closed as that one is,
    turning at most HEADING_STEP of the bearing error per sample; inf for the
    one-sample laws (decay 0) and the axle law (docs/paper-notes.md, eq. (27))."""
    decay = error_decay(settings, dt, limits)
    distance = look_ahead(settings, dt, speed_limit)
    if decay == 0.0 or decay == 1.0 or distance == 0.0:  # 1.0: dt / tau lost in rounding
        return math.inf
    return HEADING_STEP * distance / (1.0 - decay)


def turn_acceleration(settings: PaperController, dt: float, limits: FloatArray) -> float:
    """[rad/s^2] The turn-rate acceleration the error closed per sample
    follows: TURNABLE_SHARE of the limit; inf without one, and for the
    one-sample laws and the axle law (track_input)."""
    if error_decay(settings, dt, limits) == 0.0 or not math.isfinite(float(limits[3])):
        return math.inf
    return TURNABLE_SHARE * float(limits[3])


def aim_lead(settings: PaperController, dt: float, limits: FloatArray) -> float:
    """[s] How far ahead along the path the aim's offset round the zones is
    taken: the setting's time constant, the pace the law closes the aim's
    move at, so that the robot, that much behind it, meets the offset where
    the zone needs it; 0 for the one-sample laws. Under a speed acceleration
    limit too, as the filter holds a zone's rows on the whole line the robot
    brakes along: led past the zone's end, a robot far behind its reference
    cut into it while the rows were held at the braking line's end alone.
    Not under a turn-rate acceleration limit alone: no braking line is held
    there, and the lead gained nothing measured (docs/paper-notes.md,
    eq. (28), "The aim's offset a time constant ahead")."""
    if error_decay(settings, dt) == 0.0:
        return 0.0
    if not math.isfinite(float(limits[2])) and math.isfinite(float(limits[3])):
        return 0.0
    return float(settings.tracking.time_constant)


def preview_time(settings: PaperController, dt: float, limits: FloatArray) -> float:
    """[s] How far ahead the law previews the path's turns (preview_rows):
    under a turn-rate acceleration limit, and not for the one-sample laws
    and the axle law (anticipated)."""
    if turn_acceleration(settings, dt, limits) == math.inf:
        return 0.0
    return preview_rows(limits, dt) * float(dt)


def tuning_of(settings: PaperController, plant: Plant) -> PaperTuning:
    regulation = settings.regulation
    ahead = look_ahead(settings, plant.dt, plant.limits[0])
    return PaperTuning(
        look_ahead=ahead,
        error_decay=error_decay(settings, plant.dt, plant.limits),
        q=np.array(settings.Q, dtype=np.float64),
        r=np.array(settings.R, dtype=np.float64),
        w=np.array(settings.W, dtype=np.float64),
        m=np.array(settings.M, dtype=np.float64),
        form=FORMS[regulation.form],
        align_radius=regulation.align_radius,
        reverse=regulation.reverse,
        barrier_rate=min(1.0, float(plant.dt) / BARRIER_TIME),
        error_reach=error_reach(settings, plant.dt, plant.limits[0], plant.limits),
        turn_acceleration=turn_acceleration(settings, plant.dt, plant.limits),
        aim_lead=aim_lead(settings, plant.dt, plant.limits),
        preview=preview_time(settings, plant.dt, plant.limits),
        rows_ahead=rows_ahead(ahead, plant.dt, plant.limits[0]),
    )


# Registered by wmr_mission.controllers.
CONTROLLER = ControllerType(
    settings=PaperController,
    tuning_record=PaperTuning,
    tuning_of=tuning_of,
    memory_size=MEMORY_SIZE,
    new_scratch=lambda tuning: scratch(),
    step=next_input,
)
