"""Tracking inside keep-in and outside keep-out zones: eq. (28) with priority over eq. (27).

The paper treats its two kinds of constraint in separate cases: a track phase
(Case 2) holds the equality "tracking output = reference" by eq. (27), and a
regulate phase (Case 1) holds inequality rows by eq. (28). A path drawn
through a keep-out zone needs both at once, and with two inputs both cannot
always hold: the zone must win. So at a track phase with constraints the
tracking input ``u_track`` of eq. (27) is filtered, per sample:

* predict ``x_{k+1}`` with ``u_track``; evaluate every row of the phase's
  regions at the predicted tracking output (the look-ahead point, which
  reaches a zone first; no further ahead than the default look-ahead,
  paper.rows_ahead), each row's allowed side shrunk by that distance, so
  that the axle centre behind it keeps the row itself;
* none violated: ``u = u_track``, tracking untouched;
* otherwise ``u = u_track + du``, where ``du`` puts the (at most two) most
  violated rows on their bounds, to first order (eq. (28): ``A du = eta``,
  ``A`` the rows' ``D B``, ``eta = -c``), and among those changes is the one
  that moves the tracking output least from where eq. (27) sends it:
  ``du = H^-1 A^T (A H^-1 A^T)^-1 eta`` with ``H = (D_t B)^T (D_t B)``, ``D_t``
  the tracking output's Jacobian of eq. (26). That is eq. (28) with the
  tracking output's motion as its norm in place of eq. (22)'s input norm: the
  rows have priority and tracking keeps everything they leave free. With one
  row active on the tracking output, its motion loses exactly the component
  into the zone and keeps the one along the zone's edge, so the robot slides
  round a keep-out zone instead of stopping at it.

Then the actuator limits. docs/paper-notes.md, "Tracking with constraints",
records this departure from the paper and the evidence for the norm.
"""

from __future__ import annotations

import math

import numpy as np

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.kernels.convex import HEADER, PER_VERTEX
from wmr_mission.kernels.corrective import (
    ELLIPSE_ROW,
    POLYGON_ROW,
    REGULARISATION,
    kept_row_slot,
    polygon_value,
    row_value_with_margin,
)
from wmr_mission.kernels.jit import inlined, kernel
from wmr_mission.kernels.model import (
    braking_distance,
    hypot,
    input_jacobian_into,
    saturate,
    step,
)
from wmr_mission.kernels.records import Plant, Scratch

__all__ = [
    "AIM_GAP",
    "aim_gap",
    "aim_round_zones",
    "aimed_from_its_place",
    "constrained_change",
    "held_on_braking_arc",
    "keep_constraints",
    "kept_out",
    "nearest_chords",
    "ramped_offset",
    "row_value_with_margin",
    "way_at",
    "ways_round",
    "zone_between",
]


@kernel
def constrained_change(
    a: FloatArray, eta: FloatArray, count: int, h: FloatArray
) -> tuple[float, float]:
    """``du = H^-1 A^T (A H^-1 A^T)^-1 eta`` for ``count`` (1 or 2) rows of ``a``
    (rows x 2): the change of the input, smallest in the norm ``du^T H du``, that
    meets ``A du = eta``. ``H`` (2x2) is symmetric positive definite. A nearly
    singular ``A H^-1 A^T`` is regularised as in ``corrective.corrective_input``."""
    det = h[0, 0] * h[1, 1] - h[0, 1] * h[1, 0]
    i00 = h[1, 1] / det
    i01 = -h[0, 1] / det
    i11 = h[0, 0] / det
    # columns of H^-1 A^T
    p00 = i00 * a[0, 0] + i01 * a[0, 1]
    p10 = i01 * a[0, 0] + i11 * a[0, 1]
    s00 = a[0, 0] * p00 + a[0, 1] * p10
    if count == 1:
        if s00 <= 1e-300:
            return 0.0, 0.0
        lam = eta[0] / (s00 + REGULARISATION * s00)
        return p00 * lam, p10 * lam
    p01 = i00 * a[1, 0] + i01 * a[1, 1]
    p11 = i01 * a[1, 0] + i11 * a[1, 1]
    s01 = a[0, 0] * p01 + a[0, 1] * p11
    s11 = a[1, 0] * p01 + a[1, 1] * p11
    if s00 + s11 <= 1e-300:
        return 0.0, 0.0
    mu = REGULARISATION * (s00 + s11)
    s00 += mu
    s11 += mu
    sdet = s00 * s11 - s01 * s01
    lam0 = (s11 * eta[0] - s01 * eta[1]) / sdet
    lam1 = (s00 * eta[1] - s01 * eta[0]) / sdet
    return p00 * lam0 + p01 * lam1, p10 * lam0 + p11 * lam1


# Points of the braking line a polygon row is held at, evenly spaced to its
# end. The signed distance changes by at most the spacing between two, so a
# polygon is missed by at most half of it: at 3 m/s and 1.5 m/s^2 0.19 m
# apart, at 5.1 m/s and 1 m/s^2 0.81 m apart. The other rows are quadratic
# along the line and are held at its largest exactly.
BRAKING_STEPS = 16


@kernel
def _curvature_along(kind: int, p: FloatArray, margin: float, c: float, s: float) -> float:
    """The second derivative of a row's value along the unit (c, s): 0 for a
    half-plane, negative for a keep-out ellipse, positive for a keep-in one."""
    if kind != ELLIPSE_ROW:
        return 0.0
    sign = p[5]
    a = max(p[2] - sign * margin, 1e-9)
    b = max(p[3] - sign * margin, 1e-9)
    du = math.cos(p[4]) * c + math.sin(p[4]) * s
    dw = -math.sin(p[4]) * c + math.cos(p[4]) * s
    return float(2.0 * sign * (du * du / (a * a) + dw * dw / (b * b)))


@kernel
def _largest_of_quadratic_row(
    kind: int, p: FloatArray, margin: float, x: float, y: float, c: float, s: float, ahead: float
) -> tuple[float, float, float, float]:
    """A half-plane or ellipse row's largest value on the line from (x, y)
    ``ahead`` on along (c, s), its gradient and the distance on where it is:
    the row is quadratic along the line, so at the vertex of a keep-out
    ellipse's value where that lies inside the line, else at an end."""
    start, gx, gy = row_value_with_margin(kind, p, margin, x, y)
    if ahead == 0.0:
        return start, gx, gy, 0.0
    end, ex, ey = row_value_with_margin(kind, p, margin, x + ahead * c, y + ahead * s)
    curvature = _curvature_along(kind, p, margin, c, s)
    if curvature < 0.0:
        peak = -(gx * c + gy * s) / curvature
        if min(0.0, ahead) < peak < max(0.0, ahead):
            value, px, py = row_value_with_margin(kind, p, margin, x + peak * c, y + peak * s)
            return value, px, py, peak
    if end > start:
        return end, ex, ey, ahead
    return start, gx, gy, 0.0


@kernel
def _largest_of_polygon_row(
    p: FloatArray, margin: float, x: float, y: float, c: float, s: float, ahead: float
) -> tuple[float, float, float, float]:
    """A polygon row's largest value at the BRAKING_STEPS points of the line
    from (x, y) ``ahead`` on along (c, s) to its end, its gradient and the
    distance on where it is."""
    worst = -math.inf
    hx = hy = distance = 0.0
    for i in range(1, BRAKING_STEPS + 1):
        on = ahead * i / BRAKING_STEPS
        value, gx, gy = polygon_value(p, margin, x + on * c, y + on * s)
        if value > worst:
            worst = value
            hx = gx
            hy = gy
            distance = on
        if ahead == 0.0:
            break
    return worst, hx, hy, distance


@kernel
def held_on_braking_line(
    kind: int,
    p: FloatArray,
    margin: float,
    x: float,
    y: float,
    theta: float,
    v: float,
    rate: float,
    dt: float,
) -> tuple[float, float, float, float, float, float, float, bool]:
    """A row's largest value over the line the robot brakes along from
    (x, y, theta) at v, at ``rate`` (``braking_distance`` on along the
    heading): the value, its gradient, the sensitivity of the point where
    it is to (v, omega) beyond the start's (2x2 row by row), and whether
    that point is inside the line (not an end).

    The sensitivity is that of the largest value over the line. With v, only
    the line's end moves out of it: where the largest is at the end, it
    moves along the heading as the braking distance does; inside the line
    the row is at its largest along the line, its gradient across the line
    (returned so: a polygon's sampled point's component along the line is
    the sampling's, of either sign), and the points moving along the line
    change that largest value by nothing, so the sensitivity to v is 0.
    Taking the sampled point's gradient and motion along the line instead
    gave the speed's sensitivity an arbitrary sign, and the speed chattered
    between full acceleration and full braking. With omega the line turns
    about its start: the point at a distance on moves across it by that
    distance times dt. Where the largest is at the start (or the robot
    stops within the next sample: the line is its start), it moves with
    neither."""
    ahead = braking_distance(v, rate, dt)
    c = math.cos(theta)
    s = math.sin(theta)
    if kind == POLYGON_ROW:
        worst, hx, hy, distance = _largest_of_polygon_row(p, margin, x, y, c, s, ahead)
    else:
        worst, hx, hy, distance = _largest_of_quadratic_row(kind, p, margin, x, y, c, s, ahead)
    if distance == 0.0:
        return worst, hx, hy, 0.0, 0.0, 0.0, 0.0, False
    e01 = -distance * dt * s
    e11 = distance * dt * c
    if distance != ahead or (hx * c + hy * s) * ahead <= 0.0:
        # inside the line (also where a polygon's end is its furthest point
        # in sampled but the row falls towards it: its largest is just
        # before it); the gradient of the largest value: across the line
        across = hy * c - hx * s
        return worst, -across * s, across * c, 0.0, e01, 0.0, e11, True
    along = abs(v) / rate - 0.5 * dt  # d ahead / dv
    return worst, hx, hy, along * c, e01, along * s, e11, False


