"""The inputs of a phase judged by their quality, not by touching a limit.

Judged from the first sample at which the estimate is within its
convergence tolerance of the truth, widened by three noise standard
deviations (before it the law acts on an initial estimate the estimator is
still correcting):

- **jumps**: the largest one-sample change of ``v`` (``omega``). More than
  its limit, half the range ``[-limit, limit]``, is a kick.
- **reversals**: the most sign reversals of ``v`` (``omega``) within any
  window of REVERSAL_WINDOW time constants, not counting values within
  REVERSAL_FLOOR of the limit of zero (plus three times the turn rate the
  heading noise makes, for ``omega``): noise about zero and a slow sign change
  are not chatter.
- **fight time**: the time an input spends at its limit in stretches of one
  time constant or more that are not a deliberate drive. A stretch is
  deliberate when it keeps one sign and, for ``v``, turns at least half the
  distance it drives at the limit into progress (towards the target; on a path,
  along it or towards the reference point, whichever is more), read the
  plant's input delay and actuator time constant later (the motion a command
  makes comes then), but no later than the next update or the phase's end;
  for ``omega``, turns at most half a turn.
- **turn-rate jitter**: the spread of ``omega`` about its centred moving mean
  over two time constants, robust (1.4826 times the median absolute
  deviation: the few samples of a manoeuvre do not count), after the first
  REVERSAL_WINDOW time constants of what is judged (the law's switch at the
  phase's entry); in a track phase, over the samples its tracking is judged
  at (not in the entry, a detour or its rejoining, where each step of the
  turn rate sits off the moving mean for two time constants: such steps
  filled half of a short route's samples), or all if it judges none.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import jit
from wmr_mission.spec.numbers import MissionNumbers
from wmr_mission.verdicts.passes import first_within, input_pass

# Inputs this close to their limit (relative) are at it: the runner clips exactly.
AT_LIMIT = 1e-9
# Values within this share of the limit of zero are not counted as reversing.
REVERSAL_FLOOR = 0.05
# [time constants] the window reversals are counted in: an oscillation at the
# design's own rate (period 2 pi tau) reverses floor(10 / pi) = 3 times in it.
REVERSAL_WINDOW = 10.0
# A deliberate drive at the speed limit turns at least this share of its distance into progress.
DELIBERATE = 0.5
ROBUST_STD = 1.4826  # times the median absolute deviation: a Gaussian's std

# Squares' sums nearer 1 than this are compared by their hypot (:func:`_within_one`).
_NEAR_ONE = 1e-9
# [m] the progress made from sample a to sample b (a < b).
Progress = Callable[[int, int], float]
# What the compiled pass takes for no update (cuts), every sample counted, and
# no samples judged (the jitter alone).
_NO_CUTS = np.zeros(0, dtype=np.intp)
_EVERY = np.zeros(0, dtype=np.bool_)
_NO_SAMPLES = np.zeros(0)


def first_judged(
    t: FloatArray,
    errors: dict[str, FloatArray],
    numbers: MissionNumbers,
) -> float | None:
    """[s] when the estimate first comes within its convergence tolerance of the
    truth, each state's widened by three noise std, the position's x and y
    together (within the ellipse of their tolerances); None if it never does."""
    tolerance = {
        state: numbers.convergence_tolerance[state] + 3.0 * numbers.noise[state] for state in errors
    }
    if jit.judging_compiled():  # the same sample in one compiled pass (verdicts/passes.py)
        columns = (errors["x"], errors["y"], errors["theta"])
        bounds = (tolerance["x"], tolerance["y"], tolerance["theta"])
        first = jit.compiled(first_within)(columns, bounds, _NEAR_ONE)
        return float(t[first]) if first >= 0 else None
    within = _within_one(errors["x"] / tolerance["x"], errors["y"] / tolerance["y"])
    within &= np.abs(errors["theta"]) <= tolerance["theta"]
    found = np.flatnonzero(within)
    return float(t[found[0]]) if found.size else None


def _within_one(a: FloatArray, b: FloatArray) -> NDArray[np.bool_]:
    """``np.hypot(a, b) <= 1.0``, hypot taken only where the squares' sum is
    within a relative 1e-9 of 1 (the C library's hypot costs about ten times
    the squares; each is a few roundings of 1e-16 from the exact value)."""
    with np.errstate(over="ignore"):  # an inf square is beyond 1, as its hypot
        squared = a * a + b * b
    within: NDArray[np.bool_] = squared <= 1.0 - _NEAR_ONE
    near = np.flatnonzero(np.abs(squared - 1.0) < _NEAR_ONE)
    within[near] = np.hypot(a[near], b[near]) <= 1.0
    return within


def input_quality(
    t: FloatArray,
    v: FloatArray,
    omega: FloatArray,
    numbers: MissionNumbers,
    progress: Progress,
    counted: NDArray[np.bool_] | None = None,
    cuts: Sequence[int] = (),
) -> dict[str, Any]:
    """The input metrics of a phase's judged samples (``inputs`` in its summary);
    ``counted``: per sample, whether the jitter counts it (None: all);
    ``cuts``: the samples a new reference took over at (an update): a stretch
    at a limit is judged apart on each side of one, by the reference in force
    over it (a park sent back the way it came reverses at the limit, as it
    should)."""
    if jit.judging_compiled():  # the same numbers in one compiled pass (verdicts/passes.py)
        found = _passed(t, v, omega, numbers, counted, cuts)
        v_jump, v_reversals, v_stretches, omega_jump, omega_reversals, omega_fought, spread = found
        return {
            "speed_jump_max": _finite(v_jump),
            "speed_reversals": v_reversals,
            # the speed's stretches at its limit judged by the progress each makes
            "speed_fight_time": (
                fight_time(
                    v, numbers.v_limit, numbers, _drives(v.size, numbers, progress, cuts), cuts
                )
                if v_stretches
                else 0.0
            ),
            "turn_rate_jump_max": _finite(omega_jump),
            "turn_rate_reversals": omega_reversals,
            "turn_rate_fight_time": omega_fought * numbers.dt,
            "turn_rate_jitter": _finite(ROBUST_STD * spread),  # None for too few samples too: NaN
        }
    settings = _settings(numbers)
    metrics: dict[str, Any] = {}
    for name, values, limit, floor, deliberate in (
        ("speed", v, numbers.v_limit, settings.floors[0], _drives(t.size, numbers, progress, cuts)),
        ("turn_rate", omega, numbers.omega_limit, settings.floors[1], _turns(numbers)),
    ):
        jumps = np.abs(np.diff(values))
        metrics[f"{name}_jump_max"] = _finite(jumps.max()) if jumps.size else 0.0
        metrics[f"{name}_reversals"] = most_reversals(t, values, floor, settings.window)
        metrics[f"{name}_fight_time"] = fight_time(values, limit, numbers, deliberate, cuts)
    metrics["turn_rate_jitter"] = jitter(omega, numbers, counted)
    return metrics


def _drives(
    samples: int, numbers: MissionNumbers, progress: Progress, cuts: Sequence[int]
) -> Callable[[int, int], bool]:
    """Whether a stretch ``a .. b - 1`` of a phase's ``samples`` at the speed
    limit is a deliberate drive: half the distance driven at the limit is
    progress. The motion a command makes comes the plant's input delay and
    actuator lag later: a reversal to the limit first moves the robot on the
    old way. Read no later than the next update or the phase's end: a stretch
    is judged by the motion of its own target, and never by fewer samples
    than it has."""
    later, ends = round(numbers.response / numbers.dt), sorted({*cuts, samples - 1})

    def drives(a: int, b: int) -> bool:
        end = next((c for c in ends if c >= b), b)
        shift = max(0, min(later, end - b))
        distance = DELIBERATE * numbers.v_limit * (b - a) * numbers.dt
        return progress(a + shift, b + shift) >= distance

    return drives


def _turns(numbers: MissionNumbers) -> Callable[[int, int], bool]:
    """Whether a stretch ``a .. b - 1`` at the turn-rate limit turns at most
    half a turn (a sample's turn for rounding)."""
    dt, limit = numbers.dt, numbers.omega_limit
    return lambda a, b: (b - a) * dt * limit <= math.pi + 2.0 * limit * dt


class _Settings(NamedTuple):
    """What the input metrics take of a mission's numbers."""

    floors: tuple[float, float]  # of the reversals: the speed's, the turn rate's
    limits: tuple[float, float, float]  # the speed's, the turn rate's, the share at them
    window: float  # [s] the reversals are counted in
    samples: tuple[int, int, int]  # the shortest stretch, the jitter's half window and skip
    dt: float  # [s]


# The numbers last judged and their settings: a run's phases share their numbers.
_last: list[tuple[MissionNumbers, _Settings] | None] = [None]


def _settings(numbers: MissionNumbers) -> _Settings:
    """What the input metrics take of ``numbers``, made once for the numbers a
    run's phases share: the reversals' floors, REVERSAL_FLOOR of each limit
    and for the turn rate three times what raw heading noise makes of it;
    the stretches at a limit of one time constant or more (two samples at
    least)."""
    last = _last[0]
    if last is not None and last[0] is numbers:
        return last[1]
    tau, dt = numbers.time_constant, numbers.dt
    turn_rate = REVERSAL_FLOOR * numbers.omega_limit
    turn_rate += 3.0 * numbers.heading_noise / tau
    made = _Settings(  # floats, whatever the run's limits are: the pass compiled once
        (float(REVERSAL_FLOOR * numbers.v_limit), float(turn_rate)),
        (float(numbers.v_limit), float(numbers.omega_limit), 1.0 - AT_LIMIT),
        float(REVERSAL_WINDOW * tau),
        (max(2, round(tau / dt)), *_jitter_window(numbers)),
        float(dt),
    )
    _last[0] = (numbers, made)
    return made


def _passed(
    t: FloatArray,
    v: FloatArray,
    omega: FloatArray,
    numbers: MissionNumbers,
    counted: NDArray[np.bool_] | None,
    cuts: Sequence[int] = (),
) -> tuple[float, int, int, float, int, int, float]:
    """:func:`wmr_mission.verdicts.passes.input_pass` of a phase's samples
    (``t`` empty: the jitter alone)."""
    floors, limits, window, samples, dt = _settings(numbers)
    return jit.compiled(input_pass)(
        t, v, omega, _EVERY if counted is None else counted, floors, limits, window, samples,
        np.array(cuts, dtype=np.intp) if len(cuts) else _NO_CUTS, dt,
    )  # fmt: skip


def _finite(value: Any) -> float | None:
    number = float(value)
    return number if math.isfinite(number) else None


def most_reversals(t: FloatArray, values: FloatArray, floor: float, window: float) -> int:
    """The most sign reversals of ``values`` within any ``window`` [s]; values
    within ``floor`` of zero are skipped. A reversal happens at the sample that
    brings the new sign."""
    counted = np.flatnonzero(np.abs(values) > floor)
    signs = np.sign(values[counted])
    times = t[counted[1:][signs[1:] != signs[:-1]]]
    if times.size == 0:
        return 0
    dt = float(t[1] - t[0]) if t.size > 1 else 0.0
    # reversals in [time, time + window), half a sample short of it against rounding
    ends = np.searchsorted(times, times + window - 0.5 * dt, side="right")
    return int((ends - np.arange(times.size)).max())


def fight_time(
    values: FloatArray,
    limit: float,
    numbers: MissionNumbers,
    deliberate: Callable[[int, int], bool],
    cuts: Sequence[int] = (),
) -> float:
    """[s] spent at ``limit`` in stretches of one time constant or more (two
    samples at least) that change sign or are not ``deliberate(a, b)``, each
    judged apart on each side of one of ``cuts`` (an update)."""
    magnitude = np.abs(values)
    if not math.isfinite(limit) or values.size == 0 or magnitude.max() < limit * (1.0 - AT_LIMIT):
        return 0.0
    at = (magnitude >= limit * (1.0 - AT_LIMIT)).astype(np.int8)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], at, [0]))))
    shortest = max(2, round(numbers.time_constant / numbers.dt))
    fought = 0
    for a, b in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        if b - a >= shortest:
            fought += _fought(values, _cut(a, b, cuts), shortest, deliberate)
    return fought * numbers.dt


