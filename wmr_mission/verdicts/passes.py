"""The judge's passes over a phase's samples, each one compiled loop where the
run's kernels are compiled: what numpy computes for plain Python, a few array
operations at a time (each caller keeps that form beside its call).

- a phase's inputs in one pass: the speed's and the turn rate's jumps,
  reversals and stretches at their limits, and the turn rate's jitter
  (wmr_mission.verdicts.inputs);
- a regulate phase's samples stalled away from its goal, and how far it
  went past its target (wmr_mission.verdicts.regulation);
- the depth beyond an ellipse zone, its bounds, and the deepest of some
  points (wmr_mission.verdicts.zones);
- a phase's samples after its settle time, and whether its poses are
  finite (wmr_mission.verdicts.metrics);
- the largest finite value of a phase's column, scaled or its magnitude
  (wmr_mission.verdicts.metrics), with no copy of it;
- the run's estimation errors, the heading's wrapped, and the last sample
  not converged (wmr_mission.verdicts.metrics), and the first sample whose
  estimate is within its tolerance (wmr_mission.verdicts.inputs);
- where a track phase's robot has kept up with its reference, and the
  samples of its entry (wmr_mission.verdicts.tracking);
- the distances to the reference points and the exact sum of their squares
  of ``reference_error_rms`` (wmr_mission.verdicts.metrics), the float
  ``math.fsum`` gives.

The same numbers: the same operations in the same order, numpy's ``max``
(NaN if any is) and ``searchsorted`` as loops, a square as a product (as
numpy's ``** 2``), the median as the same middle values, a remainder by
2 pi as the exact one ``fmod`` gives, ``hypot`` wherever its last bits
decide a comparison (``tests/test_verdict_passes.py``). No numpy function
numba implements in its array-math module is called: loading such a pass from the cache would
import scipy's BLAS (``tests/test_start_up.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import inlined, kernel

__all__ = [  # the passes, each compiled by `wmr-mission compile` (tests/test_start_up.py)
    "ellipse_bounds",
    "ellipse_deepest",
    "ellipse_depth",
    "estimation_error_pass",
    "finite_squares_sum",
    "first_within",
    "input_pass",
    "kept_up",
    "largest_finite",
    "last_unconverged",
    "poses_finite",
    "reference_distances",
    "regulation_pass",
    "settled_count",
]

# The jitter's moving sums added to this many at a time (16 kB: within the
# cache while each of the window's samples is added to them).
_BLOCK = 2048

# Partials kept at most: non-overlapping doubles, each with a bit of its own
# among the 2 098 places from 2^-1074 to 2^1023 (math.fsum grows its list).
PARTIALS = 2100


@kernel
def largest_finite(
    values: FloatArray, chosen: NDArray[np.bool_], factor: float, divisor: float, magnitude: bool
) -> float:
    """The largest finite ``factor * value / divisor`` (of ``|value|`` with
    ``magnitude``) of the ``chosen`` values (every one where ``chosen`` is
    empty), each computed as numpy computes it; NaN where none is finite. Its
    callers ask for values that are never -0 or whose zero is read as +0: which
    of two equal zeros numpy's ``max`` keeps is its own."""
    found = math.nan
    every = chosen.size == 0
    scaled = factor != 1.0 or divisor != 1.0  # else 1.0 * value / 1.0: the value itself
    for k in range(values.size):
        if every or chosen[k]:
            value = abs(values[k]) if magnitude else values[k]
            if scaled:
                value = factor * value / divisor
            if abs(value) < math.inf and not value <= found:  # found NaN: none yet
                found = value
    return found


@kernel
def estimation_error_pass(
    true: tuple[FloatArray, FloatArray, FloatArray],
    estimate: tuple[FloatArray, FloatArray, FloatArray],
    errors: tuple[FloatArray, FloatArray, FloatArray],
) -> None:
    """True minus estimated x, y and heading of each sample into ``errors``,
    the heading's wrapped to [-pi, pi) as ``metrics.wrap_angle`` wraps it (a
    float's ``%`` is numpy's: the C library's fmod, the sign of the divisor)."""
    x, y, theta = true
    x_est, y_est, theta_est = estimate
    ex, ey, etheta = errors
    wrapped = True  # every heading error + pi within (0, 2 pi): its own remainder
    for k in range(x.size):
        ex[k] = x[k] - x_est[k]
        ey[k] = y[k] - y_est[k]
        turned = theta[k] - theta_est[k] + math.pi
        wrapped &= 0.0 < turned < 2.0 * math.pi
        etheta[k] = turned - math.pi
    if not wrapped:
        _wrap_beyond(theta, theta_est, etheta)