@kernel
def _along_arc(
    x: float, y: float, c: float, s: float, curvature: float, on: float
) -> tuple[float, float, float, float]:
    """The point ``on`` along the arc of ``curvature`` (nonzero) from (x, y)
    heading along (c, s), and its derivative with the curvature, the
    distance along held."""
    turn = curvature * on
    if abs(turn) < 1e-3:  # the closed forms below lose their digits
        ahead = on * (1.0 - turn * turn / 6.0)
        across = on * turn * (0.5 - turn * turn / 24.0)
        d_ahead = -on * on * turn / 3.0
        d_across = on * on * (0.5 - turn * turn / 8.0)
    else:
        half = math.sin(0.5 * turn)
        ahead = math.sin(turn) / curvature
        across = 2.0 * half * half / curvature
        d_ahead = (on * math.cos(turn) - ahead) / curvature
        d_across = (on * math.sin(turn) - across) / curvature
    return (
        x + c * ahead - s * across,
        y + s * ahead + c * across,
        c * d_ahead - s * d_across,
        s * d_ahead + c * d_across,
    )


@kernel
def held_on_braking_arc(
    kind: int,
    p: FloatArray,
    margin: float,
    x: float,
    y: float,
    theta: float,
    v: float,
    omega: float,
    rate: float,
    dt: float,
) -> tuple[float, float, float, float, float, float, float, bool]:
    """:func:`held_on_braking_line` on the arc the robot brakes along from
    (x, y, theta) at v with its curvature ``omega / v`` kept (its turn rate
    falling with the speed), for a half-plane or a circle row (an ellipse of
    equal axes; found exactly: at the arc's point furthest along the row's
    gradient, a half-plane's normal or the way to a keep-out circle's
    centre, from the arc's centre, where that lies inside the arc, else at
    the larger end). The line where the robot is not turning. The
    sensitivity to (v, omega): with omega the arc turns about its start
    over dt and bends as its curvature does (by 1 / v), with v it bends by
    -curvature / v, and where its end is furthest in the end moves along the
    arc as the braking distance does."""
    if v == 0.0 or omega == 0.0:
        return held_on_braking_line(kind, p, margin, x, y, theta, v, rate, dt)
    ahead = braking_distance(v, rate, dt)
    c = math.cos(theta)
    s = math.sin(theta)
    curvature = omega / v
    # the arc's centre, and the way from it to the point where the row is largest
    cx = x - s / curvature
    cy = y + c / curvature
    if kind == ELLIPSE_ROW:
        wx = -p[5] * (p[0] - cx)
        wy = -p[5] * (p[1] - cy)
    else:
        wx = p[0]
        wy = p[1]
    # that point's heading on the arc, and how far on it is (the arc's sense)
    bend = math.copysign(1.0, curvature)
    heading = math.atan2(bend * wx, -bend * wy)
    turn = (heading - theta) % (2.0 * math.pi)
    if omega < 0.0 and turn > 0.0:
        turn -= 2.0 * math.pi
    on = turn / curvature
    start, gx, gy = row_value_with_margin(kind, p, margin, x, y)
    inner = (wx != 0.0 or wy != 0.0) and abs(on) < abs(ahead)
    if not inner:
        on = ahead
    px, py, kx, ky = _along_arc(x, y, c, s, curvature, on)
    value, hx, hy = row_value_with_margin(kind, p, margin, px, py)
    if not inner and value <= start:
        return start, gx, gy, 0.0, 0.0, 0.0, 0.0, False
    # the point's motion: the arc bent (k), turned about its start over dt
    e00 = -kx * curvature / v
    e10 = -ky * curvature / v
    e01 = -(py - y) * dt + kx / v
    e11 = (px - x) * dt + ky / v
    if not inner:
        along = abs(v) / rate - 0.5 * dt  # d ahead / dv, along the arc's end
        end = theta + curvature * ahead
        e00 += along * math.cos(end)
        e10 += along * math.sin(end)
    return value, hx, hy, e00, e01, e10, e11, inner


@kernel
def held_where_braking_ends(
    kind: int,
    p: FloatArray,
    margin: float,
    keep: float,
    value: float,
    gx: float,
    gy: float,
    now: tuple[float, float, float, float],
    next_: tuple[float, float, float, float, float],
    sensitivity: tuple[float, float, float, float],
    rate: float,
    dt: float,
    omega_now: float = 0.0,
    turn_rate_rate: float = 0.0,
) -> tuple[float, float, float, float, float, float, float, bool]:
    """A row's barrier value at the point ``next_`` (x, y, heading at k+1, v,
    omega) and, where it is further in, on the line braking from v at
    ``rate`` takes, at its point furthest in (v^2 / (2 a) on along the
    heading; now: from ``now``'s point, heading and v_{k-1}): the value, its
    gradient, the point's sensitivity to (v, omega), ``sensitivity``
    (2x2 row by row) for the first, and whether the row is held inside the
    braking line, where its value does not move with v beyond the start's.
    The whole line, not its end alone: a robot whose braking line reached
    past a zone was let on towards it, and braking on a curve carried it in
    (docs/paper-notes.md, "Acceleration limits").

    Where the turn-rate acceleration ``turn_rate_rate`` lets the turn rate
    fall with the speed (``|omega / v| rate`` at most it), a half-plane or a
    circle row is held on the better of that line and the arc braking takes
    with the robot's curvature kept (:func:`held_on_braking_arc`; now: with
    ``omega_now``, omega_{k-1}): the robot can brake along either. Held on
    the line alone, a robot orbiting a circle at 3.5 m/s was held off the
    near side of a rock its circle passes, every line 1.75 m long across it,
    braked and turned in hard, and went 0.357 m inside its circle where 0.264
    is allowed (docs/paper-notes.md, eq. (28), "The braking arc")."""
    s00, s01, s10, s11 = sensitivity
    braked, hx, hy, e00, e01, e10, e11, inner = held_on_braking_line(
        kind, p, margin, next_[0], next_[1], next_[2], next_[3], rate, dt
    )
    if keep > 0.0:
        behind = held_on_braking_line(kind, p, margin, now[0], now[1], now[2], now[3], rate, dt)
        braked -= keep * behind[0]
    v = next_[3]
    omega = next_[4]
    if (
        omega != 0.0
        and abs(omega) * rate <= turn_rate_rate * abs(v)
        and (kind != POLYGON_ROW and (kind != ELLIPSE_ROW or p[2] == p[3]))
    ):
        on_arc, ax, ay, a00, a01, a10, a11, arc_inner = held_on_braking_arc(
            kind, p, margin, next_[0], next_[1], next_[2], v, omega, rate, dt
        )
        if keep > 0.0:
            arc_behind = held_on_braking_arc(
                kind, p, margin, now[0], now[1], now[2], now[3], omega_now, rate, dt
            )
            on_arc -= keep * arc_behind[0]
        if on_arc < braked:
            braked = on_arc
            hx, hy, e00, e01, e10, e11, inner = ax, ay, a00, a01, a10, a11, arc_inner
    if braked <= value:
        return value, gx, gy, s00, s01, s10, s11, False
    return braked, hx, hy, s00 + e00, s01 + e01, s10 + e10, s11 + e11, inner