def _cut(a: int, b: int, cuts: Sequence[int]) -> list[tuple[int, int]]:
    """Samples ``a .. b - 1`` in pieces, cut at each of ``cuts`` inside them."""
    inside = [c for c in cuts if a < c < b]
    return list(zip([a, *inside], [*inside, b], strict=True))


def _fought(
    values: FloatArray,
    pieces: Sequence[tuple[int, int]],
    shortest: int,
    deliberate: Callable[[int, int], bool],
) -> int:
    """The samples of ``pieces`` of a stretch at a limit that fight it: each
    piece of ``shortest`` samples or more that changes sign or is not
    ``deliberate``."""
    fought = 0
    for a, b in pieces:
        if b - a < shortest:
            continue
        one_sign = bool(np.all(values[a:b] > 0) or np.all(values[a:b] < 0))
        if not (one_sign and deliberate(a, b)):
            fought += b - a
    return fought


def jitter(
    omega: FloatArray, numbers: MissionNumbers, counted: NDArray[np.bool_] | None = None
) -> float | None:
    """[rad/s] robust spread of ``omega`` about its centred moving mean over two
    time constants, after the first REVERSAL_WINDOW time constants, of the
    samples ``counted`` (None: all; all too if it counts none of them); None
    when fewer samples are left."""
    if jit.judging_compiled():  # the same numbers in one compiled pass (verdicts/passes.py)
        spread = _passed(_NO_SAMPLES, _NO_SAMPLES, omega, numbers, counted)[-1]
        return _finite(ROBUST_STD * spread)  # None for too few samples too: NaN
    found = _deviation(omega, numbers)
    if found is None:
        return None
    return _finite(ROBUST_STD * median(np.abs(_counted(*found, counted))))


