"""Every random draw of a run, drawn ahead in blocks: the measurement noise and
the disturbances (wmr_mission.kernels.disturbances).

Every draw comes from the run's seed: the measurement noise from
``default_rng(seed)`` (as without disturbances), each disturbance from its
own child stream ``SeedSequence(seed).spawn(...)[i]`` with a fixed i, so
turning one disturbance on never changes the draws of another. The runner
draws them ahead in blocks, one row of ``DRAW_COLUMNS`` per sample, and the
compiled loop reads row by row.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.disturbances import (
    DRAW_COLUMNS,
    DROPOUT,
    MEASUREMENT_NOISE,
    OUTLIER,
    PROCESS_NOISE,
    SKID,
    Actuation,
    Sensing,
)

# Child streams of the run's seed, one per disturbance; fixed forever, so a
# run's draws never depend on which other disturbances are on.
PROCESS_STREAM = 0
SKID_STREAM = 1
DROPOUT_STREAM = 2
OUTLIER_STREAM = 3


@dataclass(frozen=True, eq=False)
class DisturbancePlan:
    """A mission's disturbances in plain numbers (samples where the loop counts),
    built by wmr_mission.sim.plan."""

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
    acceleration: tuple[float, float] = (math.inf, math.inf)  # the robot's [m/s^2, rad/s^2]

    def active(self) -> bool:
        """Whether any disturbance is on."""
        return self != DisturbancePlan()

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, DisturbancePlan):
            return NotImplemented
        return all(
            np.array_equal(getattr(self, name), getattr(other, name))
            for name in self.__dataclass_fields__
        )

    __hash__ = None  # type: ignore[assignment]

    def records(self, dt: float, measured: FloatArray) -> tuple[Actuation, Sensing]:
        """The records the loop's plant and sensors read; ``measured`` is 1.0
        for each measured state."""
        lag = 1.0 if self.time_constant == 0.0 else -math.expm1(-dt / self.time_constant)
        speed, turn = self.acceleration
        actuation = Actuation(self.input_delay, lag, self.slip, speed * dt, turn * dt)
        sensing = Sensing(
            measured,
            self.period,
            np.asarray(self.bias, dtype=np.float64),
            self.dropout_probability,
            1.0 - 1.0 / self.dropout_burst,
            self.outlier_probability,
        )
        return actuation, sensing


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

    def __init__(self, noise_std: FloatArray, disturbances: DisturbancePlan, seed: int) -> None:
        noise_std = np.asarray(noise_std, dtype=np.float64).copy()
        # (first column, draw, scale of each column)
        groups: list[tuple[int, Draw, FloatArray]] = []
        if noise_std.any():  # noise-free: zeros, instead of draws scaled by zero
            # The measurement noise is the seed's own stream, as it was before
            # disturbances existed: a mission without them keeps its trajectory.
            noise = np.random.default_rng(seed)
            groups.append((MEASUREMENT_NOISE, lambda n: noise.standard_normal((n, 3)), noise_std))
        process_std = np.asarray(disturbances.process_noise_std, dtype=np.float64)
        if process_std.any():
            process = stream(seed, PROCESS_STREAM)
            groups.append((PROCESS_NOISE, lambda n: process.standard_normal((n, 3)), process_std))
        if disturbances.skid_std > 0.0:
            skid = stream(seed, SKID_STREAM)
            skid_std = np.array([disturbances.skid_std])
            groups.append((SKID, lambda n: skid.standard_normal((n, 1)), skid_std))
        if disturbances.dropout_probability > 0.0:
            dropout = stream(seed, DROPOUT_STREAM)
            groups.append((DROPOUT, lambda n: dropout.random((n, 1)), np.ones(1)))
        if disturbances.outlier_probability > 0.0:
            outliers = stream(seed, OUTLIER_STREAM)
            outlier_scale = np.concatenate([[1.0], disturbances.outlier_std])

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