@inlined
def keep_constraints(
    estimate: FloatArray,
    u_prev: FloatArray,
    row_kinds: IntArray,
    row_params: FloatArray,
    look_ahead: float,
    robot: Plant,
    work: Scratch,
    u: FloatArray,
    barrier_rate: float = 1.0,
    held_ahead: float = math.inf,
) -> bool:
    """Change the tracking input ``u`` in place so that the predicted point
    ``ahead = min(look_ahead, held_ahead)`` ahead of the axle (the tracking
    output, or a point between it and the axle) keeps the constraint rows
    shrunk by ``ahead`` (so the axle centre, ``ahead`` behind it, keeps the
    rows themselves) and by the estimate's margin
    (``robot.constraint_margin``), as a discrete-time barrier: a row's value
    at that point may fall to ``1 - barrier_rate`` of its value now and no
    lower (1: onto the bound in one sample); True when it had to. The change
    is the smallest in the tracking output's motion (``look_ahead``).

    A row held at the point ``l`` ahead and shrunk by ``l`` keeps the axle
    up to ``2 l`` further from a zone than the row asks where the robot
    heads along the zone's edge; between two rows on either side of it
    (an aisle past a box) that is ``2 l`` of the way's width, and the rows
    met nowhere at a look-ahead of 0.3 m: ``paper.rows_ahead`` holds them at
    no more than the default look-ahead (docs/paper-notes.md, eq. (28),
    "The rows held no further ahead than the default look-ahead")."""
    dt = robot.dt
    ahead = min(look_ahead, held_ahead)
    margin = ahead + robot.constraint_margin
    keep = 1.0 - barrier_rate
    ox = estimate[0] + ahead * math.cos(estimate[2])  # the held point now
    oy = estimate[1] + ahead * math.sin(estimate[2])
    px, py, pth = step(estimate[0], estimate[1], estimate[2], u[0], u[1], dt)
    c = math.cos(pth)
    s = math.sin(pth)
    qx = px + ahead * c
    qy = py + ahead * s
    # eq. (24): sensitivity of x_{k+1} to the input, at the tracking input.
    b = work.b
    input_jacobian_into(estimate[2], u[0], u[1], dt, b)
    # D_t B: the held point's sensitivity to the input (eq. (26) D times B).
    t00 = b[0, 0] - ahead * s * b[2, 0]
    t01 = b[0, 1] - ahead * s * b[2, 1]
    t10 = b[1, 0] + ahead * c * b[2, 0]
    t11 = b[1, 1] + ahead * c * b[2, 1]
    # and the tracking output's, the norm of the change (the same where the
    # rows are held at the output)
    o00 = b[0, 0] - look_ahead * s * b[2, 0]
    o01 = b[0, 1] - look_ahead * s * b[2, 1]
    o10 = b[1, 0] + look_ahead * c * b[2, 0]
    o11 = b[1, 1] + look_ahead * c * b[2, 1]
    # Under an acceleration limit the robot stops only beyond x_{k+1}: the
    # rows are held at the point and also on the line braking from the input takes.
    rate = robot.limits[2]
    turn_rate_rate = robot.limits[3]
    a, eta, h = work.d, work.eta, work.h
    # A typed zero, not the literal 0: numba compiles a kernel once per literal it gets.
    count = int(np.int64(0))
    # whether each kept row is held inside its braking line
    inner0 = inner1 = False
    for i in range(row_kinds.shape[0]):
        if row_kinds[i] == POLYGON_ROW:
            value, gx, gy = polygon_value(row_params[i], margin, qx, qy)
            if keep > 0.0:
                value -= keep * polygon_value(row_params[i], margin, ox, oy)[0]
        else:
            value, gx, gy = row_value_with_margin(row_kinds[i], row_params[i], margin, qx, qy)
            if keep > 0.0:
                now, _, _ = row_value_with_margin(row_kinds[i], row_params[i], margin, ox, oy)
                value -= keep * now
        s00, s01, s10, s11 = t00, t01, t10, t11
        inner = False
        if rate != math.inf:
            value, gx, gy, s00, s01, s10, s11, inner = held_where_braking_ends(
                row_kinds[i], row_params[i], margin, keep, value, gx, gy,
                (ox, oy, estimate[2], u_prev[0]), (qx, qy, pth, u[0], u[1]),
                (t00, t01, t10, t11), rate, dt, u_prev[1], turn_rate_rate,
            )  # fmt: skip
        if value <= 0.0:
            continue
        slot, count = kept_row_slot(value, count, eta)
        if slot < 0:
            continue
        if slot == 0:
            inner0 = inner
        else:
            inner1 = inner
        a[slot, 0] = gx * s00 + gy * s10
        a[slot, 1] = gx * s01 + gy * s11
        eta[slot] = -value  # saturate to the violated bound
    if count == 0:
        return False
    h[0, 0] = o00 * o00 + o10 * o10
    h[0, 1] = o00 * o01 + o10 * o11
    h[1, 0] = h[0, 1]
    h[1, 1] = o01 * o01 + o11 * o11
    # keep H invertible when the output is the axle itself (look_ahead = 0)
    floor = REGULARISATION * (h[0, 0] + h[1, 1])
    h[0, 0] += floor
    h[1, 1] += floor
    dv, dw = constrained_change(a, eta, count, h)
    v_track = u[0]
    omega_track = u[1]
    u[0], u[1] = saturate(v_track + dv, omega_track + dw, u_prev[0], u_prev[1], robot.limits, dt)
    if keep > 0.0:
        # The limits clipped the change (a turn tighter than the robot can
        # make): what the rows still lack, to first order, taken from the
        # speed alone, whose sensitivity does not vanish at the turn limit.
        # Not for a row held inside its braking line: its value moves with
        # the speed only as the line's start does, by dt a sample, and the
        # step that asked for swung the speed between its limits.
        extra = 0.0
        for slot in range(count):
            if inner0 if slot == 0 else inner1:
                continue
            lacking = a[slot, 0] * (u[0] - v_track) + a[slot, 1] * (u[1] - omega_track)
            lacking -= eta[slot]
            if lacking > 0.0 and abs(a[slot, 0]) > 1e-12:
                step_v = -lacking / a[slot, 0]
                if abs(step_v) > abs(extra):
                    extra = step_v
        if extra != 0.0:
            u[0], u[1] = saturate(u[0] + extra, u[1], u_prev[0], u_prev[1], robot.limits, dt)
    return True


@kernel
def keep_reference(
    reference: FloatArray, row_kinds: IntArray, row_params: FloatArray, margin: float
) -> bool:
    """Move a reference point (x, y, unit tangent x, y) that lies beyond the
    rows, shrunk by ``margin``, back onto their boundary, its tangent along the
    boundary; True when it moved.

    A one-sample filter alone cannot bring the robot round a zone the path
    crosses: where the path's point lies straight through the zone, every
    motion it allows leads away from the point, and the robot stops at the
    edge. Aimed at the reference moved onto the zone's edge, the tracking law
    follows the edge and rejoins the path where it leaves the zone. Half-plane
    rows project exactly; an ellipse row scales the point along its ray from
    the centre (the nearest point for a circle). Two passes over the rows
    settle a point beyond two of them (a corner).
    """
    moved = False
    for _ in range(2):
        for i in range(row_kinds.shape[0]):
            p = row_params[i]
            x, y = reference[0], reference[1]
            if row_kinds[i] == POLYGON_ROW:
                value, gx, gy = polygon_value(p, margin, x, y)
            else:
                value, gx, gy = row_value_with_margin(row_kinds[i], p, margin, x, y)
            if value <= 0.0:
                continue
            moved = True
            if row_kinds[i] == ELLIPSE_ROW:
                # on the ray from the centre: G(scale * d) = 1 with G = value / sign + 1
                scale = 1.0 / math.sqrt(max(value * p[5] + 1.0, 1e-300))
                reference[0] = p[0] + scale * (x - p[0])
                reference[1] = p[1] + scale * (y - p[1])
                _, gx, gy = row_value_with_margin(
                    row_kinds[i], p, margin, reference[0], reference[1]
                )
            else:
                reference[0] = x - value * gx
                reference[1] = y - value * gy
            norm = hypot(gx, gy)
            if norm == 0.0:
                continue
            nx = gx / norm
            ny = gy / norm
            along = reference[2] * -ny + reference[3] * nx
            if along != 0.0:
                # the tangent of the boundary, in the path's sense of travel
                sense = math.copysign(1.0, along)
                reference[2] = -ny * sense
                reference[3] = nx * sense
    return moved


# The steepest the aim's way round a keep-out ellipse leaves or rejoins the
# path: 1 across in 2 along. The aim's sideways speed is this times the path's,
# and the tracking law closes its move as an error: the way up the edge of a
# zone the path meets head-on (infinitely steep) turned the turn rate from 0
# to its limit in one sample (docs/paper-notes.md, eq. (28), "The way round
# on a ramp").
RAMP_SLOPE = 0.5


@kernel
def _support_terms(
    p: FloatArray, margin: float, tx: float, ty: float, side: float
) -> tuple[float, float, float]:
    """The quadratic terms of the support function of the keep-out ellipse row
    ``p`` grown by ``margin``, h(n) = n . centre + sqrt(n' S n) with S = R
    diag(a^2, b^2) R', for n in the plane of m (across the path heading along
    the unit (tx, ty), to ``side`` of it) and t (along it): (m' S m, m' S t,
    t' S t)."""
    a = p[2] + margin
    b = p[3] + margin
    cos_phi = math.cos(p[4])
    sin_phi = math.sin(p[4])
    # the path's direction and the way across in the ellipse's own axes
    du = cos_phi * tx + sin_phi * ty
    dw = -sin_phi * tx + cos_phi * ty
    mx = -ty * side
    my = tx * side
    mu_ = cos_phi * mx + sin_phi * my
    mw = -sin_phi * mx + cos_phi * my
    sa = mu_ * mu_ * a * a + mw * mw * b * b  # m' S m
    sb = mu_ * du * a * a + mw * dw * b * b  # m' S t
    sc = du * du * a * a + dw * dw * b * b  # t' S t
    return sa, sb, sc