def _counted(first: int, deviation: FloatArray, counted: NDArray[np.bool_] | None) -> FloatArray:
    """The ``deviation`` (from sample ``first`` on) of the samples ``counted``,
    all of it if that is none (a phase judged on none of its samples)."""
    if counted is None:
        return deviation
    kept = deviation[counted[first : first + deviation.size]]
    return kept if kept.size else deviation


def _jitter_window(numbers: MissionNumbers) -> tuple[int, int]:
    """Half the moving mean's window and the samples skipped at the start [samples]."""
    half = max(2, round(numbers.time_constant / numbers.dt))
    return half, round(REVERSAL_WINDOW * numbers.time_constant / numbers.dt)


def median(values: FloatArray) -> float:
    """``np.median(values)`` of a non-empty 1-d array, the same bits (the middle
    value, or the two middle ones' sum halved; NaN if any is) at a quarter of
    its cost: numpy's general axis handling is most of it on a phase's samples."""
    half = values.size // 2
    middle = (half,) if values.size % 2 else (half - 1, half)
    part = np.partition(values, (*middle, -1))  # the last: the largest, NaN if any
    if np.isnan(part[-1]):
        return math.nan
    return float(part[half]) if values.size % 2 else float((part[half - 1] + part[half]) / 2)


def jitter_deviation(
    omega: FloatArray, numbers: MissionNumbers, counted: NDArray[np.bool_] | None = None
) -> FloatArray:
    """Per sample, what :func:`jitter` takes the spread of: ``omega`` less its
    centred moving mean; NaN at the samples it does not count."""
    deviation = np.full(omega.size, np.nan)
    found = _deviation(omega, numbers)
    if found is not None:
        first, values = found
        deviation[first : first + values.size] = values
        if counted is not None and _counted(first, values, counted).size < values.size:
            deviation[~counted] = np.nan
    return deviation


