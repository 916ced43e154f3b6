"""The numbers of a mission that its verdicts are made of.

The input limits, the sampling period, the sensors' noise, the tracking law's
time constant and look-ahead: every default threshold of `expect` that is not
a fixed number is derived from these (docs/mission-format.md, "Verdicts").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

from wmr_mission.controllers.paper import Tracking
from wmr_mission.spec import models

STATES = ("x", "y", "theta")
# [m] the fixed part of the tracking tolerance: about a quarter of a small
# robot's width; the sensors' position noise is added to it.
TRACKING_TOLERANCE = 0.1
# Five time constants leave under 1 % of an error (exp(-5) = 0.0067).
SETTLING = 5.0
# An `auto` along-track lag allows the distance the reference covers in this many
# time constants: the designed error dynamics take out 95 % of an error in them.
LAG_TIME_CONSTANTS = 3.0
# Below this share of the limit, a gap is closed at that share at least.
LEAST_CLOSING = 0.1
# The look-ahead when the mission leaves it unset: max(MIN_LOOK_AHEAD, limits.v * dt).
MIN_LOOK_AHEAD = 0.05


class MissionNumbers(NamedTuple):
    dt: float  # [s]
    v_limit: float  # [m/s]
    omega_limit: float  # [rad/s]
    time_constant: float  # [s] of the tracking law; one sample for the one-sample laws
    look_ahead: float  # [m] of the tracked point ahead of the axle; 0 for the axle law
    noise: Mapping[str, float]  # std of each measured state [m, m, rad]; 0 if not measured
    convergence_tolerance: Mapping[str, float]  # expect.convergence_tolerance
    # [m/s^2] the tighter of limits.acceleration.v and limits.v_rate (inf: none)
    v_acceleration: float = math.inf
    # [rad/s^2] the tighter of limits.acceleration.omega and limits.omega_rate (inf: none)
    omega_acceleration: float = math.inf
    # [m] how far the robot's body reaches from the axle's centre (robot.footprint); 0: a point
    body: float = 0.0
    # [s] how much later the motion a command makes comes: the plant's input delay
    # and actuator time constant (robot.disturbances); 0 without them
    response: float = 0.0

    @property
    def position_noise(self) -> float:
        """[m] the larger of the x and y noise std."""
        return max(self.noise["x"], self.noise["y"])

    @property
    def heading_noise(self) -> float:
        return self.noise["theta"]

    @property
    def tracking_tolerance(self) -> float:
        """[m] how far off its path (or behind) a robot that tracks may be, noise aside."""
        return TRACKING_TOLERANCE + self.position_noise

    def lag_allowance(self, reference_speed: float) -> float:
        """[m] what an `auto` along_track_lag_max stands for, the reference's top
        speed ``reference_speed``: the tracking tolerance and the distance the
        reference covers in LAG_TIME_CONSTANTS time constants."""
        return self.tracking_tolerance + LAG_TIME_CONSTANTS * self.time_constant * reference_speed

    @property
    def keeping_up_speed(self) -> float:
        """[m/s] how far a robot's velocity may be from its reference's (or across
        its path) while it keeps up: the tracking tolerance over the settling
        time, SETTLING time constants."""
        return self.tracking_tolerance / (SETTLING * self.time_constant)

    def recovery_time(self, error: float, reference_speed: float) -> float:
        """[s] the least time the limits need to take out a position error while the
        reference moves on: turn round (at most half a turn, under the turn-rate
        limit and its acceleration limit), accelerate to the reference's speed,
        close the gap and what the reference gained in the time the acceleration
        limits add at the speed the limit leaves over the reference's (a tenth of
        the limit at least), and settle (five time constants). Without acceleration
        limits the turn is pi / omega_limit and nothing more is lost.

        A reference at or above the speed limit leaves no speed to close a gap
        with: no time is allowed for it, and the lag it leaves is judged (a
        robot 1.3 m behind a path at 0.8 m/s, its limit 0.62, was excused for
        the rest of its phase, judged at the tenth of the limit)."""
        turn = half_turn_time(self.omega_limit, self.omega_acceleration)
        if reference_speed >= self.v_limit:
            return turn + reference_speed / self.v_acceleration + SETTLING * self.time_constant
        closing = max(self.v_limit - reference_speed, LEAST_CLOSING * self.v_limit)
        # What the reference gains meanwhile: while the turn takes longer than at the
        # rate limit, and while the robot accelerates from rest to its speed (half
        # that time's distance).
        lost = reference_speed * (
            (turn - math.pi / self.omega_limit) + reference_speed / (2.0 * self.v_acceleration)
        )
        return (
            (error + lost) / closing
            + turn
            + reference_speed / self.v_acceleration
            + SETTLING * self.time_constant
        )


def half_turn_time(rate: float, acceleration: float) -> float:
    """[s] the least time to turn half a turn from rest at turn rates up to ``rate``
    and a turn-rate acceleration ``acceleration`` (inf: none): up to the rate,
    across at it, and down again, or up and down if the rate is not reached."""
    if math.pi * acceleration < rate * rate:  # the rate is not reached
        return 2.0 * math.sqrt(math.pi / acceleration)
    return math.pi / rate + rate / acceleration


def _get(mapping: Any, *keys: str) -> Any:
    for key in keys:
        # a resolved mission's dicts told apart without the abstract class's slower
        # check, and a missing key without it too (most acceleration limits are)
        if type(mapping) is not dict and (mapping is None or not isinstance(mapping, Mapping)):
            return None
        mapping = mapping.get(key)
    return mapping


def _acceleration(limits: Any, state: str, rate_key: str) -> float:
    """[m/s^2 or rad/s^2] the tighter of limits.acceleration.STATE and
    limits.STATE_rate (``rate_key``), as ``min`` of those set picks it."""
    acceleration, rate = _get(limits, "acceleration", state), _get(limits, rate_key)
    if acceleration is None:
        return math.inf if rate is None else float(rate)
    if rate is None:
        return float(acceleration)
    first, second = float(acceleration), float(rate)
    return second if second < first else first


# The tracking law's defaults (read once: a model is not made per run judged).
_DEFAULT_OUTPUT = Tracking.model_fields["output"].default
_DEFAULT_TIME_CONSTANT = Tracking.model_fields["time_constant"].default


def mission_numbers(
    mission: Mapping[str, Any] | None, dt: float, limits: tuple[float, float]
) -> MissionNumbers:
    """The numbers of the resolved ``mission`` (``Mission.model_dump(mode="json")``),
    or the defaults where it says nothing; ``dt`` and ``limits`` are the run's."""
    tracking = _get(mission, "controller", "tracking") or {}
    axle = tracking.get("output", _DEFAULT_OUTPUT) == "axle"
    time_constant = 0.0 if axle else float(tracking.get("time_constant", _DEFAULT_TIME_CONSTANT))
    look_ahead = tracking.get("look_ahead")
    if axle:
        look_ahead = 0.0
    elif look_ahead is None:
        look_ahead = max(MIN_LOOK_AHEAD, limits[0] * dt)
    sensors = _get(mission, "sensors")
    measured = _get(sensors, "measure") or STATES
    noise_std = _get(sensors, "noise_std") or {}
    noise = {s: float(noise_std.get(s) or 0.0) if s in measured else 0.0 for s in STATES}
    tolerance = _get(mission, "expect", "convergence_tolerance") or {}
    default = models.DEFAULT_CONVERGENCE_TOLERANCE
    robot = _get(mission, "robot")
    robot_limits = _get(robot, "limits")
    disturbances = _get(robot, "disturbances")
    return MissionNumbers(
        dt=dt,
        v_limit=limits[0],
        omega_limit=limits[1],
        # A law cannot act faster than one sample: the one-sample laws' time constant.
        time_constant=max(time_constant, dt),
        look_ahead=float(look_ahead),
        noise=noise,
        convergence_tolerance={
            "x": float(tolerance.get("x") or default),
            "y": float(tolerance.get("y") or default),
            "theta": float(tolerance.get("theta") or default),
        },
        v_acceleration=_acceleration(robot_limits, "v", "v_rate"),
        omega_acceleration=_acceleration(robot_limits, "omega", "omega_rate"),
        body=_body(_get(robot, "footprint")),
        # the input delay and the actuator's time constant
        response=0.0
        + float(_get(disturbances, "input_delay") or 0.0)
        + float(_get(disturbances, "actuator_time_constant") or 0.0),
    )


def _body(footprint: Mapping[str, Any] | None) -> float:
    """[m] a footprint's radius, or its farthest corner from the axle's centre."""
    if not footprint:
        return 0.0
    if "radius" in footprint:
        return float(footprint["radius"])
    return max(math.hypot(float(x), float(y)) for x, y in footprint["polygon"])
