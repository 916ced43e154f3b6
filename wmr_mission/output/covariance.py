"""An estimator's own standard deviation per sample, for the estimation
figure's +-3 std band (the EKF's: the square roots of its covariance's diagonal).

`trajectory.csv` has no covariance column, and needs none: an estimator's
memory (the EKF's covariance P) follows from what the run records. Each step
takes the memory, the estimate x_{k|k}, the command u_k and whether the
sensors measured at k+1 (row k+1's `*_meas`: NaN where nothing came), and an
innovation gate reads that measurement. So the estimator's own step, as its
registration names it, is run again over the recorded columns, and its
estimate is compared with the recorded one at every sample: where they part
(a run whose files were edited, a backend's estimate from other inputs), the
band stops there rather than show a covariance of another run. An estimator
registers ``spread`` to have a band (wmr_mission.estimators.registry).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from wmr_mission.basics import STATES, FloatArray, measurement_mask
from wmr_mission.estimators import ESTIMATORS
from wmr_mission.estimators.registry import EstimatorType, Measurements
from wmr_mission.fields import type_name
from wmr_mission.kernels import jit
from wmr_mission.kernels.jit import kernel
from wmr_mission.kernels.model import wrap_angle
from wmr_mission.kernels.variants import estimator_spread, estimator_step

if TYPE_CHECKING:
    from wmr_mission.record import RunRecord

# The replayed estimate may differ from the recorded one by this much [m, rad]:
# trajectory.csv keeps 12 significant digits, so a run read back from its
# files replays within about 1e-9; a larger difference is another run.
REPLAY_TOLERANCE: Final = 1e-6


def band_estimator(result: RunRecord) -> EstimatorType | None:
    """The registered estimator of the run when it reports a spread (and runs
    no code of the mission's: a plug-in is not run again to draw a figure)."""
    written = (result.mission or {}).get("estimator") or {}
    settings = ESTIMATORS.settings_for(written)
    kind = None if settings is None else ESTIMATORS[type_name(settings)]
    return kind if kind is not None and kind.spread is not None and not kind.plugin else None


def estimate_std(result: RunRecord) -> FloatArray | None:
    """Per sample, the standard deviation of the estimate's error per state
    that the estimator itself holds [m, m, rad] (shape ``(samples, 3)``, NaN
    from where the replay parts from the record); None when the run's
    estimator holds none (its registration has no ``spread``)."""
    kind = band_estimator(result)
    if kind is None or kind.spread is None or result.samples == 0:
        return None
    mission: dict[str, Any] = result.mission or {}
    sensors = mission.get("sensors") or {}
    mask = measurement_mask(sensors.get("measure") or list(STATES))
    noise = sensors.get("noise_std") or {}
    noise_std = np.array(
        [float(noise.get(s) or 0.0) if m else 0.0 for s, m in zip(STATES, mask, strict=True)]
    )
    settings = kind.settings.model_validate(mission["estimator"])
    tuning = kind.tuning_of(settings, Measurements(mask, noise_std, result.dt))
    estimate = np.array([result.x_est[0], result.y_est[0], result.theta_est[0]], dtype=np.float64)
    std = np.full((result.samples, 3), np.nan)
    # Compiled where the loop is (about 1 µs a sample against 60 µs as plain
    # Python: `python benchmarks/measure.py band`): a long run's figure does
    # not wait for its band.
    # Cached on disk for the package's estimators only, as the loop is: the
    # cache's stamp covers the package's sources, and its index would name
    # another module's types to every process that loads it.
    parts = (kind.tuning_record, kind.step, kind.spread)
    cached = all(part.__module__.startswith("wmr_mission.") for part in parts)
    jit.compiled(_bound_replay(kind.step, kind.spread), cached=cached)(
        tuning, kind.new_memory(tuning, estimate), estimate, _floats(result.v),
        _floats(result.omega), result.dt, mask,
        _floats(np.column_stack([result.x_meas, result.y_meas, result.theta_meas])),
        _floats(np.column_stack([result.x_est, result.y_est, result.theta_est])), std,
    )  # fmt: skip
    return std


def _floats(values: FloatArray) -> FloatArray:
    return np.ascontiguousarray(values, dtype=np.float64)


@functools.cache
def _bound_replay(
    estimator_step: Callable[..., int], estimator_spread: Callable[..., None]
) -> Callable[..., None]:
    """:func:`_replay` with one estimator's step and spread, one copy per
    estimator, so each is compiled and cached once (as the loop is)."""
    return jit.bind(
        _replay, {"estimator_step": estimator_step, "estimator_spread": estimator_spread}
    )


@kernel
def _replay(
    tuning: Any,
    memory: Any,
    estimate: FloatArray,
    v: FloatArray,
    omega: FloatArray,
    dt: float,
    mask: FloatArray,
    sensed: FloatArray,
    recorded: FloatArray,
    std: FloatArray,
) -> None:
    """Fill ``std`` row by row while the estimator's step, fed the recorded
    commands and measurements, gives the recorded estimate."""
    measurement = np.zeros(3)
    estimator_spread(memory, std[0])
    for k in range(v.shape[0] - 1):
        measured = False
        for i in range(3):
            measurement[i] = 0.0
            if mask[i] > 0.0:
                value = sensed[k + 1, i]
                measured = math.isfinite(value)  # a measurement comes whole, or not
                measurement[i] = value if measured else 0.0
        estimator_step(tuning, memory, estimate, v[k], omega[k], dt, measurement, measured)
        for i in range(3):
            apart = estimate[i] - recorded[k + 1, i]
            if i == 2:
                apart = wrap_angle(apart)
            if not abs(apart) <= REPLAY_TOLERANCE * max(1.0, abs(estimate[i])):
                return  # another run's record: the band stops here
        estimator_spread(memory, std[k + 1])
