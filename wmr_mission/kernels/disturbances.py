"""Disturbances: the true plant and the sensors misbehave the way real robots do.

The controller and the estimator never see these settings; they act on the
true plant and the measurements only (docs/disturbances.md).

* Plant, per sample k: the plant applies ``u_{k-d}`` (input delay of d
  samples) through a first-order lag of time constant tau (exact for a
  command held over the sample: ``a_k = a_{k-1} + (1 - e^{-dt/tau})
  (u_{k-d} - a_{k-1})``); slip loses a fraction of v and adds a sideways skid
  speed; process noise is added to the new pose.
* Sensors: a measurement every ``period`` samples, with a constant bias, lost
  in bursts (a two-state Markov chain per measurement: a burst starts with
  probability p, goes on with probability 1 - 1/burst, so its length is
  geometric with mean ``burst``), now and then an outlier (a Gaussian error
  of its own spread added).

Every draw comes from the run's seed, drawn ahead by the runner
(wmr_mission.sim.draws): one row of :data:`DRAW_COLUMNS` per sample, read by
the compiled loop row by row.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.kernels.jit import kernel
from wmr_mission.kernels.model import step

# Columns of a row of draws (one row per sample).
MEASUREMENT_NOISE = 0  # 0..2: x, y, theta [m, m, rad], scaled
PROCESS_NOISE = 3  # 3..5: x, y, theta, scaled
SKID = 6  # sideways skid speed [m/s], scaled
DROPOUT = 7  # uniform on [0, 1)
OUTLIER = 8  # uniform on [0, 1)
OUTLIER_ERROR = 9  # 9..11: x, y, theta, scaled
DRAW_COLUMNS = 12


class Actuation(NamedTuple):
    """How the true plant applies the commands (see the module docstring)."""

    input_delay: int  # d [samples]
    lag: float  # 1 - exp(-dt / tau) per sample; 1.0 = no lag
    slip: float  # fraction of v lost
    # the largest change of the applied v and omega in one sample (the robot's
    # acceleration limits times dt; inf: none)
    speed_step: float = math.inf
    turn_step: float = math.inf


class Sensing(NamedTuple):
    """What the sensors measure and how they err (see the module docstring)."""

    measured: FloatArray  # (3,) 1.0 for each measured state (x, y, theta)
    period: int  # samples between measurements (1: every sample)
    bias: FloatArray  # (3,) [m, m, rad]
    dropout_start: float  # probability a burst starts at a measurement
    dropout_continue: float  # probability a burst goes on: 1 - 1/burst
    outlier_probability: float


# --- the compiled pieces of the loop (wmr_mission.kernels.loop) ------------------------


@kernel
def applied_input(
    actuation: Actuation, k: int, u: FloatArray, commands: FloatArray, applied: FloatArray
) -> None:
    """The input the plant applies over sample k, into ``applied``: u_{k-d}
    through the first-order lag. ``commands`` is a ring of the last d + 1
    commands (zero before the first), ``applied`` also the lag's state."""
    slots = actuation.input_delay + 1
    commands[k % slots, 0] = u[0]
    commands[k % slots, 1] = u[1]
    oldest = (k + 1) % slots  # the slot of u_{k-d}
    v = commands[oldest, 0]
    omega = commands[oldest, 1]
    before_v = applied[0]
    before_omega = applied[1]
    if actuation.lag < 1.0:
        applied[0] += actuation.lag * (v - applied[0])
        applied[1] += actuation.lag * (omega - applied[1])
    else:
        applied[0] = v
        applied[1] = omega
    if actuation.speed_step != math.inf:  # the robot accelerates no faster
        applied[0] = min(
            max(applied[0], before_v - actuation.speed_step), before_v + actuation.speed_step
        )
    if actuation.turn_step != math.inf:
        applied[1] = min(
            max(applied[1], before_omega - actuation.turn_step), before_omega + actuation.turn_step
        )


@kernel
def plant_step(
    state: FloatArray, applied: FloatArray, dt: float, actuation: Actuation, draws: FloatArray
) -> None:
    """Move the true pose one sample (eq. (1)) under slip and process noise;
    ``draws`` is the sample's row of draws. A disturbance that is off adds
    nothing, not even a rounding."""
    x = state[0]
    y = state[1]
    theta = state[2]
    v = applied[0]
    if actuation.slip != 0.0:
        v *= 1.0 - actuation.slip
    state[0], state[1], state[2] = step(x, y, theta, v, applied[1], dt)
    skid = draws[SKID]
    if skid != 0.0:  # sideways, across the heading the sample starts with
        state[0] -= dt * skid * math.sin(theta)
        state[1] += dt * skid * math.cos(theta)
    for i in range(3):
        if draws[PROCESS_NOISE + i] != 0.0:
            state[i] += draws[PROCESS_NOISE + i]


@kernel
def sense(
    state: FloatArray,
    k: int,
    sensing: Sensing,
    draws: FloatArray,
    burst: IntArray,
    measurement: FloatArray,
) -> bool:
    """The measurement of the true pose at sample k into ``measurement``;
    False when there is none (between periods, or lost). ``burst[0]`` is 1
    while a burst of lost measurements goes on."""
    if k % sensing.period != 0:
        return False
    if sensing.dropout_start > 0.0:
        chance = sensing.dropout_continue if burst[0] else sensing.dropout_start
        burst[0] = 1 if draws[DROPOUT] < chance else 0
        if burst[0]:
            return False
    outlier = draws[OUTLIER] < sensing.outlier_probability
    for i in range(3):
        value = state[i] + draws[MEASUREMENT_NOISE + i]
        if sensing.bias[i] != 0.0:
            value += sensing.bias[i]
        if outlier:
            value += draws[OUTLIER_ERROR + i]
        measurement[i] = value
    return True