@inlined
def _wrap_beyond(theta: FloatArray, theta_est: FloatArray, etheta: FloatArray) -> None:
    """The heading errors whose shifted value is not within (0, 2 pi) wrapped
    by the float remainder: a loop of its own, so that the remainder runs
    only where it is needed, not speculated at every sample. Within (0, 2 pi)
    the remainder is the value itself, exactly (``fmod`` is exact, and
    neither the sign nor a zero needs its fix-up)."""
    for k in range(theta.size):
        turned = theta[k] - theta_est[k] + math.pi
        if not 0.0 < turned < _TURN:
            etheta[k] = _turn_remainder(turned) - math.pi


# A turn, 2 pi, as the sum of two floats of 26 significant bits at most
# (Veltkamp's split), whose products with a whole number below 2^26 are exact.
_TURN = 2.0 * math.pi
_TURN_HIGH = 134217729.0 * _TURN - (134217729.0 * _TURN - _TURN)
_TURN_LOW = _TURN - _TURN_HIGH
# Below this magnitude a value's whole turns are below 2^24: the products exact.
_FEW_TURNS = 2.0**26


@inlined
def _turn_remainder(value: float) -> float:
    """``value % (2 pi)``, the float remainder numpy's and Python's ``%`` give
    (``fmod``, exact, then 2 pi added to a negative one), without the C
    library's ``fmod`` (tens of cycles) for a value within a few million
    turns: a heading error of a robot that has turned round a few times.
    Within one turn either side the remainder is the value, or the value
    plus (or minus, exactly) a turn; further, the value less its whole turns
    taken off exactly (:func:`_whole_turns_off`)."""
    if 0.0 < value < _TURN:
        return value
    if -_TURN < value < 0.0:  # fmod is the value itself, below 0: a turn added
        return value + _TURN
    if _TURN <= value < 2.0 * _TURN:  # exact (within a factor of 2 of a turn)
        return value - _TURN
    if not abs(value) < _FEW_TURNS:  # many turns, infinite or NaN
        return value % _TURN
    off = _whole_turns_off(abs(value))
    if off != off:  # a difference not known exact: the C library's
        return value % _TURN
    if value >= 0.0 or off == 0.0:
        return off + 0.0  # (a zero remainder is +0)
    return _TURN - off  # fmod is minus it: a turn added


@inlined
def _whole_turns_off(size: float) -> float:
    """``fmod(size, 2 pi)`` of a ``size`` within [0, _FEW_TURNS), exact; NaN
    where it is not known exact so. The whole turns ``q``: the quotient's
    floor, at most one above the exact one (a whole number below 2^53 is a
    float; rounding never passes it); ``size - q 2 pi`` is then exact as
    ``(size - q high) - q low``: both products exact, the first difference
    exact within a factor of 2 (Sterbenz), and the second's exact value the
    remainder (a float: fmod's is exact), or one turn below it where ``q`` was
    one too many (then negative)."""
    turns = float(math.floor(size / _TURN))
    for _ in range(2):
        if turns == 0.0:
            return size
        high = turns * _TURN_HIGH
        if not 0.5 * high <= size <= 2.0 * high:
            return math.nan
        off = (size - high) - turns * _TURN_LOW
        if off >= 0.0:
            return off
        turns -= 1.0
    return math.nan


@kernel
def last_unconverged(
    errors: tuple[FloatArray, FloatArray, FloatArray], tolerance: tuple[float, float, float]
) -> int:
    """The last sample at which some |error| is not below its state's
    tolerance (NaN is not), -1 if none: ``metrics.convergence_index``."""
    ex, ey, etheta = errors
    for k in range(ex.size - 1, -1, -1):
        if not (abs(ex[k]) < tolerance[0] and abs(ey[k]) < tolerance[1]):
            return k
        if not abs(etheta[k]) < tolerance[2]:
            return k
    return -1


