"""Eqs. (20)-(21): the Riccati solution ``pi`` and the gain ``T`` of the
gain-scheduled regulator, re-solved at every sample for the linearisation
``(A_{k-1}, B_{k-1})``.

Eq. (21), ``pi = Q + A^T (pi^-1 + B R^-1 B^T)^-1 A``, is the discrete algebraic
Riccati equation in its inverse form; by the matrix inversion lemma it equals
the usual ``pi = Q + A^T pi A - A^T pi B (R + B^T pi B)^-1 B^T pi A``, and the
gain of eq. (20), ``T = R^-1 B^T (pi^-1 + B R^-1 B^T)^-1 A``, equals
``(R + B^T pi B)^-1 B^T pi A``. The second forms need no inverse of ``pi``.

Three solvers, chosen per sample by :func:`wmr_mission.controllers.paper.scheduled_gain`
(docs/paper-notes.md gives the evidence):

* at rest, :func:`scalar_solution`: eq. (21) splits into scalar equations;
* moving, :func:`newton_riccati`: Newton steps from the previous samples'
  solution, two per sample on a smooth run;
* otherwise :func:`solve_riccati`, the structure-preserving doubling:
  quadratic convergence whatever the start, so about a dozen 3x3 steps where
  the fixed-point iteration of eq. (21) needs ~800 (closed-loop spectral
  radius ~0.99 at dt = 0.01).

None calls scipy, with its fixed cost, in the loop.

At rest (v = 0) the pair (A, B) is not stabilisable: the lateral direction is
unreachable and eq. (21) has no solution (scipy fails or returns a non-solution
of size 1e8). The gain has finite limits as v -> 0 from either side, but they
differ in the sign of the lateral-error gain (steering sense reverses with the
direction of travel). At rest we return the solution on the reachable subspace
(longitudinal and heading; the unreachable lateral direction unweighted), which
is the mean of the two one-sided limits, and for 0 < |v| < ``MIN_SPEED`` blend
linearly to the gain at ``+-MIN_SPEED``, so the gain is continuous in v.
See :func:`wmr_mission.controllers.paper.scheduled_gain`.
"""

from __future__ import annotations

import math

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import kernel

MIN_SPEED = 1e-3  # [m/s] below it the gain is blended with the at-rest gain
TOLERANCE = 1e-14  # relative change of the doubling iterate that ends the iteration
MAX_DOUBLINGS = 60
# Newton's method from a warm start (:func:`newton_riccati`) gives up, and the
# caller solves by doubling, after this many steps or when a step changes
# the solution by more than NEWTON_REACH of its size: the warm start was too
# far to trust.
NEWTON_STEPS = 6
NEWTON_REACH = 0.5


# A 3x3 matrix as a tuple of its 9 entries, row by row: numba keeps it in
# registers, and plain Python reads it far faster than a numpy array.
Mat3 = tuple[float, float, float, float, float, float, float, float, float]


