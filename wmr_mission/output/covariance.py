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

from typing import TYPE_CHECKING, Any, Final

import numpy as np

from wmr_mission.basics import STATES, FloatArray, measurement_mask
from wmr_mission.estimators.ekf import Ekf, new_memory, next_estimate, tuning_of
from wmr_mission.estimators.registry import Measurements

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
    memory = new_memory(tuning, estimate)
    sensed = np.column_stack([result.x_meas, result.y_meas, result.theta_meas])
    recorded = np.column_stack([result.x_est, result.y_est, result.theta_est])
    std = np.full((result.samples, 3), np.nan)
    std[0] = np.sqrt(np.diag(memory.covariance))
    for k in range(result.samples - 1):
        measurement = np.where(mask > 0.0, sensed[k + 1], 0.0)
        measured = bool(np.isfinite(measurement).all() and mask.any())
        next_estimate(
            tuning, memory, estimate, float(result.v[k]), float(result.omega[k]), result.dt,
            np.where(np.isfinite(measurement), measurement, 0.0), measured,
        )  # fmt: skip
        apart = np.abs(estimate - recorded[k + 1])
        apart[2] = abs((apart[2] + np.pi) % (2.0 * np.pi) - np.pi)
        if not bool((apart <= REPLAY_TOLERANCE * np.maximum(1.0, np.abs(estimate))).all()):
            break
        std[k + 1] = np.sqrt(np.diag(memory.covariance))
    return std