@kernel
def kept_up(
    position: tuple[FloatArray, FloatArray],
    reference: tuple[FloatArray, FloatArray],
    samples: tuple[int, int, int],
    tolerance: float,
    moving: float,
    apart_most: float,
    entry: tuple[FloatArray, float, NDArray[np.bool_]],
) -> tuple[int, int]:
    """``tracking._kept_up``: of ``samples`` (begin, end, window), the first
    sample from ``begin`` on ending ``window`` samples in a row each within
    ``tolerance`` of its reference point and, from the sample before (none
    before ``max(begin - window, 0)``), moved apart from it by at most
    ``moving`` of the reference's step and ``apart_most``; -1: none. ``hypot``
    the C library's, as numpy's. With times in ``entry`` (times, bound,
    judged), ``tracking._entry_judged``: the samples in the entry, their time
    since the first below the bound, up to the sample found (``end``: how
    many are), each judged where not in it (into ``judged``), and how many
    are in it (-1 without times)."""
    px, py = position
    rx, ry = reference
    begin, end, window = samples
    t, bound, judged = entry
    if t.size:
        end = 0
        for k in range(t.size):
            judged[k] = not t[k] - t[0] < bound
            end += 0 if judged[k] else 1
    first = max(begin - window, 0)
    run = 0  # samples with it in a row
    found = -1
    for k in range(first, end):
        ex, ey = px[k] - rx[k], py[k] - ry[k]
        with_it = np.hypot(ex, ey) <= tolerance
        if k > first:
            apart = np.hypot(ex - (px[k - 1] - rx[k - 1]), ey - (py[k - 1] - ry[k - 1]))
            moved = moving * np.hypot(rx[k] - rx[k - 1], ry[k] - ry[k - 1])
            with_it = with_it and apart <= moved and apart <= apart_most
        elif first > 0:  # the sample before the window: there for its first one's velocity
            with_it = False
        run = run + 1 if with_it else 0
        if run >= window and k >= begin:
            found = k
            break
    if not t.size:
        return found, -1
    if found >= 0:
        end = 0
        for k in range(t.size):
            judged[k] = judged[k] or k >= found
            end += 0 if judged[k] else 1
    return found, end


@kernel
def first_within(
    errors: tuple[FloatArray, FloatArray, FloatArray],
    tolerance: tuple[float, float, float],
    near: float,
) -> int:
    """The first sample whose position errors are within the ellipse of their
    tolerances and whose heading error within its own (-1: none), as
    ``inputs.first_judged`` finds it: ``hypot`` (the C library's, as numpy's)
    only where the squares' sum is within ``near`` of 1."""
    ex, ey, etheta = errors
    for k in range(ex.size):
        a, b = ex[k] / tolerance[0], ey[k] / tolerance[1]
        squared = a * a + b * b
        # the C library's hypot (as numpy's) only near the edge
        within = np.hypot(a, b) <= 1.0 if abs(squared - 1.0) < near else squared <= 1.0 - near
        if within and abs(etheta[k]) <= tolerance[2]:
            return k
    return -1


@kernel
def input_pass(
    t: FloatArray,
    v: FloatArray,
    omega: FloatArray,
    counted: NDArray[np.bool_],
    floors: tuple[float, float],
    limits: tuple[float, float, float],
    window: float,
    samples: tuple[int, int, int],
    cuts: NDArray[np.intp],
    dt: float,
) -> tuple[float, int, int, float, int, int, float]:
    """A phase's input metrics in one call (``inputs.input_quality``). Of the
    speed and the turn rate: the largest one-sample jump (NaN if any is; 0
    with fewer than two), and the most sign reversals within any ``window``
    [s] of the values beyond its floor (``floors``); the speed's stretches at
    its limit of ``shortest`` samples or more, how many (each is judged by the
    progress it makes, in Python); the turn rate's samples at its limit that
    fight it (``inputs.fight_time`` by ``inputs._turns``, half a turn
    at the sample time ``dt``, its stretches cut at ``cuts``). Last, the turn
    rate's jitter spread (:func:`_jitter_spread`). ``limits``: the speed's
    and the turn rate's, and the share of them that is at them (``|value| >=
    limit * share``); ``samples``: ``shortest`` and the jitter's ``half`` and
    ``skip``; ``t`` empty: the jitter alone (of a whole run's turn rate)."""
    v_limit, omega_limit, share = limits
    shortest, half, skip = samples
    times = np.empty(t.size)  # the reversals', of each input in turn
    speed = _input_scan(
        t, v, (floors[0], v_limit * share), window, shortest, cuts, (dt, math.inf), times
    )
    turn = _input_scan(
        t, omega, (floors[1], omega_limit * share), window, shortest, cuts, (dt, omega_limit), times
    )
    fought = turn[3] if abs(omega_limit) < math.inf else 0  # a limit never reached: no fight
    spread = _jitter_spread(omega, counted, half, skip)
    return speed[0], speed[1], speed[2], turn[0], turn[1], fought, spread