@kernel
def _mul3(a: Mat3, b: Mat3) -> Mat3:
    """a b, written out: (a b)[i, j] = a[i, 0] b[0, j] + a[i, 1] b[1, j] + a[i, 2] b[2, j]."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    return (
        a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
        a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
        a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8,
    )  # fmt: skip


@kernel
def _transpose(a: Mat3) -> Mat3:
    return (a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8])


@kernel
def _inv3(m: Mat3) -> Mat3:
    a, b, c, d, e, f, g, h, i = m
    c00 = e * i - f * h
    c01 = f * g - d * i
    c02 = d * h - e * g
    inv_det = 1.0 / (a * c00 + b * c01 + c * c02)
    return (
        c00 * inv_det, (c * h - b * i) * inv_det, (b * f - c * e) * inv_det,
        c01 * inv_det, (a * i - c * g) * inv_det, (c * d - a * f) * inv_det,
        c02 * inv_det, (b * g - a * h) * inv_det, (a * e - b * d) * inv_det,
    )  # fmt: skip


@kernel
def _symmetric_step(m: Mat3, t: Mat3) -> Mat3:
    """m + (t + t^T) / 2."""
    return (
        m[0] + 0.5 * (t[0] + t[0]), m[1] + 0.5 * (t[1] + t[3]), m[2] + 0.5 * (t[2] + t[6]),
        m[3] + 0.5 * (t[3] + t[1]), m[4] + 0.5 * (t[4] + t[4]), m[5] + 0.5 * (t[5] + t[7]),
        m[6] + 0.5 * (t[6] + t[2]), m[7] + 0.5 * (t[7] + t[5]), m[8] + 0.5 * (t[8] + t[8]),
    )  # fmt: skip


@kernel
def _change(new: Mat3, old: Mat3) -> tuple[float, float]:
    """The largest entry of ``new - old`` and of ``new``, in magnitude."""
    change = 0.0
    size = 0.0
    for i in range(9):
        change = max(change, abs(new[i] - old[i]))
        size = max(size, abs(new[i]))
    return change, size


@kernel
def solve_riccati(a: Mat3, g: Mat3, q: Mat3) -> tuple[Mat3, int]:
    """Solve eq. (21) for 3 states by doubling: ``(pi, doublings)``.

    ``g`` is ``B R^-1 B^T`` and ``q`` Q-hat of eq. (17). ``doublings`` is -1
    when the iteration did not converge (``pi`` is then the last iterate).
    """
    ak = a
    gk = g
    hk = q
    for iteration in range(1, MAX_DOUBLINGS + 1):
        # W = I + G H; everything below uses W^-1.
        w = _mul3(gk, hk)
        wi = _inv3((w[0] + 1.0, w[1], w[2], w[3], w[4] + 1.0, w[5], w[6], w[7], w[8] + 1.0))
        t1 = _mul3(wi, ak)
        # H_{k+1} = H_k + A_k^T H_k W^-1 A_k
        new = _symmetric_step(hk, _mul3(_transpose(ak), _mul3(hk, t1)))
        change, size = _change(new, hk)
        hk = new
        # G_{k+1} = G_k + A_k W^-1 G_k A_k^T
        gk = _symmetric_step(gk, _mul3(ak, _mul3(_mul3(wi, gk), _transpose(ak))))
        # A_{k+1} = A_k W^-1 A_k
        ak = _mul3(ak, t1)
        if change <= TOLERANCE * size:
            return hk, iteration
    return hk, -1


@kernel
def scalar_solution(q: float, b: float, r: float) -> float:
    """Eq. (21) for one state with a = 1: ``p = q + p - p^2 b^2 / (r + b^2 p)``,
    i.e. ``b^2 p^2 - q b^2 p - q r = 0``; its root ``p >= 0``."""
    return 0.5 * q + math.sqrt(0.25 * q * q + q * r / (b * b))


Row6 = tuple[float, float, float, float, float, float]


@kernel
def _symmetric_product(u0: float, u1: float, u2: float, w0: float, w1: float, w2: float) -> Row6:
    """The coefficients of ``u^T X w + w^T X u`` (halved on the diagonal) on
    the unknowns X00, X01, X02, X11, X12, X22 of a symmetric X."""
    return (u0 * w0, u0 * w1 + u1 * w0, u0 * w2 + u2 * w0, u1 * w1, u1 * w2 + u2 * w1, u2 * w2)


@kernel
def _row(system: FloatArray, at: int, unit: Row6, other: Row6, rhs: float) -> None:
    system[at] = unit[0] + other[0]
    system[at + 1] = unit[1] + other[1]
    system[at + 2] = unit[2] + other[2]
    system[at + 3] = unit[3] + other[3]
    system[at + 4] = unit[4] + other[4]
    system[at + 5] = unit[5] + other[5]
    system[at + 6] = rhs


@kernel
def _lyapunov(e: Mat3, c: Mat3, system: FloatArray, at: int) -> Mat3:
    """The symmetric X with ``X - F^T X F = c`` for F = I - ``e`` (``c``
    symmetric), as ``X e + e^T X - e^T X e = c``: no cancellation when F is
    near I, as it is at dt = 0.01. Six unknowns X00, X01, X02, X11, X12, X22;
    Gaussian elimination with partial pivoting in ``system[at : at + 42]``:
    scratch, 6 rows of 7, row by row."""
    # Column j of e and of F: the row of unknown (i, j) is
    # sym(unit_i, e_j) + sym(e_i, F_j), sym(u, w) = u^T X w + w^T X u.
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = e
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = (
        1.0 - e00, -e01, -e02, -e10, 1.0 - e11, -e12, -e20, -e21, 1.0 - e22,
    )  # fmt: skip
    _row(system, at, _symmetric_product(1.0, 0.0, 0.0, e00, e10, e20),
         _symmetric_product(e00, e10, e20, f00, f10, f20), c[0])  # fmt: skip
    _row(system, at + 7, _symmetric_product(1.0, 0.0, 0.0, e01, e11, e21),
         _symmetric_product(e00, e10, e20, f01, f11, f21), c[1])  # fmt: skip
    _row(system, at + 14, _symmetric_product(1.0, 0.0, 0.0, e02, e12, e22),
         _symmetric_product(e00, e10, e20, f02, f12, f22), c[2])  # fmt: skip
    _row(system, at + 21, _symmetric_product(0.0, 1.0, 0.0, e01, e11, e21),
         _symmetric_product(e01, e11, e21, f01, f11, f21), c[4])  # fmt: skip
    _row(system, at + 28, _symmetric_product(0.0, 1.0, 0.0, e02, e12, e22),
         _symmetric_product(e01, e11, e21, f02, f12, f22), c[5])  # fmt: skip
    _row(system, at + 35, _symmetric_product(0.0, 0.0, 1.0, e02, e12, e22),
         _symmetric_product(e02, e12, e22, f02, f12, f22), c[8])  # fmt: skip
    for col in range(6):
        pivot = col
        for row in range(col + 1, 6):
            if abs(system[at + 7 * row + col]) > abs(system[at + 7 * pivot + col]):
                pivot = row
        if system[at + 7 * pivot + col] == 0.0:  # singular: F has eigenvalues l1 l2 = 1
            nan = math.nan
            return (nan, nan, nan, nan, nan, nan, nan, nan, nan)
        if pivot != col:
            for n in range(col, 7):
                system[at + 7 * col + n], system[at + 7 * pivot + n] = (
                    system[at + 7 * pivot + n],
                    system[at + 7 * col + n],
                )
        for row in range(col + 1, 6):
            factor = system[at + 7 * row + col] / system[at + 7 * col + col]
            for n in range(col + 1, 7):
                system[at + 7 * row + n] -= factor * system[at + 7 * col + n]
    for row in range(5, -1, -1):
        total = system[at + 7 * row + 6]
        for n in range(row + 1, 6):
            total -= system[at + 7 * row + n] * system[at + 7 * n + 6]
        system[at + 7 * row + 6] = total / system[at + 7 * row + row]
    x0 = system[at + 6]
    x1 = system[at + 13]
    x2 = system[at + 20]
    x3 = system[at + 27]
    x4 = system[at + 34]
    x5 = system[at + 41]
    return (x0, x1, x2, x1, x3, x4, x2, x4, x5)


@kernel
def newton_riccati(
    a: Mat3,
    b: tuple[float, float, float, float, float, float],
    r: FloatArray,
    q: Mat3,
    pi: Mat3,
    system: FloatArray,
    at: int,
) -> tuple[Mat3, int]:
    """Solve eq. (21) by Newton's method (Hewer) from ``pi``, a nearby solution:
    ``(pi, steps)``; ``-steps`` when it gave up (the caller then solves by doubling).

    Each step linearises eq. (21) at ``pi``: with F = A - B T the closed loop
    of its gain (eq. (20)), the correction D solves the discrete Lyapunov
    equation ``D - F^T D F = residual of eq. (21) at pi``. Convergence is
    quadratic near the solution, so the next correction, the error left, is
    foreseen from the last two: ``c_next = c^2 (c / c_prev^2)``, relative to
    the solution. The iteration stops once that is below TOLERANCE, the
    doubling's bound on its last change. Near rest eq. (21) is so
    ill-conditioned that the corrections stall at 1e-14..1e-12 of the
    solution, its rounding noise, where a bound on the correction itself
    would never be met. The result is trusted only if it converged within
    NEWTON_STEPS, its first correction was within NEWTON_REACH, and it is
    positive definite (with Q-hat > 0 the one positive semi-definite solution
    is the stabilising one). ``system[at : at + 42]`` is scratch."""
    previous = 0.0  # the relative size of the last correction
    for iteration in range(1, NEWTON_STEPS + 1):
        t = regulator_gain(a, b, r, pi)
        # With N = A - I and E = B T - N = I - F (F the closed loop), the
        # residual Q + A^T pi F - pi of eq. (21) is Q + N^T pi F - pi E: the
        # large terms of pi, which cancel, are never formed.
        e = (
            b[0] * t[0] + b[1] * t[3] - a[0] + 1.0, b[0] * t[1] + b[1] * t[4] - a[1],
            b[0] * t[2] + b[1] * t[5] - a[2],
            b[2] * t[0] + b[3] * t[3] - a[3], b[2] * t[1] + b[3] * t[4] - a[4] + 1.0,
            b[2] * t[2] + b[3] * t[5] - a[5],
            b[4] * t[0] + b[5] * t[3] - a[6], b[4] * t[1] + b[5] * t[4] - a[7],
            b[4] * t[2] + b[5] * t[5] - a[8] + 1.0,
        )  # fmt: skip
        pe = _mul3(pi, e)
        npf = _mul3(
            (a[0] - 1.0, a[3], a[6], a[1], a[4] - 1.0, a[7], a[2], a[5], a[8] - 1.0),  # N^T
            (pi[0] - pe[0], pi[1] - pe[1], pi[2] - pe[2],
             pi[3] - pe[3], pi[4] - pe[4], pi[5] - pe[5],
             pi[6] - pe[6], pi[7] - pe[7], pi[8] - pe[8]),
        )  # fmt: skip
        residual = _symmetric_step(
            q,
            (npf[0] - pe[0], npf[1] - pe[1], npf[2] - pe[2],
             npf[3] - pe[3], npf[4] - pe[4], npf[5] - pe[5],
             npf[6] - pe[6], npf[7] - pe[7], npf[8] - pe[8]),
        )  # fmt: skip
        correction = _lyapunov(e, residual, system, at)
        new = _symmetric_step(pi, correction)  # pi + correction: both symmetric
        change, size = _change(new, pi)
        pi = new
        if not change <= NEWTON_REACH * size:  # too far to trust, or not a number
            return pi, -iteration
        relative = change / size if change > 0.0 else 0.0
        # c_next <= TOLERANCE, without dividing by a c_prev of 0.
        foreseen = relative * relative * relative <= TOLERANCE * previous * previous
        previous = relative
        if relative == 0.0 or (iteration > 1 and foreseen):
            minor = pi[0] * pi[4] - pi[1] * pi[3]
            det = pi[0] * (pi[4] * pi[8] - pi[5] * pi[7]) - pi[1] * (pi[3] * pi[8] - pi[5] * pi[6])
            det += pi[2] * (pi[3] * pi[7] - pi[4] * pi[6])
            if pi[0] > 0.0 and minor > 0.0 and det > 0.0:
                return pi, iteration
            return pi, -iteration
    return pi, -NEWTON_STEPS


@kernel
def regulator_gain(
    a: Mat3, b: tuple[float, float, float, float, float, float], r: FloatArray, pi: Mat3
) -> tuple[float, float, float, float, float, float]:
    """Eq. (20): T = (R + B^T pi B)^-1 B^T pi A, row by row; ``b`` is B (3x2)
    row by row and ``r`` the diagonal of R-hat."""
    # pb = pi B (3x2)
    pb00 = pi[0] * b[0] + pi[1] * b[2] + pi[2] * b[4]
    pb10 = pi[3] * b[0] + pi[4] * b[2] + pi[5] * b[4]
    pb20 = pi[6] * b[0] + pi[7] * b[2] + pi[8] * b[4]
    pb01 = pi[0] * b[1] + pi[1] * b[3] + pi[2] * b[5]
    pb11 = pi[3] * b[1] + pi[4] * b[3] + pi[5] * b[5]
    pb21 = pi[6] * b[1] + pi[7] * b[3] + pi[8] * b[5]
    # S = R + B^T pi B (2x2, symmetric)
    s00 = r[0] + b[0] * pb00 + b[2] * pb10 + b[4] * pb20
    s01 = b[0] * pb01 + b[2] * pb11 + b[4] * pb21
    s11 = r[1] + b[1] * pb01 + b[3] * pb11 + b[5] * pb21
    det = s00 * s11 - s01 * s01
    i00 = s11 / det
    i01 = -s01 / det
    i11 = s00 / det
    # (B^T pi A)[:, j] = pb^T A[:, j]
    m00 = pb00 * a[0] + pb10 * a[3] + pb20 * a[6]
    m10 = pb01 * a[0] + pb11 * a[3] + pb21 * a[6]
    m01 = pb00 * a[1] + pb10 * a[4] + pb20 * a[7]
    m11 = pb01 * a[1] + pb11 * a[4] + pb21 * a[7]
    m02 = pb00 * a[2] + pb10 * a[5] + pb20 * a[8]
    m12 = pb01 * a[2] + pb11 * a[5] + pb21 * a[8]
    return (
        i00 * m00 + i01 * m10, i00 * m01 + i01 * m11, i00 * m02 + i01 * m12,
        i01 * m00 + i11 * m10, i01 * m01 + i11 * m11, i01 * m02 + i11 * m12,
    )  # fmt: skip


def _mat3(m: FloatArray) -> Mat3:
    return tuple(float(v) for v in np.asarray(m, dtype=np.float64).reshape(9))  # type: ignore[return-value]


def dlqr(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray
) -> tuple[FloatArray, FloatArray, int]:
    """Array form for tests and notebooks: (T, pi, doublings). ``q`` is the
    diagonal of Q-hat or the whole matrix."""
    b = np.asarray(b, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    g = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            g[i, j] = b[i, 0] * b[j, 0] / r[0] + b[i, 1] * b[j, 1] / r[1]
    q_hat = np.diag(q) if np.ndim(q) == 1 else np.asarray(q, dtype=np.float64)
    pi, doublings = solve_riccati(_mat3(a), _mat3(g), _mat3(q_hat))
    rows = b.reshape(6)
    b6 = (
        float(rows[0]),
        float(rows[1]),
        float(rows[2]),
        float(rows[3]),
        float(rows[4]),
        float(rows[5]),
    )
    gain = regulator_gain(_mat3(a), b6, r, pi)
    return np.array(gain).reshape(2, 3), np.array(pi).reshape(3, 3), doublings
