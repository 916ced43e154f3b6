"""Corrective control, eqs. (22)-(28), and the constraint rows it acts on.

For j violated (or tracked) constraints with Jacobian ``D`` (j x 3) at the
predicted state and the input Jacobian ``B`` (3 x 2), eqs. (27)/(28) give

    du = Rw^-1 (D B)^T (D B Rw^-1 (D B)^T)^-1 eta,   Rw = B^T W B + M,

the smallest change of the input (in the ``Rw`` norm of eq. (22)) that makes
the linearised constraint ``G(x) + D B du = E`` of eq. (26) hold exactly.

When ``D B Rw^-1 (D B)^T`` is singular or nearly so (robot at rest, or a
constraint the inputs cannot move in one sample), its inverse is replaced by
``(S + mu I)^-1`` with ``mu = REGULARISATION * trace(S)``: the Tikhonov
(least-squares) answer. It meets the reachable part of ``eta`` and ignores the
unreachable part instead of returning NaN or an unbounded input.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from wmr_mission._jit import kernel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

REGULARISATION = 1e-12
ELLIPSE = 0
HALF_PLANE = 1


@kernel
def corrective_input(
    d: FloatArray, eta: FloatArray, count: int, b: FloatArray, w: FloatArray, m: FloatArray
) -> tuple[float, float]:
    """Eq. (27)/(28) for ``count`` (1 or 2) rows of ``d`` (rows x 3) and ``eta``.

    ``w`` (3,) and ``m`` (2,) are the diagonals of W and M of eq. (22).
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
        if s <= 1e-300:
            return 0.0, 0.0
        lam = eta[0] / (s + REGULARISATION * s)
        return h00 * lam, h10 * lam
    g10 = d[1, 0] * b[0, 0] + d[1, 1] * b[1, 0] + d[1, 2] * b[2, 0]
    g11 = d[1, 0] * b[0, 1] + d[1, 1] * b[1, 1] + d[1, 2] * b[2, 1]
    h01 = i00 * g10 + i01 * g11
    h11 = i01 * g10 + i11 * g11
    # S = DB Rw^-1 DB^T (2x2) + mu I
    s00 = g00 * h00 + g01 * h10
    s01 = g00 * h01 + g01 * h11
    s11 = g10 * h01 + g11 * h11
    if s00 + s11 <= 1e-300:
        return 0.0, 0.0
    mu = REGULARISATION * (s00 + s11)
    s00 += mu
    s11 += mu
    sdet = s00 * s11 - s01 * s01
    lam0 = (s11 * eta[0] - s01 * eta[1]) / sdet
    lam1 = (s00 * eta[1] - s01 * eta[0]) / sdet
    return h00 * lam0 + h01 * lam1, h10 * lam0 + h11 * lam1


@kernel
def row_value(kind: int, p: FloatArray, x: float, y: float) -> tuple[float, float, float]:
    """Value ``c`` of one constraint row (satisfied when ``c <= 0``) and its gradient.

    Rows are described in docs/architecture.md; an ellipse row with sign +1 is
    eq. (33) written as ``G(x) - 1 <= 0``.
    """
    if kind == ELLIPSE:
        cos_phi = math.cos(p[4])
        sin_phi = math.sin(p[4])
        dx = x - p[0]
        dy = y - p[1]
        u = cos_phi * dx + sin_phi * dy
        w = -sin_phi * dx + cos_phi * dy
        ia2 = 1.0 / (p[2] * p[2])
        ib2 = 1.0 / (p[3] * p[3])
        sign = p[5]
        value = sign * (u * u * ia2 + w * w * ib2 - 1.0)
        gu = 2.0 * u * ia2
        gw = 2.0 * w * ib2
        return value, sign * (gu * cos_phi - gw * sin_phi), sign * (gu * sin_phi + gw * cos_phi)
    return p[0] * x + p[1] * y - p[2], p[0], p[1]


@kernel
def max_row_value(kinds: IntArray, params: FloatArray, x: float, y: float) -> float:
    """Largest row value at (x, y): > 0 means some constraint is violated."""
    worst = -math.inf
    for i in range(kinds.shape[0]):
        value, _, _ = row_value(kinds[i], params[i], x, y)
        worst = max(worst, value)
    return worst


def corrective_input_array(
    d: FloatArray, eta: FloatArray, b: FloatArray, w: FloatArray, m: FloatArray
) -> FloatArray:
    """Array form of :func:`corrective_input` for tests and notebooks."""
    rows = np.zeros((2, 3))
    rows[: d.shape[0]] = d
    values = np.zeros(2)
    values[: eta.shape[0]] = eta
    return np.array(corrective_input(rows, values, d.shape[0], b, w, m))