@inlined
def _input_scan(
    t: FloatArray,
    values: FloatArray,
    bounds: tuple[float, float],
    window: float,
    shortest: int,
    cuts: NDArray[np.intp],
    turn: tuple[float, float],
    times: FloatArray,
) -> tuple[float, int, int, int]:
    """Of the first ``t.size`` values: the largest one-sample jump, the most
    reversals within any ``window`` of those beyond the floor (``bounds[0]``;
    ``times``: scratch, a sample's worth), the stretches at the limit
    (``|value| >= bounds[1]``) of ``shortest`` samples or more (how many),
    and their samples that fight a turn-rate limit (:func:`_fought`). The
    reversals and the stretches are looked for only where a first pass, one
    the compiler vectorises, found values beyond the floor of both signs and
    values at the limit."""
    floor, at_limit = bounds
    n = t.size
    jump = 0.0 if n < 2 else -math.inf
    for k in range(1, n):
        step = abs(values[k] - values[k - 1])
        if step != step:  # numpy's max: NaN if any is
            jump = step
            break
        jump = max(jump, step)
    positive, negative, at = False, False, False
    for k in range(n):
        positive |= values[k] > floor
        negative |= values[k] < -floor
        at |= abs(values[k]) >= at_limit
    most = 0
    if positive and negative:  # else no reversal
        most = _most_reversals(t, values, floor, window, times)
    stretches, fought, start = 0, 0, -1
    for k in range(n if at else 0):
        at = abs(values[k]) >= at_limit
        if at and start < 0:
            start = k
        if start >= 0 and (not at or k == n - 1):
            end = k + 1 if at else k
            if end - start >= shortest:
                stretches += 1
                if turn[1] < math.inf:  # the speed's stretches are judged in Python
                    fought += _fought(values, (start, end), shortest, cuts, turn)
            start = -1
    return jump, most, stretches, fought


@inlined
def _most_reversals(
    t: FloatArray, values: FloatArray, floor: float, window: float, times: FloatArray
) -> int:
    """The most sign reversals of the first ``t.size`` values within any
    ``window`` [s], at the sample that brings the new sign, values within
    ``floor`` of zero skipped (``inputs.most_reversals``)."""
    count, sign = 0, 0
    for k in range(t.size):
        if abs(values[k]) > floor:
            now = 1 if values[k] > 0 else -1
            if sign != 0 and now != sign:
                times[count] = t[k]
                count += 1
            sign = now
    dt = t[1] - t[0] if t.size > 1 else 0.0
    most, end = 0, 0
    for first in range(count):  # np.searchsorted(times, times + window - dt / 2, "right")
        reach = times[first] + window - 0.5 * dt
        while end < count and times[end] <= reach:
            end += 1
        most = max(most, end - first)
    return most


@inlined
def _one_sign(values: FloatArray, a: int, b: int) -> bool:
    """Whether ``values[a:b]`` are all positive or all negative."""
    positive, negative = 0, 0
    for k in range(a, b):
        positive += 1 if values[k] > 0 else 0
        negative += 1 if values[k] < 0 else 0
    return positive == b - a or negative == b - a


@inlined
def _fought(
    values: FloatArray,
    stretch: tuple[int, int],
    shortest: int,
    cuts: NDArray[np.intp],
    turn: tuple[float, float],
) -> int:
    """The samples of the ``stretch`` (first, one past the last) at a turn-rate
    limit that fight it: each of its pieces cut at ``cuts`` (``inputs._cut``)
    of ``shortest`` samples or more that changes sign or turns more than half
    a turn (``inputs._turns``; ``turn``: the sample time
    and the limit)."""
    start, end = stretch
    dt, limit = turn
    fought, a = 0, start
    for c in range(cuts.size + 1):
        b = cuts[c] if c < cuts.size else end
        if c < cuts.size and not start < b < end:
            continue
        if b - a >= shortest and not (
            _one_sign(values, a, b) and (b - a) * dt * limit <= math.pi + 2.0 * limit * dt
        ):
            fought += b - a
        a = b
    return fought


