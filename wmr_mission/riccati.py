"""Eqs. (20)-(21): the Riccati solution ``pi`` and the gain ``T`` of the
gain-scheduled regulator, re-solved at every sample for the linearisation
``(A_{k-1}, B_{k-1})``.

Eq. (21), ``pi = Q + A^T (pi^-1 + B R^-1 B^T)^-1 A``, is the discrete algebraic
Riccati equation in its inverse form; by the matrix inversion lemma it equals
the usual ``pi = Q + A^T pi A - A^T pi B (R + B^T pi B)^-1 B^T pi A``, and the
gain of eq. (20), ``T = R^-1 B^T (pi^-1 + B R^-1 B^T)^-1 A``, equals
``(R + B^T pi B)^-1 B^T pi A``. The second forms need no inverse of ``pi``.

We solve it with the structure-preserving doubling algorithm: quadratic
convergence whatever the start, so about a dozen 3x3 steps where the
fixed-point iteration of eq. (21) needs ~800 (closed-loop spectral radius
~0.99 at dt = 0.01), and no scipy call with its fixed cost in the loop.

At rest (v = 0) the pair (A, B) is not stabilisable: the lateral direction is
unreachable and eq. (21) has no solution (scipy fails or returns a non-solution
of size 1e8). The gain has finite limits as v -> 0 from either side, but they
differ in the sign of the lateral-error gain (steering sense reverses with the
direction of travel). At rest we return the solution on the reachable subspace
(longitudinal and heading; the unreachable lateral direction unweighted), which
is the mean of the two one-sided limits, and for 0 < |v| < ``MIN_SPEED`` blend
linearly to the gain at ``+-MIN_SPEED``, so the gain is continuous in v.
See :func:`wmr_mission.control.scheduled_gain`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wmr_mission._jit import kernel

FloatArray = NDArray[np.float64]

MIN_SPEED = 1e-3  # [m/s] below it the gain is blended with the at-rest gain
TOLERANCE = 1e-14  # relative change of the doubling iterate that ends the iteration
MAX_DOUBLINGS = 60


@kernel
def _inv3(m: FloatArray, out: FloatArray) -> None:
    a, b, c = m[0, 0], m[0, 1], m[0, 2]
    d, e, f = m[1, 0], m[1, 1], m[1, 2]
    g, h, i = m[2, 0], m[2, 1], m[2, 2]
    c00 = e * i - f * h
    c01 = f * g - d * i
    c02 = d * h - e * g
    inv_det = 1.0 / (a * c00 + b * c01 + c * c02)
    out[0, 0] = c00 * inv_det
    out[1, 0] = c01 * inv_det
    out[2, 0] = c02 * inv_det
    out[0, 1] = (c * h - b * i) * inv_det
    out[1, 1] = (a * i - c * g) * inv_det
    out[2, 1] = (b * g - a * h) * inv_det
    out[0, 2] = (b * f - c * e) * inv_det
    out[1, 2] = (c * d - a * f) * inv_det
    out[2, 2] = (a * e - b * d) * inv_det


@kernel
def _mul3(a: FloatArray, b: FloatArray, out: FloatArray) -> None:
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@kernel
def _mul3_at(a: FloatArray, b: FloatArray, out: FloatArray) -> None:
    """out = a^T b."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[0, i] * b[0, j] + a[1, i] * b[1, j] + a[2, i] * b[2, j]


