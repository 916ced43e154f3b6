"""The EKF's standard deviation per sample, for the estimation figure's +-3 std band.

`trajectory.csv` has no covariance column, and needs none: the filter's
covariance P follows from what the run records. Each step takes P_k, the
estimate x_{k|k} (its Jacobian), the command u_k and whether the sensors
measured at k+1 (row k+1's `*_meas`: NaN where nothing came), and the
innovation gate reads that measurement. So the filter's own step
(:func:`wmr_mission.estimators.ekf.next_estimate`) is run again over the
recorded columns, and its estimate is compared with the recorded one at
every sample: where they part (a run whose files were edited, a backend's
estimate from other inputs), the band stops there rather than show a
covariance of another run.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from wmr_mission.basics import STATES, FloatArray, measurement_mask
from wmr_mission.estimators.ekf import (
    Ekf,
    EkfMemory,
    EkfTuning,
    new_memory,
    next_estimate,
    tuning_of,
)
from wmr_mission.estimators.registry import Measurements
from wmr_mission.kernels import jit
from wmr_mission.kernels.jit import kernel
from wmr_mission.kernels.model import wrap_angle

if TYPE_CHECKING:
    from wmr_mission.output.result import RunResult

# The replayed estimate may differ from the recorded one by this much [m, rad]:
# trajectory.csv keeps 12 significant digits, so a run read back from its
# files replays within about 1e-9; a larger difference is another run.
REPLAY_TOLERANCE: Final = 1e-6


def ekf_std(result: RunResult) -> FloatArray | None:
    """Per sample, the square roots of the diagonal of the EKF's covariance
    P_{k|k} [m, m, rad] (shape ``(samples, 3)``, NaN from where the replay
    parts from the record); None when the run's estimator is not the EKF."""
    mission: dict[str, Any] = result.mission or {}
    estimator = mission.get("estimator") or {}
    if estimator.get("type") != "ekf" or result.samples == 0:
        return None
    sensors = mission.get("sensors") or {}
    measure = sensors.get("measure") or list(STATES)
    noise = sensors.get("noise_std") or {}
    mask = measurement_mask(measure)
    noise_std = np.array(
        [float(noise.get(s) or 0.0) if m else 0.0 for s, m in zip(STATES, mask, strict=True)]
    )
    tuning = tuning_of(Ekf.model_validate(estimator), Measurements(mask, noise_std, result.dt))
    estimate = np.array([result.x_est[0], result.y_est[0], result.theta_est[0]], dtype=np.float64)
    std = np.full((result.samples, 3), np.nan)
    # Compiled where the loop is (about 0.1 µs a sample against 65 µs as plain
    # Python): a long run's figure does not wait for its band.
    jit.compiled(_replay)(
        tuning, new_memory(tuning, estimate), estimate, _floats(result.v),
        _floats(result.omega), result.dt,
        _floats(np.column_stack([result.x_meas, result.y_meas, result.theta_meas])),
        _floats(np.column_stack([result.x_est, result.y_est, result.theta_est])), std,
    )  # fmt: skip
    return std


def _floats(values: FloatArray) -> FloatArray:
    return np.ascontiguousarray(values, dtype=np.float64)


@kernel
def _replay(
    tuning: EkfTuning,
    memory: EkfMemory,
    estimate: FloatArray,
    v: FloatArray,
    omega: FloatArray,
    dt: float,
    sensed: FloatArray,
    recorded: FloatArray,
    std: FloatArray,
) -> None:
    """Fill ``std`` row by row while the filter's step, fed the recorded
    commands and measurements, gives the recorded estimate."""
    covariance = memory.covariance
    mask = tuning.mask
    measurement = np.zeros(3)
    for i in range(3):
        std[0, i] = math.sqrt(covariance[i, i])
    for k in range(v.shape[0] - 1):
        measured = False
        for i in range(3):
            measurement[i] = 0.0
            if mask[i] > 0.0:
                value = sensed[k + 1, i]
                measured = math.isfinite(value)  # a measurement comes whole, or not
                measurement[i] = value if measured else 0.0
        next_estimate(tuning, memory, estimate, v[k], omega[k], dt, measurement, measured)
        for i in range(3):
            apart = estimate[i] - recorded[k + 1, i]
            if i == 2:
                apart = wrap_angle(apart)
            if not abs(apart) <= REPLAY_TOLERANCE * max(1.0, abs(estimate[i])):
                return  # another run's record: the band stops here
        for i in range(3):
            std[k + 1, i] = math.sqrt(covariance[i, i])
