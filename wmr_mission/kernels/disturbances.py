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

Every draw comes from the run's seed: the measurement noise from
``default_rng(seed)`` (as without disturbances), each disturbance from its
own child stream ``SeedSequence(seed).spawn(...)[i]`` with a fixed i, so
turning one disturbance on never changes the draws of another. The runner
draws them ahead in blocks, one row of :data:`DRAW_COLUMNS` per sample, and
the compiled loop reads row by row.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from wmr_mission.kernels.jit import kernel
from wmr_mission.kernels.model import step

if TYPE_CHECKING:
    from wmr_mission.spec.models import Mission

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

# Columns of a row of draws (one row per sample).
MEASUREMENT_NOISE = 0  # 0..2: x, y, theta [m, m, rad], scaled
PROCESS_NOISE = 3  # 3..5: x, y, theta, scaled
SKID = 6  # sideways skid speed [m/s], scaled
DROPOUT = 7  # uniform on [0, 1)
OUTLIER = 8  # uniform on [0, 1)
OUTLIER_ERROR = 9  # 9..11: x, y, theta, scaled
DRAW_COLUMNS = 12

# Child streams of the run's seed, one per disturbance; fixed forever, so a
# run's draws never depend on which other disturbances are on.
PROCESS_STREAM = 0
SKID_STREAM = 1
DROPOUT_STREAM = 2
OUTLIER_STREAM = 3


class Disturbances(NamedTuple):
    """The record the compiled loop reads (see the module docstring)."""

    input_delay: int  # d [samples]
    lag: float  # 1 - exp(-dt / tau) per sample; 1.0 = no lag
    slip: float  # fraction of v lost
    period: int  # samples between measurements (1: every sample)
    bias: FloatArray  # (3,) [m, m, rad]
    dropout_start: float  # probability a burst starts at a measurement
    dropout_continue: float  # probability a burst goes on: 1 - 1/burst
    outlier_probability: float


@dataclass(frozen=True, eq=False)
class Settings:
    """A mission's disturbances in plain numbers (samples where the loop counts)."""

    process_noise_std: FloatArray = field(default_factory=lambda: np.zeros(3))
    input_delay: int = 0  # samples
    time_constant: float = 0.0  # [s]
    slip: float = 0.0
    skid_std: float = 0.0  # [m/s]
    period: int = 1  # samples
    bias: FloatArray = field(default_factory=lambda: np.zeros(3))
    dropout_probability: float = 0.0
    dropout_burst: float = 1.0
    outlier_probability: float = 0.0
    outlier_std: FloatArray = field(default_factory=lambda: np.zeros(3))

    def active(self) -> bool:
        """Whether any disturbance is on."""
        return self != Settings()

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Settings):
            return NotImplemented
        return all(
            np.array_equal(getattr(self, name), getattr(other, name))
            for name in self.__dataclass_fields__
        )

    __hash__ = None  # type: ignore[assignment]

    def record(self, dt: float) -> Disturbances:
        lag = 1.0 if self.time_constant == 0.0 else -math.expm1(-dt / self.time_constant)
        return Disturbances(
            self.input_delay,
            lag,
            self.slip,
            self.period,
            np.asarray(self.bias, dtype=np.float64),
            self.dropout_probability,
            1.0 - 1.0 / self.dropout_burst,
            self.outlier_probability,
        )


def samples(seconds: float, dt: float) -> int:
    """A duration as whole samples (validate rejects one that is not)."""
    return round(seconds / dt)


def settings(mission: Mission) -> Settings:
    """The disturbances of a validated mission."""
    dt = float(mission.robot.dt)
    plant = mission.robot.disturbances
    sensors = mission.sensors

    def per_state(values: object) -> FloatArray:
        return np.array([getattr(values, name) for name in ("x", "y", "theta")], dtype=np.float64)

    dropout = sensors.dropout
    outliers = sensors.outliers
    return Settings(
        process_noise_std=per_state(plant.process_noise_std),
        input_delay=samples(plant.input_delay, dt),
        time_constant=float(plant.actuator_time_constant),
        slip=float(plant.slip.longitudinal),
        skid_std=float(plant.slip.lateral_std),
        period=1 if sensors.period is None else max(1, samples(sensors.period, dt)),
        bias=per_state(sensors.bias),
        dropout_probability=0.0 if dropout is None else float(dropout.probability),
        dropout_burst=1.0 if dropout is None else float(dropout.burst),
        outlier_probability=0.0 if outliers is None else float(outliers.probability),
        outlier_std=np.zeros(3) if outliers is None else per_state(outliers.std),
    )


