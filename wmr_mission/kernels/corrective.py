"""Corrective control, eqs. (22)-(28), and the constraint rows it acts on.

For j violated (or tracked) constraints with Jacobian ``D`` (j x 3) at the
predicted state and the input Jacobian ``B`` (3 x 2), eqs. (27)/(28) give

    du = Rw^-1 (D B)^T (D B Rw^-1 (D B)^T)^-1 eta,   Rw = B^T W B + M,

the smallest change of the input (in the ``Rw`` norm of eq. (22)) that makes
the linearised constraint ``G(x) + D B du = E`` of eq. (26) hold exactly.

Near singularity (robot at rest, a row the inputs can hardly move in one
sample) the exact answer asks for unbounded inputs. When it asks for more than
the span of the inputs (|dv| > 2 v_max or |domega| > 2 omega_max, from one
limit to the other), or ``S = D B Rw^-1 (D B)^T`` is singular to rounding, the
inverse of ``S`` becomes a pseudo-inverse truncated to the inputs: along each
eigenvector of ``S`` the change that meets that part of ``eta`` is kept when
it fits within the span and scaled down to it otherwise; eigenvalues below
``REGULARISATION`` times the largest are dropped. A reachable part is met
exactly, an unreachable part as far as the inputs allow, and
``|dv| <= 2 count v_max``, ``|domega| <= 2 count omega_max``.
"""

from __future__ import annotations

import math

import numpy as np

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.kernels.convex import polygon_distance
from wmr_mission.kernels.jit import kernel
from wmr_mission.kernels.model import hypot

# Eigenvalues of S below this fraction of the largest are rounding, not reach.
REGULARISATION = 1e-12
# Kinds of constraint rows (wmr_mission.geometry.regions builds them).
ELLIPSE_ROW = 0
HALF_PLANE_ROW = 1
POLYGON_ROW = 2  # keep out of a convex polygon (wmr_mission.kernels.convex)


@kernel
def _within_inputs(dv: float, dw: float, limits: FloatArray) -> tuple[float, float]:
    """(dv, dw) scaled down, direction kept, to at most the span of the inputs,
    |dv| <= 2 limits[0], |dw| <= 2 limits[1]: from one limit to the other."""
    scale = 0.5 * max(abs(dv) / limits[0], abs(dw) / limits[1])
    if scale > 1.0:
        return dv / scale, dw / scale
    return dv, dw


@kernel
def corrective_input(
    d: FloatArray,
    eta: FloatArray,
    count: int,
    b: FloatArray,
    w: FloatArray,
    m: FloatArray,
    limits: FloatArray,
) -> tuple[float, float]:
    """Eq. (27)/(28) for ``count`` (1 or 2) rows of ``d`` (rows x 3) and ``eta``.

    ``w`` (3,) and ``m`` (2,) are the diagonals of W and M of eq. (22);
    ``limits[0:2]`` the input range that bounds the change.
    """
    # Rw = B^T W B + M (2x2, symmetric), and its inverse.
    r00 = m[0] + w[0] * b[0, 0] * b[0, 0] + w[1] * b[1, 0] * b[1, 0] + w[2] * b[2, 0] * b[2, 0]
    r01 = w[0] * b[0, 0] * b[0, 1] + w[1] * b[1, 0] * b[1, 1] + w[2] * b[2, 0] * b[2, 1]
    r11 = m[1] + w[0] * b[0, 1] * b[0, 1] + w[1] * b[1, 1] * b[1, 1] + w[2] * b[2, 1] * b[2, 1]
    det = r00 * r11 - r01 * r01
    i00 = r11 / det
    i01 = -r01 / det
    i11 = r00 / det
    # DB rows (j x 2) and Rw^-1 (DB)^T columns.
    g00 = d[0, 0] * b[0, 0] + d[0, 1] * b[1, 0] + d[0, 2] * b[2, 0]
    g01 = d[0, 0] * b[0, 1] + d[0, 1] * b[1, 1] + d[0, 2] * b[2, 1]
    h00 = i00 * g00 + i01 * g01
    h10 = i01 * g00 + i11 * g01
    if count == 1:
        s = g00 * h00 + g01 * h10
        if not s > 0.0:
            return 0.0, 0.0
        lam = eta[0] / s
        return _within_inputs(h00 * lam, h10 * lam, limits)
    g10 = d[1, 0] * b[0, 0] + d[1, 1] * b[1, 0] + d[1, 2] * b[2, 0]
    g11 = d[1, 0] * b[0, 1] + d[1, 1] * b[1, 1] + d[1, 2] * b[2, 1]
    h01 = i00 * g10 + i01 * g11
    h11 = i01 * g10 + i11 * g11
    # S = DB Rw^-1 DB^T (2x2, symmetric).
    s00 = g00 * h00 + g01 * h10
    s01 = g00 * h01 + g01 * h11
    s11 = g10 * h01 + g11 * h11
    mean = 0.5 * (s00 + s11)
    radius = hypot(0.5 * (s00 - s11), s01)
    largest = mean + radius
    if not largest > 0.0:
        return 0.0, 0.0
    if mean - radius > REGULARISATION * largest:
        # Well posed: the exact answer, kept when it is within the inputs' span.
        sdet = s00 * s11 - s01 * s01
        lam0 = (s11 * eta[0] - s01 * eta[1]) / sdet
        lam1 = (s00 * eta[1] - s01 * eta[0]) / sdet
        dv = h00 * lam0 + h01 * lam1
        dw = h10 * lam0 + h11 * lam1
        if abs(dv) <= 2.0 * limits[0] and abs(dw) <= 2.0 * limits[1]:
            return dv, dw
    # Truncated: along each eigenvector (cos a, sin a), (-sin a, cos a) of S,
    # the change that meets that part of eta, within the inputs' span.
    angle = 0.5 * math.atan2(2.0 * s01, s00 - s11)
    ca = math.cos(angle)
    sa = math.sin(angle)
    dv = 0.0
    dw = 0.0
    for i in range(2):
        e0, e1, value = (ca, sa, largest) if i == 0 else (-sa, ca, mean - radius)
        if value <= REGULARISATION * largest:
            continue  # below rounding: nothing reachable this way
        lam = (e0 * eta[0] + e1 * eta[1]) / value
        part_v, part_w = _within_inputs(
            (h00 * e0 + h01 * e1) * lam, (h10 * e0 + h11 * e1) * lam, limits
        )
        dv += part_v
        dw += part_w
    return dv, dw