@inlined
def _jitter_spread(omega: FloatArray, counted: NDArray[np.bool_], half: int, skip: int) -> float:
    """The median of ``|omega - its centred moving mean|`` over ``2 half + 1``
    samples (summed in order from 0), of the samples from ``skip`` on that
    ``counted`` counts (empty: all; all too where it counts none of them);
    NaN if any of those is, or when fewer than ``skip + 2 half + 1`` samples
    are left (so a short phase compiles it too, in ``wmr-mission compile``'s
    warm-up)."""
    window = 2 * half + 1
    if omega.size < skip + window:
        return math.nan
    centres = omega.size - window + 1
    dropped = max(0, skip - half)
    total = np.zeros(centres - dropped)
    for begin in range(0, total.size, _BLOCK):  # a block of sums kept in cache while added to
        block = total[begin : min(begin + _BLOCK, total.size)]
        at, n = dropped + begin, block.size
        # Each sum in order, the centres side by side, three samples added to
        # each between its load and its store, then the rest one by one.
        for offset in range(0, window - 2, 3):
            first = omega[at + offset : at + offset + n]
            second = omega[at + offset + 1 : at + offset + 1 + n]
            third = omega[at + offset + 2 : at + offset + 2 + n]
            for c in range(n):
                block[c] = ((block[c] + first[c]) + second[c]) + third[c]
        for offset in range(window - window % 3, window):
            samples = omega[at + offset : at + offset + n]
            for c in range(n):
                block[c] += samples[c]
    every = True  # none counted: all are
    for c in range(dropped, centres if counted.size else 0):
        if counted[half + c]:
            every = False
            break
    size = 0
    spread = total  # each deviation in place of its sum, read just before: no second array
    for c in range(dropped, centres):
        if every or counted[half + c]:
            deviation = abs(omega[half + c] - total[c - dropped] / window)
            if deviation != deviation:
                return math.nan
            spread[size] = deviation
            size += 1
    spread = spread[:size]
    middle = spread.size // 2
    found = _select(spread, middle)
    if spread.size % 2:
        return found
    below = spread[0]  # the largest before the middle: the one below it in order
    for k in range(1, middle):
        below = max(below, spread[k])
    return float((below + found) / 2)