def _deviation(omega: FloatArray, numbers: MissionNumbers) -> tuple[int, FloatArray] | None:
    """The first sample :func:`jitter` counts and, from it, ``omega`` less its
    centred moving mean over two time constants; None when too few samples."""
    half, skip = _jitter_window(numbers)
    window = 2 * half + 1
    if omega.size < skip + window:
        return None
    # Summed in order, not by np.convolve: its products are BLAS's, whose
    # kernels, chosen by the CPU, round differently (docs/reliability.md).
    centres = omega.size - window + 1
    total = np.zeros(centres)
    for offset in range(window):
        total += omega[offset : offset + centres]
    deviation = omega[half : half + centres] - total / window
    dropped = max(0, skip - half)
    return half + dropped, deviation[dropped:]


def progress_along(x: FloatArray, y: FloatArray, rx: FloatArray, ry: FloatArray) -> Progress:
    """Progress from sample a to b on a path: the robot's travel, step by step,
    projected on the path's direction (the reference's own step) or on the
    direction to the reference point, whichever adds up to more."""

    def progress(a: int, b: int) -> float:
        end = min(b, x.size - 1)
        if end <= a:
            return 0.0
        dx, dy = np.diff(x[a : end + 1]), np.diff(y[a : end + 1])
        along_path = (np.diff(rx[a : end + 1]), np.diff(ry[a : end + 1]))
        towards = (rx[a:end] - x[a:end], ry[a:end] - y[a:end])
        best = -math.inf
        for ux, uy in (along_path, towards):
            norm = np.hypot(ux, uy)
            ok = norm > 0
            best = max(best, float(np.sum((dx[ok] * ux[ok] + dy[ok] * uy[ok]) / norm[ok])))
        return best

    return progress