@kernel
def _mul3_bt(a: FloatArray, b: FloatArray, out: FloatArray) -> None:
    """out = a b^T."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]


@kernel
def solve_riccati(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, pi: FloatArray, work: FloatArray
) -> int:
    """Solve eq. (21) for 3 states and 2 inputs by doubling; write ``pi``.

    ``q`` (3, 3) is Q-hat and ``r`` (2,) the diagonal of R-hat of eq. (17);
    ``work`` is scratch of shape (8, 3, 3). Returns the number of doublings, or
    -1 when the iteration did not converge (``pi`` then holds the last iterate).
    """
    ak = work[0]
    gk = work[1]
    hk = work[2]
    wk = work[3]
    wi = work[4]
    t1 = work[5]
    t2 = work[6]
    t3 = work[7]
    for i in range(3):
        for j in range(3):
            ak[i, j] = a[i, j]
            # G_0 = B R^-1 B^T, H_0 = Q.
            gk[i, j] = b[i, 0] * b[j, 0] / r[0] + b[i, 1] * b[j, 1] / r[1]
            hk[i, j] = q[i, j]
    for iteration in range(1, MAX_DOUBLINGS + 1):
        # W = I + G H; everything below uses W^-1.
        _mul3(gk, hk, wk)
        for i in range(3):
            wk[i, i] += 1.0
        _inv3(wk, wi)
        # t1 = W^-1 A_k
        _mul3(wi, ak, t1)
        # H_{k+1} = H_k + A_k^T H_k W^-1 A_k
        _mul3(hk, t1, t2)
        _mul3_at(ak, t2, t3)
        change = 0.0
        size = 0.0
        for i in range(3):
            for j in range(3):
                new = hk[i, j] + 0.5 * (t3[i, j] + t3[j, i])
                change = max(change, abs(new - hk[i, j]))
                size = max(size, abs(new))
                hk[i, j] = new
        # G_{k+1} = G_k + A_k W^-1 G_k A_k^T
        _mul3(wi, gk, t2)
        _mul3_bt(t2, ak, t3)
        _mul3(ak, t3, t2)
        for i in range(3):
            for j in range(3):
                gk[i, j] = gk[i, j] + 0.5 * (t2[i, j] + t2[j, i])
        # A_{k+1} = A_k W^-1 A_k
        _mul3(ak, t1, t2)
        for i in range(3):
            for j in range(3):
                ak[i, j] = t2[i, j]
        if change <= TOLERANCE * size:
            for i in range(3):
                for j in range(3):
                    pi[i, j] = hk[i, j]
            return iteration
    for i in range(3):
        for j in range(3):
            pi[i, j] = hk[i, j]
    return -1


@kernel
def regulator_gain(
    a: FloatArray, b: FloatArray, r: FloatArray, pi: FloatArray, gain: FloatArray
) -> None:
    """Eq. (20): T = (R + B^T pi B)^-1 B^T pi A, written into ``gain`` (2x3)."""
    # pb = pi B (3x2)
    pb00 = pi[0, 0] * b[0, 0] + pi[0, 1] * b[1, 0] + pi[0, 2] * b[2, 0]
    pb10 = pi[1, 0] * b[0, 0] + pi[1, 1] * b[1, 0] + pi[1, 2] * b[2, 0]
    pb20 = pi[2, 0] * b[0, 0] + pi[2, 1] * b[1, 0] + pi[2, 2] * b[2, 0]
    pb01 = pi[0, 0] * b[0, 1] + pi[0, 1] * b[1, 1] + pi[0, 2] * b[2, 1]
    pb11 = pi[1, 0] * b[0, 1] + pi[1, 1] * b[1, 1] + pi[1, 2] * b[2, 1]
    pb21 = pi[2, 0] * b[0, 1] + pi[2, 1] * b[1, 1] + pi[2, 2] * b[2, 1]
    # S = R + B^T pi B (2x2, symmetric)
    s00 = r[0] + b[0, 0] * pb00 + b[1, 0] * pb10 + b[2, 0] * pb20
    s01 = b[0, 0] * pb01 + b[1, 0] * pb11 + b[2, 0] * pb21
    s11 = r[1] + b[0, 1] * pb01 + b[1, 1] * pb11 + b[2, 1] * pb21
    det = s00 * s11 - s01 * s01
    i00 = s11 / det
    i01 = -s01 / det
    i11 = s00 / det
    for j in range(3):
        # (B^T pi A)[:, j] = pb^T A[:, j]
        m0 = pb00 * a[0, j] + pb10 * a[1, j] + pb20 * a[2, j]
        m1 = pb01 * a[0, j] + pb11 * a[1, j] + pb21 * a[2, j]
        gain[0, j] = i00 * m0 + i01 * m1
        gain[1, j] = i01 * m0 + i11 * m1


def dlqr(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray
) -> tuple[FloatArray, FloatArray, int]:
    """Array form for tests and notebooks: (T, pi, doublings). ``q`` is the
    diagonal of Q-hat or the whole matrix."""
    pi = np.zeros((3, 3))
    gain = np.zeros((2, 3))
    work = np.zeros((8, 3, 3))
    doublings = solve_riccati(
        np.ascontiguousarray(a, dtype=np.float64),
        np.ascontiguousarray(b, dtype=np.float64),
        np.ascontiguousarray(np.diag(q) if np.ndim(q) == 1 else q, dtype=np.float64),
        np.asarray(r, dtype=np.float64),
        pi,
        work,
    )
    regulator_gain(
        np.ascontiguousarray(a, dtype=np.float64),
        np.ascontiguousarray(b, dtype=np.float64),
        np.asarray(r, dtype=np.float64),
        pi,
        gain,
    )
    return gain, pi, doublings