def stream(seed: int, index: int) -> np.random.Generator:
    """Child ``index`` of the run's seed: ``SeedSequence(seed).spawn(n)[index]``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


# n rows of unscaled draws (standard normal or uniform) of a group of columns.
Draw = Callable[[int], FloatArray]


class Draws:
    """Every random draw of a run, one row of DRAW_COLUMNS per sample.

    Drawn in blocks of ``BLOCK`` rows, each group of columns from its own
    generator; a group that is off stays zero and draws nothing. The rows
    depend only on the seed, however the run is cut into chunks.
    """

    BLOCK = 4096

    def __init__(self, noise_std: FloatArray, settings: Settings, seed: int) -> None:
        noise_std = np.asarray(noise_std, dtype=np.float64).copy()
        # (first column, draw, scale of each column)
        groups: list[tuple[int, Draw, FloatArray]] = []
        if noise_std.any():  # noise-free: zeros, instead of draws scaled by zero
            # The measurement noise is the seed's own stream, as it was before
            # disturbances existed: a mission without them keeps its trajectory.
            noise = np.random.default_rng(seed)
            groups.append((MEASUREMENT_NOISE, lambda n: noise.standard_normal((n, 3)), noise_std))
        process_std = np.asarray(settings.process_noise_std, dtype=np.float64)
        if process_std.any():
            process = stream(seed, PROCESS_STREAM)
            groups.append((PROCESS_NOISE, lambda n: process.standard_normal((n, 3)), process_std))
        if settings.skid_std > 0.0:
            skid = stream(seed, SKID_STREAM)
            skid_std = np.array([settings.skid_std])
            groups.append((SKID, lambda n: skid.standard_normal((n, 1)), skid_std))
        if settings.dropout_probability > 0.0:
            dropout = stream(seed, DROPOUT_STREAM)
            groups.append((DROPOUT, lambda n: dropout.random((n, 1)), np.ones(1)))
        if settings.outlier_probability > 0.0:
            outliers = stream(seed, OUTLIER_STREAM)
            outlier_scale = np.concatenate([[1.0], settings.outlier_std])

            def outlier(n: int) -> FloatArray:
                which = outliers.random((n, 1))  # drawn first: the stream's order
                return np.hstack([which, outliers.standard_normal((n, 3))])

            groups.append((OUTLIER, outlier, outlier_scale))
        self._groups = groups
        self._ahead = np.zeros((0, DRAW_COLUMNS))

    def ahead(self) -> FloatArray:
        """The rows drawn and not yet used; the next block is drawn only once
        none are left (the loop stops where they run out)."""
        if not self._groups:  # nothing random: the same zeros serve every chunk
            if self._ahead.shape[0] == 0:
                self._ahead = np.zeros((self.BLOCK, DRAW_COLUMNS))
            return self._ahead
        if self._ahead.shape[0] == 0:
            block = np.zeros((self.BLOCK, DRAW_COLUMNS))
            for first, draw, scale in self._groups:
                values = draw(self.BLOCK)
                # Column by column: numpy is slow along rows of three.
                for j in range(scale.shape[0]):
                    np.multiply(values[:, j], scale[j], out=block[:, first + j])
            self._ahead = block
        return self._ahead

    def used(self, rows: int) -> None:
        """Mark the first ``rows`` rows of :meth:`ahead` as used."""
        if self._groups:
            self._ahead = self._ahead[rows:]


# --- the compiled pieces of the loop (wmr_mission.kernels.loop) ------------------------


@kernel
def applied_input(
    disturbances: Disturbances, k: int, u: FloatArray, commands: FloatArray, applied: FloatArray
) -> None:
    """The input the plant applies over sample k, into ``applied``: u_{k-d}
    through the first-order lag. ``commands`` is a ring of the last d + 1
    commands (zero before the first), ``applied`` also the lag's state."""
    slots = disturbances.input_delay + 1
    commands[k % slots, 0] = u[0]
    commands[k % slots, 1] = u[1]
    oldest = (k + 1) % slots  # the slot of u_{k-d}
    v = commands[oldest, 0]
    omega = commands[oldest, 1]
    if disturbances.lag < 1.0:
        applied[0] += disturbances.lag * (v - applied[0])
        applied[1] += disturbances.lag * (omega - applied[1])
    else:
        applied[0] = v
        applied[1] = omega


@kernel
def plant_step(
    state: FloatArray, applied: FloatArray, dt: float, disturbances: Disturbances, draws: FloatArray
) -> None:
    """Move the true pose one sample (eq. (1)) under slip and process noise;
    ``draws`` is the sample's row of draws. A disturbance that is off adds
    nothing, not even a rounding."""
    x = state[0]
    y = state[1]
    theta = state[2]
    v = applied[0]
    if disturbances.slip != 0.0:
        v *= 1.0 - disturbances.slip
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
    disturbances: Disturbances,
    draws: FloatArray,
    burst: IntArray,
    measurement: FloatArray,
) -> bool:
    """The measurement of the true pose at sample k into ``measurement``;
    False when there is none (between periods, or lost). ``burst[0]`` is 1
    while a burst of lost measurements goes on."""
    if k % disturbances.period != 0:
        return False
    if disturbances.dropout_start > 0.0:
        chance = disturbances.dropout_continue if burst[0] else disturbances.dropout_start
        burst[0] = 1 if draws[DROPOUT] < chance else 0
        if burst[0]:
            return False
    outlier = draws[OUTLIER] < disturbances.outlier_probability
    for i in range(3):
        value = state[i] + draws[MEASUREMENT_NOISE + i]
        if disturbances.bias[i] != 0.0:
            value += disturbances.bias[i]
        if outlier:
            value += draws[OUTLIER_ERROR + i]
        measurement[i] = value
    return True