@kernel
def kept_row_slot(value: float, count: int, eta: FloatArray) -> tuple[int, int]:
    """Where a violated row (``value > 0``) goes among the two rows eq. (28) keeps
    (two inputs meet at most two), and the new count of kept rows. ``eta`` holds
    the kept rows' ``-value``; slot -1: this row is no more violated than both.
    """
    if count < 2:
        return count, count + 1
    slot = 0 if eta[0] > eta[1] else 1  # the less violated of the two kept
    if -value >= eta[slot]:
        return -1, count
    return slot, count


@kernel
def row_value_with_margin(
    kind: int, p: FloatArray, margin: float, x: float, y: float
) -> tuple[float, float, float]:
    """:func:`row_value` of the row with its allowed side shrunk by ``margin``.

    A point that keeps the shrunk row keeps the row itself with every point
    within ``margin`` of it: exactly for half-planes and circles (offset, or
    radius -+ margin); for an ellipse the semi-axes move by ``margin``, which
    is exact on its axes and off by ``O(margin^2 / radius of curvature)``
    elsewhere. (A polygon row: :func:`polygon_value`.)
    """
    if kind != ELLIPSE_ROW:
        return p[0] * x + p[1] * y - (p[2] - margin), p[0], p[1]
    sign = p[5]
    a = max(p[2] - sign * margin, 1e-9)
    b = max(p[3] - sign * margin, 1e-9)
    cos_phi = math.cos(p[4])
    sin_phi = math.sin(p[4])
    dx = x - p[0]
    dy = y - p[1]
    u = cos_phi * dx + sin_phi * dy
    w = -sin_phi * dx + cos_phi * dy
    ia2 = 1.0 / (a * a)
    ib2 = 1.0 / (b * b)
    value = sign * (u * u * ia2 + w * w * ib2 - 1.0)
    gu = 2.0 * u * ia2
    gw = 2.0 * w * ib2
    return value, sign * (gu * cos_phi - gw * sin_phi), sign * (gu * sin_phi + gw * cos_phi)


@kernel
def polygon_value(p: FloatArray, margin: float, x: float, y: float) -> tuple[float, float, float]:
    """:func:`row_value_with_margin` of a polygon row: ``margin`` minus the
    signed distance to the polygon, exact. Its callers branch to it on the
    row's kind themselves: a polygon branch inside row_value_with_margin cost
    missions without polygons 15 % of the step (docs/performance.md)."""
    distance, gx, gy = polygon_distance(p, x, y)
    return margin - distance, -gx, -gy


@kernel
def row_value(kind: int, p: FloatArray, x: float, y: float) -> tuple[float, float, float]:
    """Value ``c`` of one constraint row (satisfied when ``c <= 0``) and its gradient.

    Rows are described in docs/architecture.md; an ellipse row with sign +1 is
    eq. (33) written as ``G(x) - 1 <= 0``.
    """
    return row_value_with_margin(kind, p, 0.0, x, y)


@kernel
def max_row_value(kinds: IntArray, params: FloatArray, x: float, y: float) -> float:
    """Largest row value at (x, y): > 0 means some constraint is violated."""
    worst = -math.inf
    for i in range(kinds.shape[0]):
        if kinds[i] == POLYGON_ROW:
            value, _, _ = polygon_value(params[i], 0.0, x, y)
        else:
            value, _, _ = row_value(kinds[i], params[i], x, y)
        worst = max(worst, value)
    return worst


def corrective_input_array(
    d: FloatArray,
    eta: FloatArray,
    b: FloatArray,
    w: FloatArray,
    m: FloatArray,
    input_range: tuple[float, float] = (math.inf, math.inf),
) -> FloatArray:
    """Array form of :func:`corrective_input` for tests and notebooks;
    ``input_range`` = (|v|, |omega|) limits (none by default)."""
    rows = np.zeros((2, 3))
    rows[: d.shape[0]] = d
    values = np.zeros(2)
    values[: eta.shape[0]] = eta
    limits = np.array([*input_range, math.inf, math.inf])
    return np.array(corrective_input(rows, values, d.shape[0], b, w, m, limits))