@kernel
def _way_round(
    p: FloatArray, margin: float, x: float, y: float, tx: float, ty: float, side: float
) -> tuple[float, float, float]:
    """How far the aim (x, y) on a path heading along the unit (tx, ty) moves
    across the path, to ``side`` of it (1 the left of travel, -1 the right),
    to clear the keep-out ellipse row ``p`` grown by ``margin``, on a ramp:
    the moved aim keeps every point of the zone outside the wedge of slope
    RAMP_SLOPE about the path's line ahead of it and behind it. (distance >= 0,
    unit side x, y); 0 where the zone lies on the other side of the wedge."""
    dx = p[0] - x  # the zone's centre from the aim
    dy = p[1] - y
    mx = -ty * side
    my = tx * side
    # The reach is the least support h(m + mu t) over |mu| <= RAMP_SLOPE: the
    # largest of m . q - RAMP_SLOPE |t . q| over the zone's points q (its
    # minimax), a convex function of mu.
    sa, sb, sc = _support_terms(p, margin, tx, ty, side)
    along = tx * dx + ty * dy
    across = mx * dx + my * dy
    slack = max(sa - sb * sb / sc, 0.0)
    if along * along < sc:
        mu = -sb / sc - math.copysign(1.0, along) * abs(along) * math.sqrt(
            slack / (sc * (sc - along * along))
        )
    else:  # monotone in mu: the least at an end
        mu = -math.copysign(RAMP_SLOPE, along)
    mu = min(max(mu, -RAMP_SLOPE), RAMP_SLOPE)
    reach = across + mu * along + math.sqrt(max(sa + 2.0 * sb * mu + sc * mu * mu, 0.0))
    return max(reach, 0.0), mx, my


@kernel
def _climb_stretch(rise: float, bend: float) -> float:
    """[m] The stretch over which :func:`_climb`'s slope grows at its third
    derivative ``bend`` (and, mirrored, falls): to RAMP_SLOPE, or, for a
    climb too short to reach that, to the slope at its middle."""
    return min(math.sqrt(RAMP_SLOPE / bend), math.pow(0.5 * rise / bend, 1.0 / 3.0))


@kernel
def _climb(distance: float, rise: float, bend: float) -> tuple[float, float]:
    """(climbed, length) of a way across that rises by ``rise`` and starts
    and ends straight (no slope, no curvature), ``distance`` along from its
    start: no steeper than RAMP_SLOPE, its third derivative at most
    ``bend`` [1/m^2], the shortest both allow. Its slope grows at ``bend``
    over a stretch ``s`` and stops growing over another, to ``bend s^2``,
    holds that, and the same mirrored at the top."""
    stretch = _climb_stretch(rise, bend)
    slope = bend * stretch * stretch
    length = 2.0 * stretch + rise / slope
    u = min(max(distance, 0.0), length)
    mirrored = u > 0.5 * length
    if mirrored:
        u = length - u
    if u <= stretch:
        climbed = bend * u * u * u / 6.0
    elif u <= 2.0 * stretch:
        w = u - stretch
        cube = stretch * stretch * stretch / 6.0
        climbed = bend * (cube + 0.5 * stretch * w * (stretch + w) - w * w * w / 6.0)
    else:
        climbed = slope * (u - stretch)
    return (rise - climbed if mirrored else climbed), length


@kernel
def _way_round_eased(
    p: FloatArray,
    margin: float,
    x: float,
    y: float,
    way: FloatArray,
    side: float,
    turn_acceleration: float,
    room: float,
) -> float:
    """:func:`_way_round` under a turn-rate acceleration limit: how far the
    aim (x, y) moves across the path to ``side`` of it, round the keep-out
    ellipse row ``p`` grown by ``margin``, on a climb the limit lets the
    robot follow. The ramp of slope RAMP_SLOPE asks its whole turn at its
    foot, which the turn-rate acceleration gives only over time: the robot
    fell behind the aim as it turned onto the ramp and swung past its top
    (gen-124-line, 1.59 m off where the top was 1.06 m). The climb to the
    zone's reach across the path ``P`` (the top) is no steeper than the
    ramp, and its curvature changes at most as fast as the turn rate can at
    ``turn_acceleration`` at the path's speed where it passes the zone
    (``way[5]``): a third derivative of ``turn_acceleration / speed^2``
    along the path, a sideways jerk of ``speed turn_acceleration``
    (:func:`_climb`). It ends where the ramp reaches the top's height, so
    it keeps the aim at least as far across as the ramp, and the way down
    is its mirror. It starts no further back than ``room``, how far the aim
    is past where the path last rests before the zone (``way[6]``: a robot
    at rest turns in place), steeper there, and no climb is left (-1,
    the ramp's way) where not even the ramp fits (docs/paper-notes.md,
    eq. (28), "The ramp eased under a turn-rate acceleration limit")."""
    tx = way[2]
    ty = way[3]
    mx = -ty * side
    my = tx * side
    sa, sb, sc = _support_terms(p, margin, tx, ty, side)
    top = math.sqrt(max(sa, 0.0))
    reach = mx * (p[0] - x) + my * (p[1] - y) + top  # the zone's support across
    if reach <= 0.0 or top == 0.0:
        return 0.0
    # The top (the zone's point furthest across) this far ahead of the aim,
    # and how far before it (after it, on the way down) the ramp of slope
    # RAMP_SLOPE reaches its height: the wedge's support h(m -+ mu t) less
    # RAMP_SLOPE a metre until it is the top's h(m).
    ahead = tx * (p[0] - x) + ty * (p[1] - y) + sb / top
    sense = 1.0 if ahead >= 0.0 else -1.0
    slope = sense * RAMP_SLOPE
    wedge = math.sqrt(max(sa - 2.0 * slope * sb + slope * slope * sc, 0.0))
    corner = (wedge - top) / RAMP_SLOPE + sense * sb / top
    return _climb_to_top(reach, ahead, corner, way[5], turn_acceleration, room)


@kernel
def _climb_to_top(
    reach: float, ahead: float, corner: float, speed: float, turn_acceleration: float, room: float
) -> float:
    """How far across the aim is on the climb to the zone's top ``reach``
    across the path (:func:`_climb`, at the third derivative
    ``turn_acceleration / speed^2``), the top ``ahead`` of the aim (behind
    it: negative, on the way down), the climb ending ``corner`` before the
    top (after it, on the way down), where the ramp of slope RAMP_SLOPE
    reaches the top's height; no further back than ``room`` before the top
    less ``ahead`` (where the path rests), steeper there, and -1 (the ramp's
    way) where not even the ramp fits. The ellipse's and the polygon's
    (:func:`_way_round_eased`, :func:`_way_round_polygon_eased`)."""
    bend = turn_acceleration / max(speed * speed, 1e-300)
    length = _climb(0.0, reach, bend)[1]
    if ahead >= 0.0 and ahead + room - corner < length:
        # From where the path rests: the climb as long as the room allows.
        stretch = 0.5 * (ahead + room - corner - reach / RAMP_SLOPE)
        if not stretch > 0.0:
            return -1.0
        bend = max(bend, RAMP_SLOPE / (stretch * stretch))
        length = _climb(0.0, reach, bend)[1]
    return _climb(corner + length - abs(ahead), reach, bend)[0]


# [m] A move across the path no larger than rounding leaves (a straight path
# measured in two frames of the same line).
ROUNDING = 1e-9

# |m + mu t| at the ramp's ends: the factor a disc's support grows by there.
_RAMP_NORM = math.sqrt(1.0 + RAMP_SLOPE * RAMP_SLOPE)


@kernel
def polygon_side(p: FloatArray, x: float, y: float, tx: float, ty: float) -> float:
    """The shorter way across the keep-out polygon row ``p`` for a path
    through (x, y) heading along the unit (tx, ty): 1 the left of travel, -1
    the right; the side the polygon reaches less far into from the path's
    line, the left where both are as far (to rounding: a path through a
    box's middle). Along a straight path it is the same all the way."""
    left = -math.inf
    right = -math.inf
    for i in range(int(p[0])):
        k = HEADER + PER_VERTEX * i
        side = -ty * (p[k] - x) + tx * (p[k + 1] - y)
        left = max(left, side)
        right = max(right, -side)
    if left > right + 1e-9 * (abs(left) + abs(right)):
        return -1.0
    return 1.0