@inlined
def _select(values: FloatArray, k: int) -> float:
    """The k-th smallest of ``values`` (no NaN), the values moved so that none
    before it is larger (Hoare's selection). Not ``np.partition``: numba
    implements it in the module that loads scipy's BLAS with it, for every run
    that loads this pass from the cache."""
    low, high = 0, values.size - 1
    while low < high:
        a, b, c = values[low], values[(low + high) // 2], values[high]
        pivot = max(min(a, b), min(max(a, b), c))  # the median of three
        i, j = low, high
        while i <= j:
            while values[i] < pivot:
                i += 1
            while values[j] > pivot:
                j -= 1
            if i <= j:
                values[i], values[j] = values[j], values[i]
                i += 1
                j -= 1
        if k <= j:
            high = j
        elif k >= i:
            low = i
        else:  # between the two sides: the pivot's value
            break
    return float(values[k])


@kernel
def regulation_pass(
    x: FloatArray,
    y: FloatArray,
    theta: FloatArray,
    target: tuple[float, float, float],
    goal: tuple[float, float],
    window: int,
    reach: tuple[float, float],
    progress: float,
    way: tuple[float, float, float],
) -> tuple[int, float, bool, bool]:
    """Of a regulate phase's stretch: the samples k from which the window
    k .. k + ``window`` holds no sample within ``goal`` (position, heading) of
    ``target`` and takes out neither ``progress`` of the position error (or of
    ``reach[0]``) nor of the heading error (or of ``reach[1]``)
    (:func:`wmr_mission.verdicts.regulation.stall_time`); the largest distance
    beyond the target along ``way`` (from the first position to the target,
    and its length; NaN if any is, as numpy's ``max``;
    :func:`wmr_mission.verdicts.regulation.overshoot`); whether every position
    is finite, and every heading. One pass: a sample's window ends ``window``
    samples later, where its end is at hand.

    The position errors are the C library's ``hypot`` (as numpy's) where a
    comparison's side depends on their last bits; elsewhere the square root
    of the squares' sum, within a few roundings of it (and ten times
    cheaper): a side that holds by more than ``_SLACK`` of the values
    compared holds for both."""
    n = x.size
    tx, ty, aim = target
    way_x, way_y, length = way
    position, heading = np.empty(n), np.empty(n)
    exact = np.empty(n, dtype=np.bool_)  # whether position[k] is hypot's
    beyond = -math.inf
    placed, turned_finite = True, True
    last_at_goal = -1  # the last sample within the goal so far
    stalled = 0
    for j in range(n):
        dx, dy = x[j] - tx, y[j] - ty
        placed &= abs(x[j]) < math.inf and abs(y[j]) < math.inf
        turned_finite &= abs(theta[j]) < math.inf
        squared = dx * dx + dy * dy
        # (squares that underflow or overflow, NaN: hypot's)
        exact[j] = not _LEAST_SQUARED < squared < _MOST_SQUARED
        position[j] = math.hypot(dx, dy) if exact[j] else math.sqrt(squared)
        heading[j] = abs(_turn_remainder(theta[j] - aim + math.pi) - math.pi)
        beyond = _nan_max(beyond, (dx * way_x + dy * way_y) / length)
        if not exact[j] and abs(position[j] - goal[0]) <= _SLACK * position[j]:
            _exactly(x, y, tx, ty, j, position, exact)
        if position[j] <= goal[0] and heading[j] <= goal[1]:
            last_at_goal = j
        k = j - window
        if k < 0 or last_at_goal >= k:  # no window ends here, or it is at the goal
            continue
        start, end = position[k], position[j]
        taken, wanted = start - end, progress * min(start, reach[0])
        if not (exact[k] and exact[j]) and abs(taken - wanted) <= _SLACK * (start + end):
            start = _exactly(x, y, tx, ty, k, position, exact)
            end = _exactly(x, y, tx, ty, j, position, exact)
            taken, wanted = start - end, progress * min(start, reach[0])
        closer = taken >= wanted
        turn_start, turn_end = heading[k], heading[j]
        turned = turn_start - turn_end >= progress * min(turn_start, reach[1])
        if not closer and not turned:
            stalled += 1
    return stalled, beyond, placed, turned_finite


# Squared distances whose square root is within a few roundings of hypot's:
# neither square underflows beyond what the sum keeps, nor overflows.
_LEAST_SQUARED = 1e-290
_MOST_SQUARED = 1e290
# A comparison of position errors known to come out as with hypot's: its
# sides this share of the values compared apart, where the square roots are
# within 1e-15 of them (two roundings each of the root and of hypot).
_SLACK = 1e-12


@inlined
def _exactly(
    x: FloatArray, y: FloatArray, tx: float, ty: float, k: int, position: FloatArray,
    exact: NDArray[np.bool_],
) -> float:  # fmt: skip
    """Sample k's position error as hypot has it, in ``position`` from now on."""
    if not exact[k]:
        position[k] = math.hypot(x[k] - tx, y[k] - ty)
        exact[k] = True
    return float(position[k])


@kernel
def ellipse_bounds(
    x: FloatArray,
    y: FloatArray,
    frame: tuple[float, float, float, float, float, float],
    keep_inside: bool,
) -> tuple[NDArray[np.bool_], float, NDArray[np.intp]]:
    """Of the points and an ellipse zone (``frame``: its centre, the cosine and
    sine of its rotation, its semi-axes as written): whether each is beyond it
    (``Zone.beyond``), the largest upper bound on their depths, and the points
    whose upper bound is at least every lower bound, those whose depth may be
    the largest (``Zone.max_depth``). NaN bounds as numpy's ``max`` gives them."""
    cx, cy, c, s, a, b = frame
    major, minor = max(a, b), min(a, b)
    n = x.size
    beyond = np.empty(n, dtype=np.bool_)
    most, least = np.empty(n), np.empty(n)
    for k in range(n):  # (no reduction: a loop the compiler runs several points at a time)
        u = c * (x[k] - cx) + s * (y[k] - cy)
        w = -s * (x[k] - cx) + c * (y[k] - cy)
        # the scaled radius; its sum's order does not matter: IEEE sums commute
        radius = math.sqrt((u / a) * (u / a) + (w / b) * (w / b))
        beyond[k] = radius > 1.0 if keep_inside else radius < 1.0
        out = radius - 1.0 if keep_inside else 1.0 - radius  # never -0
        most[k] = out * (major if out > 0 else minor)  # the depth is at most
        least[k] = out * (minor if out > 0 else major)  # and at least
    highest, lowest = -math.inf, -math.inf
    unknown = False  # a NaN bound: both NaN, as numpy's max gives them
    for k in range(n):
        unknown |= most[k] != most[k]
        highest, lowest = max(highest, most[k]), max(lowest, least[k])
    if unknown:
        highest, lowest = math.nan, math.nan
    contenders = np.empty(n, dtype=np.intp)
    count = 0
    for k in range(n):  # (not np.flatnonzero: see _select)
        if most[k] >= lowest:
            contenders[count] = k
            count += 1
    return beyond, highest, contenders[:count]


@inlined
def _nan_max(found: float, value: float) -> float:
    """numpy's ``max`` a value at a time: NaN once any is."""
    if found != found or value != value:
        return math.nan
    return max(found, value)


@kernel
def ellipse_depth(
    x: FloatArray,
    y: FloatArray,
    frame: tuple[float, float, float, float, float, float],
    squares: tuple[float, float],
    keep_inside: bool,
    within: float,
    steps: int,
) -> FloatArray:
    """``Zone.depth`` of an ellipse zone (``frame`` as :func:`ellipse_bounds`
    takes it; ``squares``: the major and the minor semi-axis squared, as Python
    squares them): the distance to the foot of the ellipse's normal through
    each point, the roots of the points off the axes stepped together until
    the last has settled (``steps`` at most), as ``zones._roots`` steps them."""
    cx, cy, c, s, a, b = frame
    a2, b2 = squares
    swapped = a < b
    major, minor = (b, a) if swapped else (a, b)
    n = x.size
    found = np.empty(n)
    pu, pw = np.empty(n), np.empty(n)  # the measured points' |coordinates|, major first
    measured = np.empty(n, dtype=np.int64)
    count = 0
    for k in range(n):
        u = c * (x[k] - cx) + s * (y[k] - cy)
        w = -s * (x[k] - cx) + c * (y[k] - cy)
        if swapped:
            u, w = w, u
        radius = math.sqrt((u / major) * (u / major) + (w / minor) * (w / minor))
        if major == minor:
            found[k] = (radius - 1.0) * major
            continue
        inside = radius < 1.0
        found[k] = -math.inf if inside else math.inf
        if abs(1.0 - radius) * minor <= within or inside != keep_inside:
            pu[count], pw[count], measured[count] = abs(u), abs(w), k
            if (minor * pw[count] - b2) + b2 == 0.0:  # on the major axis, as zones._to_ellipse
                pw[count] = 0.0
            count += 1
    # Newton's method from the left of each root, the points off the axes together.
    t = np.empty(count)
    for j in range(count):
        su, sw = pu[j] / major, pw[j] / minor
        t[j] = 0.0 if su * su + sw * sw > 1.0 else minor * pw[j] - b2
    for _ in range(steps):
        moving = False
        for j in range(count):
            if not (pu[j] > 0.0 and pw[j] > 0.0):
                continue
            au, bw = major * pu[j], minor * pw[j]
            first, second = au / (t[j] + a2), bw / (t[j] + b2)
            slope = -2.0 * (first * first / (t[j] + a2) + second * second / (t[j] + b2))
            step = (first * first + second * second - 1.0) / slope
            t[j] = t[j] - step
            moving = moving or abs(step) > 1e-15 * (abs(t[j]) + a2)
        if not moving:
            break
    for j in range(count):
        u, w = pu[j], pw[j]
        if u > 0.0 and w > 0.0:
            foot = a2 * u / (t[j] + a2)
            height = minor * math.sqrt(_unit((foot / major) * (foot / major)))
            distance = np.hypot(foot - u, height - w)  # the C library's, as numpy's
        elif w > 0.0:  # on the minor axis: its end
            distance = abs(w - minor)
        elif w == 0.0:  # on the major axis: its end, or the foot of a normal
            if u * major < a2 - b2:
                foot = a2 * u / (a2 - b2)
                height = minor * math.sqrt(_unit((foot / major) * (foot / major)))
                distance = np.hypot(foot - u, height)
            else:
                distance = abs(u - major)
        else:
            distance = math.nan
        k = measured[j]
        found[k] = -distance if found[k] < 0.0 else distance
    if not keep_inside:
        for k in range(n):
            found[k] = -found[k]
    return found


@inlined
def _unit(squared: float) -> float:
    """``np.clip(1.0 - squared, 0.0, 1.0)``, NaN kept."""
    value = 1.0 - squared
    if value < 0.0:
        return 0.0
    if value > 1.0:
        return 1.0
    return value


@kernel
def reference_distances(
    position: tuple[FloatArray, FloatArray],
    reference: tuple[FloatArray, FloatArray],
    distance: FloatArray,
) -> None:
    """Each sample's distance from its reference point into ``distance``, as
    ``metrics.reference_distance`` computes it (IEEE operations alone)."""
    x, y = position
    x_ref, y_ref = reference
    for k in range(x.size):
        dx, dy = x[k] - x_ref[k], y[k] - y_ref[k]
        distance[k] = math.sqrt(dx * dx + dy * dy)


@kernel
def finite_squares_sum(values: FloatArray, partials: FloatArray) -> tuple[float, int]:
    """``math.fsum`` of ``value * value`` over the finite ``values``, and how
    many they are; NaN for the sum where ``math.fsum`` must decide (a square or
    the sum beyond the largest float, or more than ``partials.size`` partials).
    ``partials``: scratch, made by the caller (an array made in compiled code
    makes loading the kernel import numba's array module).

    ``math.fsum`` keeps the running sum as non-overlapping partials
    (Shewchuk's algorithm) and rounds their total once, half to even: this is
    CPython's own loop (``Modules/mathmodule.c``, ``math_fsum``) step by step,
    so the float is the same on every CPU (``tests/test_verdict_exact_sum.py``
    compares it with ``math.fsum`` on sums built to round otherwise when added
    in order or with a compensation)."""
    n = 0  # partials in use, smallest first
    count = 0
    for k in range(values.size):
        value = values[k]
        if not abs(value) < math.inf:  # NaN or infinite: left out, as np.isfinite leaves it
            continue
        count += 1
        x = value * value
        i = 0
        for j in range(n):  # x added to each partial, the round-off kept
            y = partials[j]
            if abs(x) < abs(y):
                x, y = y, x
            hi = x + y
            lo = y - (hi - x)
            if lo != 0.0:
                partials[i] = lo
                i += 1
            x = hi
        n = i
        if x != 0.0:
            if not abs(x) < math.inf or n == partials.size:
                return math.nan, count
            partials[n] = x
            n += 1
    total = 0.0
    if n > 0:  # the partials added from the largest until the sum is inexact
        n -= 1
        total = partials[n]
        lo = 0.0
        while n > 0:
            x = total
            n -= 1
            y = partials[n]
            total = x + y
            lo = y - (total - x)
            if lo != 0.0:
                break
        # half to even across the partials: the round-off and the partial below it
        # agree in sign, so the exact sum lies beyond the half-way point
        if n > 0 and ((lo < 0.0 and partials[n - 1] < 0.0) or (lo > 0.0 and partials[n - 1] > 0.0)):
            y = lo * 2.0
            x = total + y
            if y == x - total:
                total = x
    return total, count


@kernel
def settled_count(t: FloatArray, start_time: float, settle_time: float) -> tuple[int, bool]:
    """Of a phase's sample times ``t``: how many are at least ``settle_time``
    after ``start_time`` (``t - start_time >= settle_time``), and whether they
    are its last ones (``metrics.PhaseSamples``)."""
    count, last = 0, True
    for k in range(t.size):
        if t[k] - start_time >= settle_time:
            count += 1
        elif count:  # one before it is: not its last ones
            last = False
    return count, last


@kernel
def poses_finite(x: FloatArray, y: FloatArray, theta: FloatArray) -> bool:
    """Whether every pose is finite (``metrics.PhaseSamples.pose_finite``)."""
    finite = True
    for k in range(x.size):
        finite &= abs(x[k]) < math.inf and abs(y[k]) < math.inf and abs(theta[k]) < math.inf
    return finite


@kernel
def ellipse_deepest(
    x: FloatArray,
    y: FloatArray,
    chosen: NDArray[np.intp],
    frame: tuple[float, float, float, float, float, float],
    squares: tuple[float, float],
    keep_inside: bool,
    steps: int,
) -> float:
    """The largest :func:`ellipse_depth` of the ``chosen`` points (at least
    one), their depths found together as ``Zone.max_depth`` finds them; NaN if
    any is, as numpy's ``max``."""
    depth = ellipse_depth(x[chosen], y[chosen], frame, squares, keep_inside, math.inf, steps)
    found = float(depth[0])
    for k in range(1, depth.size):
        found = _nan_max(found, depth[k])
    return found
