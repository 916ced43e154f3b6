"""A regulate phase judged by its progress to its target: no stall, no limit cycle.

Away from its goal, a regulator that works takes a share of its error out in
every stretch of time long enough to turn round and settle: PROGRESS of the
position error (or of the distance the speed limit covers in the stretch) or
of the heading error, in every WINDOW. A robot that stops short of its target,
or shakes in place in a limit cycle, does not; the time it spends so is
``stall_time``. A phase whose `until` is a goal that is never met times out
too; one that runs for a set time is judged by this alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import jit
from wmr_mission.spec.numbers import MissionNumbers
from wmr_mission.verdicts.passes import regulation_pass
from wmr_mission.verdicts.zones import Zone

# The share of its error a regulator takes out in every window, away from its goal.
PROGRESS = 0.1
# [time constants] a window is at least this long, and at least half a turn at
# the turn-rate limit and ten time constants (to turn round, then settle).
WINDOW = 20.0


def regulated(
    x: FloatArray,
    y: FloatArray,
    theta: FloatArray,
    target: tuple[float, float, float],
    goal: tuple[float, float],
    numbers: MissionNumbers,
    zones: Sequence[Zone] = (),
    finite: bool | None = None,
) -> tuple[float | None, float | None]:
    """:func:`stall_time` and :func:`overshoot` (its goal ``goal[0]``) of a
    stretch of poses (at least one): one compiled pass over them where the
    judge's passes run compiled (the same numbers). ``finite``: whether every
    pose is, if known."""
    if not jit.judging_compiled():
        return (
            stall_time(x, y, theta, target, goal, numbers, zones, finite),
            overshoot(x, y, target, goal[0], finite),
        )
    tx, ty, heading_target = float(target[0]), float(target[1]), float(target[2])
    way_x, way_y = tx - float(x[0]), ty - float(y[0])
    length = math.hypot(way_x, way_y)
    way_in = not length <= goal[0]  # else no overshoot: nothing beyond measured
    window, reach = _window(numbers)
    stalled, beyond, placed, turned = jit.compiled(regulation_pass)(
        x, y, theta, (tx, ty, heading_target), (float(goal[0]), float(goal[1])), window, reach,
        PROGRESS, (way_x, way_y, length) if way_in else (0.0, 0.0, 1.0),
    )  # fmt: skip
    stall = (
        None
        if not (placed and turned) or _beyond_a_zone(tx, ty, zones)
        else float(stalled) * numbers.dt
    )
    if not placed or not way_in:
        return stall, None
    beyond = float(beyond)
    if beyond == 0.0:  # which zero numpy's max keeps, and so max(., 0.0) gives, is its own
        return stall, overshoot(x, y, target, goal[0], True)
    return stall, max(beyond, 0.0)


def _window(numbers: MissionNumbers) -> tuple[int, tuple[float, float]]:
    """The samples of a window, and what the limits cover in it (position, heading)."""
    tau, dt = numbers.time_constant, numbers.dt
    span = max(WINDOW * tau, math.pi / numbers.omega_limit + 10.0 * tau)
    window = max(2, round(span / dt))
    return window, (numbers.v_limit * window * dt, numbers.omega_limit * window * dt)


def _beyond_a_zone(tx: float, ty: float, zones: Sequence[Zone]) -> bool:
    """Whether a target is beyond one of the phase's zones (the robot stops as
    near as the zone allows)."""
    return any(zone.holds_beyond(tx, ty) for zone in zones)


def stall_time(
    x: FloatArray,
    y: FloatArray,
    theta: FloatArray,
    target: tuple[float, float, float],
    goal: tuple[float, float],
    numbers: MissionNumbers,
    zones: Sequence[Zone] = (),
    finite: bool | None = None,
) -> float | None:
    """[s] the samples from which a whole window away from the goal (position and
    heading tolerances ``goal``) takes out neither PROGRESS of the position error
    (or of what the speed limit covers in the window) nor of the heading error;
    None for a target beyond one of the phase's zones (the robot stops as near as
    the zone allows) or after a divergence. ``finite``: whether every pose
    is, if known."""
    tx, ty, heading_target = target
    if _beyond_a_zone(tx, ty, zones):
        return None
    if finite is None:
        finite = bool(np.isfinite(x).all() and np.isfinite(y).all() and np.isfinite(theta).all())
    if not finite:
        return None
    dt = numbers.dt
    window, reach = _window(numbers)
    # (none of fewer samples than a window: the pass counts none, compiled even so)
    if jit.judging_compiled() and x.size:  # the same count in one compiled pass (passes.py)
        return regulated(x, y, theta, target, goal, numbers)[0]
    if x.size <= window:
        return 0.0
    position = np.hypot(x - tx, y - ty)
    heading = np.abs((theta - heading_target + np.pi) % (2 * np.pi) - np.pi)
    at_goal = (position <= goal[0]) & (heading <= goal[1])
    reached = np.concatenate(([0], np.cumsum(at_goal, dtype=np.int64)))
    away = reached[window + 1 :] - reached[: -window - 1] == 0  # no sample of k..k+window at it
    start, end = position[:-window], position[window:]
    closer = start - end >= PROGRESS * np.minimum(start, reach[0])
    turn_start, turn_end = heading[:-window], heading[window:]
    turned = turn_start - turn_end >= PROGRESS * np.minimum(turn_start, reach[1])
    return float(np.count_nonzero(away & ~closer & ~turned)) * dt


def overshoot(
    x: FloatArray,
    y: FloatArray,
    target: tuple[float, float, float],
    goal: float,
    finite: bool | None = None,
) -> float | None:
    """[m] How far the robot went past its target: the largest distance beyond
    the target along the way from where the phase started to it (0 if never);
    None for a phase that starts within ``goal`` [m] of its target (it has no
    way in) or after a divergence. A regulator that plans its deceleration
    stops within its goal. ``finite``: whether every position is, if known."""
    if finite is None:
        finite = bool(np.isfinite(x).all() and np.isfinite(y).all())
    if not finite:
        return None
    tx, ty = target[0], target[1]
    way_x, way_y = tx - float(x[0]), ty - float(y[0])
    length = math.hypot(way_x, way_y)
    if length <= goal:
        return None
    beyond = ((x - tx) * way_x + (y - ty) * way_y) / length
    return max(float(beyond.max()), 0.0)