def progress_to(
    x: FloatArray, y: FloatArray, aim: tuple[float, float] | tuple[FloatArray, FloatArray]
) -> Progress:
    """Progress from sample a to b: how much nearer the aim the robot came; with
    an aim per sample (a target an update moved), the sum over the stretches of
    each aim of the progress towards the one in force over it, the robot's way
    judged by where it was being sent at each sample (not by a target that took
    over at b, the sample after the stretch)."""
    if np.ndim(aim[0]) == 0:  # one aim: the progress towards it
        to = (float(aim[0]), float(aim[1]))

        def towards(a: int, b: int) -> float:
            end = min(b, x.size - 1)
            before = math.hypot(float(x[a]) - to[0], float(y[a]) - to[1])
            return before - math.hypot(float(x[end]) - to[0], float(y[end]) - to[1])

        return towards
    aim_x, aim_y = np.asarray(aim[0], dtype=float), np.asarray(aim[1], dtype=float)

    def progress(a: int, b: int) -> float:
        end = min(b, x.size - 1)
        # where the aim in force changes within the stretch
        moved = (np.diff(aim_x[a:end]) != 0) | (np.diff(aim_y[a:end]) != 0)
        cuts = [a, *(np.flatnonzero(moved) + a + 1).tolist(), end]
        total = 0.0
        for start, stop in itertools.pairwise(cuts):
            to = (float(aim_x[start]), float(aim_y[start]))
            before = math.hypot(float(x[start]) - to[0], float(y[start]) - to[1])
            total += before - math.hypot(float(x[stop]) - to[0], float(y[stop]) - to[1])
        return total

    return progress