@kernel
def _way_round_polygon(
    p: FloatArray, margin: float, x: float, y: float, tx: float, ty: float, side: float
) -> tuple[float, float, float]:
    """:func:`_way_round` for the keep-out polygon row ``p`` grown by ``margin``
    (K, its Minkowski sum with a disc of that radius), about the aim a, to
    ``side`` of the path (1 the left of travel, -1 the right; 0 the shorter
    way across here, :func:`polygon_side`).

    The reach is the least of K's
    support function over n = m + mu t, |mu| <= RAMP_SLOPE, as for the
    ellipse; by the minimax theorem it is the most of m.(q - a) - RAMP_SLOPE
    |t.(q - a)| over the points q of K, a concave function: its most over the
    half ahead of a (or behind) is K's support point in the direction m - s t
    (m + s t) where that lies there, else on the line through a across the
    path, where K's farthest point along m is on an edge moved out by the
    margin or on a corner's disc. Exact, without iterating."""
    if side == 0.0:
        side = polygon_side(p, x, y, tx, ty)
    mx = -ty * side
    my = tx * side
    r = margin
    # The disc about the vertices' mean that holds the polygon, grown: a line
    # that misses it leaves the zone on one side, and the wedge that misses it
    # on both sides leaves the aim far from the zone: nothing to move.
    dx = p[1] - x
    dy = p[2] - y
    held = p[3] + r
    across = abs(mx * dx + my * dy)
    if across >= held or across - RAMP_SLOPE * abs(tx * dx + ty * dy) + held * _RAMP_NORM <= 0.0:
        return 0.0, mx, my
    n = int(p[0])
    reach = -math.inf
    for sense in (1.0, -1.0):  # ahead of the aim, then behind it
        ux = mx - sense * RAMP_SLOPE * tx
        uy = my - sense * RAMP_SLOPE * ty
        best = -math.inf
        bx = 0.0
        by = 0.0
        for i in range(n):
            k = HEADER + PER_VERTEX * i
            value = ux * (p[k] - x) + uy * (p[k + 1] - y)
            if value > best:
                best = value
                bx = p[k]
                by = p[k + 1]
        # the support point, the vertex moved out by r along u / |u|
        along = tx * (bx - x) + ty * (by - y) + r * (tx * ux + ty * uy) / _RAMP_NORM
        if sense * along >= 0.0:
            reach = max(reach, best + r * _RAMP_NORM)
    for i in range(n):  # K's farthest point along m on the line a + s m
        k = HEADER + PER_VERTEX * i
        vx = p[k] - x
        vy = p[k + 1] - y
        w = tx * vx + ty * vy
        if abs(w) <= r:  # the corner's disc
            reach = max(reach, mx * vx + my * vy + math.sqrt(r * r - w * w))
        # the edge moved out by 0..r: 0 <= n.(q - v) <= r, 0 <= e.(q - v) <= length
        nx = p[k + 2]
        ny = p[k + 3]
        low = -math.inf
        high = math.inf
        for start, rate, top in (
            (-(nx * vx + ny * vy), nx * mx + ny * my, r),
            (ny * vx - nx * vy, -ny * mx + nx * my, p[k + 4]),
        ):
            if rate == 0.0:
                if start < 0.0 or start > top:
                    high = -math.inf
            else:
                one = -start / rate
                two = (top - start) / rate
                low = max(low, min(one, two))
                high = min(high, max(one, two))
        if low <= high:
            reach = max(reach, high)
    return max(reach, 0.0), mx, my


@kernel
def _way_round_polygon_eased(
    p: FloatArray,
    margin: float,
    x: float,
    y: float,
    way: FloatArray,
    turn_acceleration: float,
    room: float,
) -> float:
    """:func:`_way_round_eased` for the keep-out polygon row ``p`` grown by
    ``margin`` (K), about the aim a on the line of the pass of ``way``, to
    its side ``way[4]``: the climb to K's reach across the path ``P`` (its
    support along m less m.a) that ends where the ramp's line reaches that
    height, and the way down its mirror. Ahead of the aim the ramp is at
    most K's support along m - RAMP_SLOPE t (less that of a), rising at
    RAMP_SLOPE a metre as the aim moves on (all of K ahead of it), so it is
    ``P`` at most from (P - h(m - RAMP_SLOPE t)) / RAMP_SLOPE ahead of the
    aim on; behind it, mirrored, by h(m + RAMP_SLOPE t) up to as far past.
    Between the two (a box's face along the path) the climb holds ``P``.
    The ramp alone swung the robot past its top under acceleration limits
    as it did round an ellipse (gen-124-line-box of
    scripts/keep_out_shapes.py: 1.66 m off its line where 1.30 m is
    allowed; docs/paper-notes.md, eq. (28), "The way round a box or
    polygon, decided once", The climb under a turn-rate acceleration
    limit)."""
    tx = way[2]
    ty = way[3]
    mx = -ty * way[4]
    my = tx * way[4]
    r = margin
    # the line through a that misses the disc holding K: nothing to move
    # (as _way_round_polygon)
    if abs(mx * (p[1] - x) + my * (p[2] - y)) >= p[3] + r:
        return 0.0
    top = -math.inf
    rising = -math.inf  # h(m - s t), the ramp's line ahead of the aim
    falling = -math.inf  # h(m + s t), behind it
    for i in range(int(p[0])):
        k = HEADER + PER_VERTEX * i
        across = mx * (p[k] - x) + my * (p[k + 1] - y)
        along = tx * (p[k] - x) + ty * (p[k + 1] - y)
        top = max(top, across)
        rising = max(rising, across - RAMP_SLOPE * along)
        falling = max(falling, across + RAMP_SLOPE * along)
    reach = top + r
    if reach <= 0.0:
        return 0.0
    before = (reach - rising - r * _RAMP_NORM) / RAMP_SLOPE  # to where the rise is at P
    after = (reach - falling - r * _RAMP_NORM) / RAMP_SLOPE  # past where the fall leaves P
    # the plateau's middle ahead of the aim, and its half-length
    ahead = 0.5 * (before - after)
    corner = max(-0.5 * (before + after), 0.0)
    return _climb_to_top(reach, ahead, corner, way[5], turn_acceleration, room)


@kernel
def _polygon_round(
    p: FloatArray,
    way: FloatArray,
    margin: float,
    x: float,
    y: float,
    lead: float,
    aim: FloatArray,
    start_x: float,
    start_y: float,
    turn_acceleration: float,
    joined: float,
) -> tuple[float, float, float]:
    """How far the aim (x, y), heading along ``aim[2:4]``, moves across its
    path round the keep-out polygon row ``p`` grown by ``margin``, and the
    unit side it moves to (reach negative: the other side). On the pass of
    its way round ``way`` (:func:`ways_round`, heading within a quarter turn
    of the pass's tangent) as an ellipse's (:func:`aim_round_zones`): by the
    side decided once for the phase, measured in the frame of the pass,
    ``lead`` further along it, fading to the way round by the aim's own side
    of the zone's centre, from its own place, as the aim leaves the pass for
    another stretch of path (:func:`on_another_stretch`, from its path's
    point ``start_x``, ``start_y``). Heading away from the pass (a lap's far
    side), the shorter way across at the aim's own place, ``lead`` along its
    own tangent, as before the way was decided once.

    The shorter way across at each aim swings with the path's tangent on a
    curve: a spiral through a rock went round it by the outside, then the
    inside, then the outside again, its aim 0.7 m to either side of the
    path (docs/paper-notes.md, eq. (28), "The way round a box or polygon,
    decided once")."""
    tx = aim[2]
    ty = aim[3]
    if way[4] == 0.0 or tx * way[2] + ty * way[3] <= 0.0:
        return _way_round_polygon(p, margin, x + lead * tx, y + lead * ty, tx, ty, 0.0)
    along = way[2] * (x - way[0]) + way[3] * (y - way[1]) + lead
    across = -ty * (x - start_x) + tx * (y - start_y)
    at_x = way[0] + along * way[2] - across * way[3]
    at_y = way[1] + along * way[3] + across * way[2]
    reach = _way_round_polygon(p, margin, at_x, at_y, way[2], way[3], way[4])[0]
    if turn_acceleration != math.inf and joined > 0.0:
        # the climb a turn-rate acceleration limit lets the robot follow, as
        # an ellipse's (aim_round_zones), from no further back than the rest
        eased = _way_round_polygon_eased(
            p, margin, at_x, at_y, way, turn_acceleration, along + way[6]
        )
        if eased >= 0.0:
            reach += joined * (eased - reach)
    # The pass's line is the path's only near the pass: on a curve the aim
    # lies off it, and the ramp measured on it left the aim inside the zone
    # where the path curves away from the side gone round by (0.10 m inside
    # a box a circle of radius 2.5 m runs through; the robot stood at its
    # corner, 0.81 m off its path, gen-025-circle-box of
    # scripts/keep_out_shapes.py). Where the wedge at the aim's own place asks
    # more, both in the pass's frame and along the aim's own tangent, the aim
    # goes the lesser of those: each alone keeps it outside the zone, and far
    # from the pass the one or the other asks far more (the aim far off the
    # line; the tangent swung across the zone) (docs/paper-notes.md, eq.
    # (28), "The way round a box or polygon, decided once"). Along a straight
    # path the three agree to rounding, and the line's is kept to the byte.
    placed = _way_round_polygon(
        p, margin, x + lead * way[2], y + lead * way[3], way[2], way[3], way[4]
    )[0]
    if placed > reach + ROUNDING:
        own = _way_round_polygon(p, margin, x + lead * tx, y + lead * ty, tx, ty, way[4])[0]
        if own > reach + ROUNDING:
            reach = min(placed, own)
    nx = -ty * way[4]
    ny = tx * way[4]
    share, off, side = on_another_stretch(way, p[1], p[2], start_x, start_y)
    if share > 0.0:  # another stretch: round by its own side, from its own place
        off_x = at_x - off * way[3]
        off_y = at_y + off * way[2]
        own = _way_round_polygon(p, margin, off_x, off_y, way[2], way[3], side)[0]
        reach = (1.0 - share) * reach + share * own * side * way[4]
    return reach, nx, ny


# The fastest the aim's offset round the zones moves, per metre of the path's
# own step: the ramp's slope for the path's line, and as much again for the
# line's swing on a curve, where a zone ahead moves across the line as the
# tangent turns (a circle of radius 2.5 m through a zone asked for 0.8 m per
# metre; docs/paper-notes.md, eq. (28), "The aim's offset on a curve").
OFFSET_SLOPE = 2.0 * RAMP_SLOPE


@kernel
def ramped_offset(
    wanted_x: float, wanted_y: float, before_x: float, before_y: float, path_step: float
) -> tuple[float, float]:
    """The aim's offset from the path round the zones, ``wanted`` (from
    :func:`aim_round_zones`), moved from the offset of the sample before by
    at most OFFSET_SLOPE times the path's step. Along a straight path the
    ramp moves the offset no faster than RAMP_SLOPE, and it is kept as it is;
    at a corner, or on a curve whose zone lies across the path's line, the
    wedge swings with the path's tangent and the offset it asked for leapt
    to one side of the zone and to the other within two samples
    (``gen-039-polyline``: 0.11 m left, then 0.12 m right, the turn rate from
    6.4 to -7.3 rad/s in one sample)."""
    change_x = wanted_x - before_x
    change_y = wanted_y - before_y
    change = hypot(change_x, change_y)
    most = OFFSET_SLOPE * path_step
    if change <= most:
        return wanted_x, wanted_y
    share = most / change
    return before_x + share * change_x, before_y + share * change_y


# [m] How far the aim stands beyond the bound the filter keeps the output to
# (the zone grown by the look-ahead and the margin), so that the law's target
# is not where the filter acts: the look-ahead, up to the default look-ahead's
# 0.05 m without acceleration limits (aim_gap). A gap of a whole look-ahead
# widened every detour by it, 0.1 to 0.23 m more on the generated missions of
# fast robots at coarse rates (docs/paper-notes.md, eq. (28), "How wide a
# detour is").
AIM_GAP = 0.05


@inlined
def aim_gap(look_ahead: float, speed_rate: float, margin: float) -> float:
    """[m] The aim's gap beyond the filter's bound: the look-ahead, and with
    the margin the controller keeps round a zone for the estimate's error
    (``margin``, the body's reach apart) at most twice AIM_GAP, as both widen
    a detour beyond the zone's reach and the look-ahead, out of the 0.1 m the
    cross-track tolerance allows beyond the noise (a full gap with the
    paper's estimator at 1.9 cm of noise, a margin of 0.095 m, went 6 mm
    wider than that; with acceleration limits, a gap of 0.154 m beside a
    margin of 0.05 m went 0.86 m off where 0.85 is allowed;
    docs/paper-notes.md, eq. (28), "How wide a detour is"). Without an
    acceleration limit (``speed_rate`` infinite) also at most AIM_GAP; under
    one at most half of it: there the aim's move is fed forward
    (paper.next_input) and the robot follows the aim itself, so the gap is
    all of its detour beyond the margin, and at AIM_GAP three detours went
    2-7 mm wider than the tolerance (docs/paper-notes.md, eq. (28), "The
    aim's move fed forward under acceleration limits")."""
    gap = min(look_ahead, max(2.0 * AIM_GAP - margin, 0.0))
    if speed_rate != math.inf:
        return min(gap, 0.5 * AIM_GAP)
    return min(gap, AIM_GAP)


# The columns of a row of the ways round (ways_round): the path's point
# nearest the zone's centre, its unit tangent there, the side, the path's
# speed there, how far back along that tangent the path last rests before
# it (inf: it does not, or its times are not known), then the pass: the
# stretch of path about that point, PASS_POINTS points evenly along it, x
# then y (on_another_stretch); last, how far along the path from that point
# the pass's first point is (<= 0) and the path's length between two of its
# points (0 where the pass is straight: along_the_pass).
WAY_HEAD = 7
PASS_POINTS = 33
PASS_FIRST = WAY_HEAD + 2 * PASS_POINTS
PASS_STEP = PASS_FIRST + 1
WAY_COLUMNS = PASS_STEP + 1
# The widest a straight pass's points lie off its line, as a share of its
# length (rounding): along it, distances are measured on the line.
STRAIGHT = 1e-9
# [m] How far an aim may lie from the pass and still be on it; beyond, it
# fades onto another stretch of path heading the same way (a spiral's other
# loop, a coverage path's other lane) over as far again.
PASS_BAND = 0.1
# A path within this share of a zone's size (at least 1 m) of its centre runs
# through it, to rounding: round by the left (the validator's note names it).
THROUGH_CENTRE = 1e-12


def nearest_chords(
    x: FloatArray, y: FloatArray, px: FloatArray, py: FloatArray
) -> tuple[IntArray, FloatArray]:
    """For each point (px, py) (n of them), the chord (from sample k to k + 1)
    of its polyline through the samples (x, y) nearest it, and its share along
    it where it is nearest; (-1, 0) where the samples never move. One
    polyline for all (x, y of shape (m,)) or one each (shape (n, m))."""
    px = np.asarray(px, dtype=np.float64)[:, None]
    py = np.asarray(py, dtype=np.float64)[:, None]
    ax, ay, ex, ey = x[..., :-1], y[..., :-1], np.diff(x), np.diff(y)
    length2 = ex * ex + ey * ey
    moving = length2 > 0.0
    with np.errstate(all="ignore"):
        share = ((px - ax) * ex + (py - ay) * ey) / length2
        np.clip(share, 0.0, 1.0, out=share)
        gaps = np.hypot(ax + share * ex - px, ay + share * ey - py)
    k = np.argmin(np.where(moving, gaps, np.inf), axis=1)
    share = share[np.arange(k.size), k]
    still = ~moving.any(axis=-1)
    if np.any(still):
        k = np.where(still, -1, k)
        share = np.where(still, 0.0, share)
    return k, share


def kept_out(row_kinds: IntArray, row_params: FloatArray) -> tuple[IntArray, FloatArray]:
    """The keep-out rows, those a way round is found for (:func:`ways_round`):
    keep-out ellipses, boxes and polygons; and their centres, (n, 2)."""
    polygon = row_kinds == POLYGON_ROW
    rows = np.flatnonzero(polygon | ((row_kinds == ELLIPSE_ROW) & (row_params[:, 5] < 0.0)))
    first = np.where(polygon[rows], 1, 0)  # a polygon's centre follows its vertex count
    centres = row_params[rows[:, None], first[:, None] + np.arange(2)]
    return rows, centres


def comes_near(kind: int, p: FloatArray, x: FloatArray, y: FloatArray, clear: float) -> bool:
    """Whether a path through the points (x, y) comes within ``clear`` of the
    keep-out row ``p`` of ``kind``: into the ellipse grown by it (its
    semi-axes, as row_value_with_margin grows them). A box or polygon: True,
    its way kept whatever (a zero way still goes round it by the shorter way
    at each aim)."""
    if kind == POLYGON_ROW:
        return True
    c, s = math.cos(p[4]), math.sin(p[4])
    u = (c * (x - p[0]) + s * (y - p[1])) / (p[2] + clear)
    w = (-s * (x - p[0]) + c * (y - p[1])) / (p[3] + clear)
    return bool(np.any(u * u + w * w <= 1.0))


def ways_round(
    x: FloatArray, y: FloatArray, row_kinds: IntArray, row_params: FloatArray
) -> FloatArray:
    """The way round each keep-out row of a path sampled at (x, y),
    decided once for the phase (:func:`aim_round_zones`): per row, the point
    of the path (the polyline through the samples) nearest the zone's centre,
    the path's unit tangent there, and the side the aim goes round by, 1 the
    left of travel and -1 the right: the side away from the centre, the left
    where the path runs through the centre itself (THROUGH_CENTRE); a box
    or polygon's the shorter way across there (:func:`polygon_side`), its
    centre the one of the disc about its vertices' mean. Rows of other
    kinds, and a path that never moves, have no way (side 0).

    The side the zone's edge faced where the path's tangent line entered it
    swung with the tangent on a curve or at a corner, and the aim's offset
    went over to the other side within a detour: turn-rate kicks and
    reversals (docs/paper-notes.md, eq. (28), "The way round, decided once")."""
    ways = np.zeros((row_kinds.shape[0], WAY_COLUMNS))
    rows, centres = kept_out(row_kinds, row_params)
    chords, shares = nearest_chords(x, y, centres[:, 0], centres[:, 1])
    for i, k, share in zip(rows.tolist(), chords.tolist(), shares.tolist(), strict=True):
        kind = int(row_kinds[i])
        ways[i] = way_at(x, y, k, share, kind, row_params[i])
        if k >= 0:
            ways[i, WAY_HEAD:] = pass_points(x, y, k, share, pass_reach(kind, row_params[i]))
    return ways


def way_at(
    x: FloatArray,
    y: FloatArray,
    k: int,
    share: float,
    kind: int,
    p: FloatArray,
    speed: float = 0.0,
    rest: float = math.inf,
) -> FloatArray:
    """The way round the keep-out row ``p`` of ``kind`` (:func:`ways_round`) where
    the polyline through (x, y) passes its centre nearest: ``share`` along
    the chord from sample ``k`` (:func:`nearest_chords`); none for k < 0.
    ``speed`` and ``rest``: the path's speed there and the point where it
    last rests before it (WAY_COLUMNS), as far back along its tangent as
    that point is behind it."""
    if k < 0:
        return np.zeros(WAY_COLUMNS)
    ex = x[k + 1] - x[k]
    ey = y[k + 1] - y[k]
    length = math.hypot(ex, ey)
    nx = x[k] + share * ex
    ny = y[k] + share * ey
    if kind == POLYGON_ROW:
        side = polygon_side(p, nx, ny, ex / length, ey / length)
    else:
        cross = ex * (p[1] - y[k]) - ey * (p[0] - x[k])
        through = math.hypot(nx - p[0], ny - p[1]) <= THROUGH_CENTRE * max(p[2], 1.0)
        side = 1.0 if through or cross < 0.0 else -1.0
    way = np.zeros(WAY_COLUMNS)  # the pass is left to the caller (ways_round)
    way[:WAY_HEAD] = [nx, ny, ex / length, ey / length, side, speed, rest]
    return way


def pass_reach(kind: int, p: FloatArray) -> float:
    """[m] How far along the path either side of its point nearest the
    keep-out row ``p`` of ``kind`` the pass reaches: as far as the aim's climb
    round it can start, twice its ramp across the zone and a metre and a
    half (the margins and gaps), and the zone beyond (a box or polygon's
    size the radius of the disc about its vertices' mean that holds it)."""
    size = float(p[3]) if kind == POLYGON_ROW else max(float(p[2]), float(p[3]))
    return 2.0 * ((2.0 * size + 1.5) / RAMP_SLOPE + size)


def pass_points(x: FloatArray, y: FloatArray, k: int, share: float, reach: float) -> FloatArray:
    """The pass of a way round, its columns from WAY_HEAD on (WAY_COLUMNS):
    PASS_POINTS points evenly along the polyline through (x, y) from
    ``reach`` before its point ``share`` along chord ``k`` to ``reach`` after
    it, as far as the polyline goes and heads the way chord ``k`` does
    (within a quarter turn of it: where the way round applies,
    aim_round_zones), x then y; then how far along from that point the
    first is, and the length between two (0 for a straight pass)."""
    dx, dy = np.diff(x), np.diff(y)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(dx, dy))])
    here = along[k] + share * (along[k + 1] - along[k])
    turned = np.flatnonzero(dx * dx[k] + dy * dy[k] <= 0.0)  # chords a quarter turn or more off
    first = along[turned[turned < k].max() + 1] if (turned < k).any() else 0.0
    last = along[turned[turned > k].min()] if (turned > k).any() else along[-1]
    at = np.linspace(max(here - reach, first), min(here + reach, last), PASS_POINTS)
    px, py = np.interp(at, along, x), np.interp(at, along, y)
    length = math.hypot(dx[k], dy[k])
    off = np.abs(dy[k] * (px - x[k]) - dx[k] * (py - y[k])) / length if length > 0.0 else px * 0.0
    step = 0.0 if off.max() <= STRAIGHT * max(at[-1] - at[0], 1.0) else float(at[1] - at[0])
    return np.concatenate([px, py, [float(at[0]) - here, step]])


@kernel
def along_the_pass(way: FloatArray, x: float, y: float) -> float:
    """[m] How far along the path from the point of the way round ``way``
    (the path's point nearest the zone) the point (x, y) on or beside its
    pass lies: the pass's length to its point nearest (x, y), and beyond the
    pass's ends on along its end chords; along the way's tangent where the
    pass is straight. On a curve the distance along the tangent falls behind
    the path's own: it grows no further than the curve's radius, and a
    ramp down measured on it stretched over the quarter turn that followed
    a rock (docs/paper-notes.md, eq. (28), "The ramp down along a curved
    pass")."""
    step = float(way[PASS_STEP])
    if step == 0.0:
        return float(way[2] * (x - way[0]) + way[3] * (y - way[1]))
    # The pass heads within a quarter turn of the tangent: its points'
    # distances along the tangent grow. From the chord about the point's own
    # distance along, on to the nearer neighbour while there is one: the
    # distance to a pass that bends less sharply than the point is far from
    # it falls to its least and rises after.
    low = _last_pass_point_before(way, way[2] * (x - way[0]) + way[3] * (y - way[1]))
    gap, share = _squared_off_chord(way, low, x, y)
    for sense in (1, -1):
        while 0 <= low + sense <= PASS_POINTS - 2:
            next_gap, next_share = _squared_off_chord(way, low + sense, x, y)
            if not next_gap < gap:
                break
            low += sense
            gap, share = next_gap, next_share
    return float(way[PASS_FIRST]) + (low + share) * step


@kernel
def _last_pass_point_before(way: FloatArray, along: float) -> int:
    """The last of the pass's points of ``way`` no further than ``along``
    along the way's tangent (0 if none is): the pass heads within a quarter
    turn of the tangent, so its points' distances along it grow."""
    low = 0
    high = PASS_POINTS - 1
    while high - low > 1:
        middle = (low + high) // 2
        at = way[2] * (way[WAY_HEAD + middle] - way[0]) + way[3] * (
            way[WAY_HEAD + PASS_POINTS + middle] - way[1]
        )
        if at <= along:
            low = middle
        else:
            high = middle
    return low


@kernel
def _off_chord(way: FloatArray, i: int, x: float, y: float) -> tuple[float, float, float]:
    """The offset of (x, y) from the point of chord ``i`` of the pass of
    ``way`` nearest it, and that point's share along the chord; beyond the
    pass's ends the share goes on along its end chords (the offset the end
    point's)."""
    ax = way[WAY_HEAD + i]
    ay = way[WAY_HEAD + PASS_POINTS + i]
    ex = way[WAY_HEAD + i + 1] - ax
    ey = way[WAY_HEAD + PASS_POINTS + i + 1] - ay
    length2 = ex * ex + ey * ey
    share = 0.0
    if length2 > 0.0:
        share = ((x - ax) * ex + (y - ay) * ey) / length2
    kept = min(max(share, 0.0), 1.0)
    if not ((i == 0 and share < 0.0) or (i == PASS_POINTS - 2 and share > 1.0)):
        share = kept
    return ax + kept * ex - x, ay + kept * ey - y, share


@kernel
def _squared_off_chord(way: FloatArray, i: int, x: float, y: float) -> tuple[float, float]:
    """:func:`_off_chord`'s offset squared, and its share."""
    off_x, off_y, share = _off_chord(way, i, x, y)
    return off_x * off_x + off_y * off_y, share


@kernel
def on_another_stretch(
    way: FloatArray, cx: float, cy: float, x: float, y: float
) -> tuple[float, float, float]:
    """How far the aim (x, y) lies on another stretch of path than the pass
    of the way round ``way`` (the stretch about the path's point nearest
    the zone, WAY_COLUMNS): (share, across, side). ``share`` 0 within
    PASS_BAND of the pass, rising to 1 at twice that; ``across`` the aim's
    distance across the line of the way's tangent, and ``side`` the way
    round the zone centred at (cx, cy) by the side of it the aim is on, as the
    pass's own side is chosen (ways_round). Measured on the pass's line alone,
    any stretch heading the same way took the pass's detour: a lane 1.6 m
    from a pond made the pond's detour too, and a spiral's first loop cut
    0.33 m inside itself at a rock its second loop passes
    (docs/paper-notes.md, eq. (28), "Another stretch of the path past a
    zone")."""
    # The pass heads within a quarter turn of the way's tangent: its points'
    # distances along it grow, and only its chords within twice the band of
    # the aim's own distance along can be within twice the band of the aim.
    reach = 2.0 * PASS_BAND
    along = way[2] * (x - way[0]) + way[3] * (y - way[1])
    near = math.inf
    for i in range(_last_pass_point_before(way, along - reach), PASS_POINTS - 1):
        off_x, off_y, _ = _off_chord(way, i, x, y)
        near = min(near, math.hypot(off_x, off_y))
        ax = way[WAY_HEAD + i]
        ay = way[WAY_HEAD + PASS_POINTS + i]
        if way[2] * (ax - way[0]) + way[3] * (ay - way[1]) > along + reach:
            break  # this chord starts beyond the reach: so do the rest
    share = min(max(near / PASS_BAND - 1.0, 0.0), 1.0)
    across = -way[3] * (x - way[0]) + way[2] * (y - way[1])
    centre = -way[3] * (cx - way[0]) + way[2] * (cy - way[1])
    return share, across, 1.0 if across >= centre else -1.0


@inlined
def aim_round_zones(
    aim: FloatArray,
    row_kinds: IntArray,
    row_params: FloatArray,
    ways: FloatArray,
    look_ahead: float,
    margin: float,
    gap: float,
    lead: float = 0.0,
    turn_acceleration: float = math.inf,
    joined: float = 1.0,
) -> bool:
    """Move the point the tracked output aims at, ``aim[:2] + look_ahead *
    aim[2:]`` (x, y, unit tangent of the path), out of every row shrunk by
    ``look_ahead + margin`` (where ``keep_constraints`` lets the output go),
    its tangent kept; True when it moved. The aim stands ``gap`` beyond that
    bound (:func:`aim_gap`).

    The output's aim moves continuously as the path goes through a zone, so
    the tracking law is handed no jump at a zone's edge. A keep-out ellipse
    moves the aim sideways, across the path, on a ramp no steeper than
    RAMP_SLOPE (``_way_round``), by its way round (``ways``, of
    :func:`ways_round`): to the side decided once for the phase, measured
    in the frame of the path where it passes nearest the zone's centre (the
    aim's distance along that tangent, the move across applied across the
    path at the aim), and not at all where the path heads away from that
    tangent (a lap's far side): on a curve the path's own tangent line
    swings across the zone, and neither its side nor its distance from the
    zone holds for the stretch of path that passes it. The robot goes round,
    never stopping where two sides balance. A keep-out box or polygon goes
    round as well (``_polygon_round``), by the shorter way across where the
    path passes its centre nearest, and by the shorter way across at the aim
    where the path heads away from there. Other rows project the aim onto
    their edge (half-planes exactly, keep-in ellipses along the ray from the
    centre). Two passes settle an aim beyond two rows.

    A keep-out zone's move across the path is the one ``lead`` further
    along the path's tangent: the law follows the aim's move that late
    (paper.aim_lead). The projections onto other rows' edges are the aim's
    own: one taken ahead would hold the aim back along the path.

    Under a turn-rate acceleration limit (``turn_acceleration``, the share of
    it the law's turns follow, paper.turn_acceleration) a keep-out zone's
    ramp is the climb that limit lets the robot follow (``_way_round_eased``,
    a box's or polygon's ``_way_round_polygon_eased``), ``joined`` of the way
    from the ramp: 0 while the robot is joining its path, as the path's
    turns are previewed only once it is on it (paper.next_input).
    """
    grown = look_ahead + gap + margin
    x = aim[0] + look_ahead * aim[2]
    y = aim[1] + look_ahead * aim[3]
    start_x = x
    start_y = y
    moved = False
    for _ in range(2):
        for i in range(row_kinds.shape[0]):
            p = row_params[i]
            keep_out = row_kinds[i] == POLYGON_ROW or (row_kinds[i] == ELLIPSE_ROW and p[5] < 0.0)
            if keep_out:
                # Across the path, on a ramp: moving on from before the zone
                # without a kink steeper than RAMP_SLOPE, keeping its side.
                if row_kinds[i] == POLYGON_ROW:
                    reach, nx, ny = _polygon_round(
                        p, ways[i], grown, x, y, lead, aim, start_x, start_y,
                        turn_acceleration, joined,
                    )  # fmt: skip
                else:
                    way = ways[i]
                    reach = 0.0
                    nx = -aim[3] * way[4]
                    ny = aim[2] * way[4]
                    if way[4] != 0.0 and aim[2] * way[2] + aim[3] * way[3] > 0.0:
                        # the aim in the frame of the path where it passes the
                        # zone: its distance along (past that point, the
                        # path's own on a curve: along_the_pass), and the rows'
                        # moves across
                        along = way[2] * (x - way[0]) + way[3] * (y - way[1]) + lead
                        past = way[2] * (start_x - way[0]) + way[3] * (start_y - way[1])
                        if way[PASS_STEP] != 0.0 and past > 0.0:
                            along = along_the_pass(way, start_x, start_y)
                            along += way[2] * (x - start_x) + way[3] * (y - start_y) + lead
                        across = -aim[3] * (x - start_x) + aim[2] * (y - start_y)
                        at_x = way[0] + along * way[2] - across * way[3]
                        at_y = way[1] + along * way[3] + across * way[2]
                        reach, _, _ = _way_round(p, grown, at_x, at_y, way[2], way[3], way[4])
                        if turn_acceleration != math.inf and joined > 0.0:
                            # the aim's distance past where the path rests
                            room = along + way[6]
                            eased = _way_round_eased(
                                p, grown, at_x, at_y, way, way[4], turn_acceleration, room
                            )
                            if eased >= 0.0:
                                reach += joined * (eased - reach)
                        # (only where the pass's own ramp reaches: elsewhere
                        # no stretch is moved, and the pass costs nothing)
                        share, off, side = 0.0, 0.0, way[4]
                        if reach > 0.0:
                            share, off, side = on_another_stretch(way, p[0], p[1], start_x, start_y)
                        if share > 0.0:
                            # another stretch: round by its own side, from
                            # where it is across from the pass
                            off_x = at_x - off * way[3]
                            off_y = at_y + off * way[2]
                            own, _, _ = _way_round(p, grown, off_x, off_y, way[2], way[3], side)
                            reach = (1.0 - share) * reach + share * own * side * way[4]
                if reach != 0.0:  # another stretch's own side is negative
                    moved = True
                    x += reach * nx
                    y += reach * ny
                continue
            value, gx, gy = row_value_with_margin(row_kinds[i], p, grown, x, y)
            if value <= 0.0:
                continue
            moved = True
            if row_kinds[i] != ELLIPSE_ROW:
                x -= value * gx
                y -= value * gy
            else:
                scale = 1.0 / math.sqrt(max(value + 1.0, 1e-300))
                x = p[0] + scale * (x - p[0])
                y = p[1] + scale * (y - p[1])
    if moved:
        aim[0] = x - look_ahead * aim[2]
        aim[1] = y - look_ahead * aim[3]
    return moved


@kernel
def zone_between(
    kind: int, p: FloatArray, margin: float, ox: float, oy: float, ax: float, ay: float
) -> bool:
    """Whether the keep-out row ``p`` grown by ``margin`` lies across the
    straight way from (ox, oy) to (ax, ay): the way enters it after its start
    and leaves it before its end. An ellipse exactly (the least of its
    quadratic along the way); a polygon with its edges moved out by
    ``margin`` (its corners square, a little more than grown)."""
    dx = ax - ox
    dy = ay - oy
    if kind == POLYGON_ROW:
        enters = 0.0
        leaves = 1.0
        for i in range(int(p[0])):
            k = HEADER + PER_VERTEX * i
            inside = p[k + 2] * (p[k] - ox) + p[k + 3] * (p[k + 1] - oy) + margin
            rate = p[k + 2] * dx + p[k + 3] * dy
            if rate == 0.0:
                if inside < 0.0:
                    return False
            elif rate > 0.0:
                leaves = min(leaves, inside / rate)
            else:
                enters = max(enters, inside / rate)
        return 0.0 < enters < leaves < 1.0
    a = p[2] + margin
    b = p[3] + margin
    cos_phi = math.cos(p[4])
    sin_phi = math.sin(p[4])
    u0 = (cos_phi * (ox - p[0]) + sin_phi * (oy - p[1])) / a
    w0 = (-sin_phi * (ox - p[0]) + cos_phi * (oy - p[1])) / b
    du = (cos_phi * dx + sin_phi * dy) / a
    dw = (-sin_phi * dx + cos_phi * dy) / b
    rate2 = du * du + dw * dw
    if rate2 == 0.0 or u0 * u0 + w0 * w0 <= 1.0:
        return False
    u1 = u0 + du
    w1 = w0 + dw
    if u1 * u1 + w1 * w1 <= 1.0:
        return False
    nearest = -(u0 * du + w0 * dw) / rate2
    if not 0.0 < nearest < 1.0:
        return False
    un = u0 + nearest * du
    wn = w0 + nearest * dw
    return bool(un * un + wn * wn < 1.0)


@kernel
def _way_blocked(
    aim_now: FloatArray,
    ox: float,
    oy: float,
    row_kinds: IntArray,
    row_params: FloatArray,
    look_ahead: float,
    margin: float,
) -> bool:
    """Whether a keep-out row grown by ``margin`` lies across the straight way
    from the output (ox, oy) to the point it aims at, ``aim_now[:2] +
    look_ahead * aim_now[2:4]``."""
    ax = aim_now[0] + look_ahead * aim_now[2]
    ay = aim_now[1] + look_ahead * aim_now[3]
    for i in range(row_kinds.shape[0]):
        p = row_params[i]
        keep_out = row_kinds[i] == POLYGON_ROW or (row_kinds[i] == ELLIPSE_ROW and p[5] < 0.0)
        if keep_out and zone_between(row_kinds[i], p, margin, ox, oy, ax, ay):
            return True
    return False


@inlined
def aimed_from_its_place(
    aim_now: FloatArray,
    aim: FloatArray,
    path_x: float,
    path_y: float,
    estimate: FloatArray,
    row_kinds: IntArray,
    row_params: FloatArray,
    ways: FloatArray,
    look_ahead: float,
    margin: float,
    gap: float,
    lead: float,
) -> bool:
    """Where a keep-out zone lies across the straight way from the tracked
    output to its aim (``aim_now``, moved round the zones from the path's
    point ``path_x``, ``path_y``) while the robot is behind that point, aim
    from the robot's own place on the path's line instead, moved round the
    zones as an aim there would be (:func:`aim_round_zones`), the path's
    step (``aim`` - ``aim_now``) fed forward from there. True when it did.
    ``next_input`` asks once the robot has stopped, and again each sample
    until the way is clear: a robot still moving goes round as before.

    The aim moves round a zone as the path passes it, as if the robot were
    with it. A robot that fell behind (it stopped at the zone's edge under
    its acceleration limits, or started just before the zone) was left
    aiming through the zone: every motion the filter allows leads away from
    the aim, and the robot stood at the edge for good (a box 0.2 m ahead of
    a robot at rest: 30 s at its edge, its reference 30 m on;
    docs/paper-notes.md, eq. (28), "An aim beyond a zone")."""
    ox = estimate[0] + look_ahead * math.cos(estimate[2])
    oy = estimate[1] + look_ahead * math.sin(estimate[2])
    tx = aim_now[2]
    ty = aim_now[3]
    along = tx * (estimate[0] - path_x) + ty * (estimate[1] - path_y)
    if along >= 0.0 or not _way_blocked(aim_now, ox, oy, row_kinds, row_params, look_ahead, margin):
        return False
    step_x = aim[0] - aim_now[0]
    step_y = aim[1] - aim_now[1]
    aim_now[0] = path_x + along * tx
    aim_now[1] = path_y + along * ty
    aim_round_zones(aim_now, row_kinds, row_params, ways, look_ahead, margin, gap, lead)
    aim[0] = aim_now[0] + step_x
    aim[1] = aim_now[1] + step_y
    return True
