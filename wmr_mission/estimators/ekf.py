"""A baseline extended Kalman filter on the same plant and measurements, so a
mission can compare the paper's estimator with the standard one.

Predict with eq. (1) and its Jacobian; update with the measured subset using
the Joseph form ``P = (I - K C) P (I - K C)^T + K R K^T`` (stays symmetric and
positive definite where the short form drifts), heading residual wrapped.
Unmeasured states are handled by zero rows of ``C``: their innovation is zero
and their measurement variance is set to 1, which leaves the gain exactly zero
on them. An optional innovation gate (a Mahalanobis test) rejects a wild
measurement; a sample without a measurement is the prediction alone.
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple, Self

import numpy as np
from pydantic import Field

from wmr_mission.basics import STATES, FloatArray, StateName
from wmr_mission.estimators.observer import CHI_SQUARE_GATE, MAX_REJECTED
from wmr_mission.estimators.registry import EstimatorSettings, EstimatorType, Measurements
from wmr_mission.fields import Model, Positive, StateStd
from wmr_mission.kernels.jit import inlined, kernel
from wmr_mission.kernels.model import jacobian_terms, step, wrap_angle

# The smallest measurement noise the filter assumes by default [m or rad]: a
# noise-free sensor would make the gain singular.
MEASUREMENT_STD_FLOOR = 1e-3


# The initial std, as a share of the noise std, of an estimate that starts at the
# true pose: sqrt((1 - 0.9) / 0.9), the first gain the observer's default pole gives.
INITIAL_SHARE = 1.0 / 3.0

# --- settings: the mission's `estimator: {type: ekf, ...}` ---------------------


class StatePositiveStd(Model):
    """A strictly positive standard deviation per state."""

    x: Positive = Field(default=1.0, description="Standard deviation of x [m].")
    y: Positive = Field(default=1.0, description="Standard deviation of y [m].")
    theta: Positive = Field(default=0.5, description="Standard deviation of theta [rad].")


class Ekf(EstimatorSettings):
    """Baseline extended Kalman filter."""

    type: Literal["ekf"] = Field(description="Estimator kind.")
    initial_std: StatePositiveStd = Field(
        default_factory=lambda: StatePositiveStd(x=1.0, y=1.0, theta=0.5),
        description=(
            "Square root of the diagonal of P0 [m, m, rad], > 0; default 1, 1, 0.5, and with "
            "noisy sensors and initial_estimate unset (the estimate starts at the true pose) a "
            "third of each noise std (0.001 at least); with the heading unmeasured, the noisy "
            "positions the law's budget (docs/paper-notes.md, eq. 6-7)."
        ),
    )
    process_std: StateStd = Field(
        default_factory=lambda: StateStd(x=0.001, y=0.001, theta=0.001),
        description=(
            "Process noise per sample [m, m, rad], >= 0; default 0.001, and with noisy sensors "
            "(no robot.disturbances) less: x and y so that the estimate's noise takes at most "
            "1 % of the turn-rate limit through the tracking law, theta a third of its noise "
            "(0 when it is not measured: docs/paper-notes.md, eq. 6-7)."
        ),
    )
    measurement_std: dict[StateName, Positive] | None = Field(
        default=None,
        description=(
            "Measurement noise per measured state [m or rad], > 0; "
            "null = sensors.noise_std floored at 0.001."
        ),
    )
    innovation_gate: Positive | None = Field(
        default=None,
        description=(
            "Reject a measurement whose squared Mahalanobis distance r^T S^-1 r exceeds this "
            "(chi-square with as many degrees of freedom as measured states: 16.27 is its "
            "0.999 quantile for 3); a rejected measurement is a prediction-only step, at most "
            "3 in a row (then every measurement is taken until one is within it). "
            "null = no gating. Default with noisy sensors: the 1 - 1e-6 quantile (30.66 for 3)."
        ),
    )

    def with_sensors(
        self, measured_noise: dict[str, float], position_budget: float = math.inf
    ) -> Self:
        """With noisy sensors: an innovation gate, a position process noise
        that filters the position noise down to ``position_budget`` [m]
        (docs/paper-notes.md, "Eqs. (6)-(7) under position noise"), and, for
        an estimate that starts at the true pose (``initial_estimate`` unset),
        an initial std of a third of the noise std."""
        update: dict[str, object] = {}
        noisy = sum(std > 0.0 for std in measured_noise.values())
        if noisy and "innovation_gate" not in self.model_fields_set:
            update["innovation_gate"] = CHI_SQUARE_GATE[noisy - 1]
        # With the heading unmeasured it is inferred from the positions, and the
        # cross-track estimate is as noisy as the heading lets it be
        # (docs/paper-notes.md, "Eqs. (6)-(7) under position noise").
        quiet_heading = (
            "theta" not in measured_noise
            and math.isfinite(position_budget)
            and any(measured_noise.get(s, 0.0) > 0.0 for s in ("x", "y"))
        )
        if noisy and self.initial_estimate is None and "initial_std" not in self.model_fields_set:
            # The estimate starts at the true pose, so the first measurement is
            # weighed as the observer's default pole weighs it (a gain of 1 - 0.9:
            # P0 = R (1 - p) / p, a third of the noise std). P0 = 1 m took it
            # whole, and its noise kicked the turn rate from limit to limit at t = 0.
            # With the heading unmeasured, the noisy positions start as certain as
            # their process noise keeps them (the budget), as the observer starts
            # at its own poles there: the first seconds' noise would turn the heading.
            update["initial_std"] = StatePositiveStd(
                **{
                    s: (
                        position_budget
                        if quiet_heading and s != "theta" and measured_noise.get(s, 0.0) > 0.0
                        else max(measured_noise.get(s, 0.0), MEASUREMENT_STD_FLOOR) * INITIAL_SHARE
                    )
                    for s in STATES
                }
            )
        if "process_std" not in self.model_fields_set:
            written = self.process_std.model_dump()
            # Positions: the tracking law's budget. Heading: a third of its own
            # noise, as the observer's default pole leaves (0.23): a goal the
            # estimate meets, the truth meets within one noise std.
            # (No budget, as under stated disturbances: the defaults as written.)
            budgets = {"x": position_budget, "y": position_budget}
            if math.isfinite(position_budget):
                budgets["theta"] = measured_noise.get("theta", 0.0) * INITIAL_SHARE
            process = {
                state: quiet_process_std(measured_noise[state], budget, written[state])
                for state, budget in budgets.items()
                if measured_noise.get(state, 0.0) > 0.0
            }
            if quiet_heading:
                # The model's heading holds exactly between samples (no stated
                # disturbances); a heading random walk is what the positions'
                # noise would turn into the heading, and the positions' budget
                # leaves none for it.
                process["theta"] = 0.0
            if process:
                update["process_std"] = self.process_std.model_copy(update=process)
        return self.model_copy(update=update) if update else self


def quiet_process_std(noise_std: float, budget: float, process_std: float) -> float:
    """The process noise std whose filtered estimate's variance is at
    most ``budget^2``: in steady state a coordinate's variance is about
    ``sqrt(q r)`` for ``q << r``, so ``sqrt(q) = budget^2 / noise_std``; never
    more than ``process_std``. Rounded to 3 significant digits."""
    if not math.isfinite(budget) or noise_std <= 0.0:
        return process_std
    return min(process_std, float(f"{budget * budget / noise_std:.3g}"))


# --- the kernels ---------------------------------------------------------------


class EkfTuning(NamedTuple):
    """What the filter's kernels read."""

    mask: FloatArray  # 1.0 for each measured state (x, y, theta)
    process_var: FloatArray  # diagonals of the noise covariances
    measurement_var: FloatArray
    innovation_gate: float  # largest accepted r^T S^-1 r (inf: no gating)
    initial_var: FloatArray  # diagonal of P0


class EkfMemory(NamedTuple):
    covariance: FloatArray  # (3, 3) P
    work: FloatArray  # (4, 3, 3) scratch
    gated: FloatArray  # (1,) measurements gated in a row


@kernel
def _predict(
    estimate: FloatArray,
    covariance: FloatArray,
    v: float,
    omega: float,
    dt: float,
    process_var: FloatArray,
    work: FloatArray,
) -> tuple[float, float, float]:
    """The predicted pose (returned) and covariance ``A P A^T + Qn`` (into
    ``work[0]``); ``work[1]`` and ``work[2]`` are scratch."""
    a13, a23, _, _, _, _ = jacobian_terms(estimate[2], v, omega, dt)
    # P_pred = A P A^T + Qn, with A = I + a e3^T.
    p = covariance
    pp = work[0]
    a = work[1]
    for i in range(3):
        for j in range(3):
            a[i, j] = 1.0 if i == j else 0.0
    a[0, 2] = a13
    a[1, 2] = a23
    tmp = work[2]
    for i in range(3):
        for j in range(3):
            tmp[i, j] = a[i, 0] * p[0, j] + a[i, 1] * p[1, j] + a[i, 2] * p[2, j]
    for i in range(3):
        for j in range(3):
            pp[i, j] = tmp[i, 0] * a[j, 0] + tmp[i, 1] * a[j, 1] + tmp[i, 2] * a[j, 2]
        pp[i, i] += process_var[i]
    return step(estimate[0], estimate[1], estimate[2], v, omega, dt)


@inlined
def ekf_predict(
    estimate: FloatArray,
    covariance: FloatArray,
    v: float,
    omega: float,
    dt: float,
    params: EkfTuning,
    work: FloatArray,
) -> None:
    """A sample without a measurement (between periods, lost or gated): the
    prediction alone, x_{k+1|k} and P_{k+1|k}."""
    estimate[0], estimate[1], estimate[2] = _predict(
        estimate, covariance, v, omega, dt, params.process_var, work
    )
    # Element by element: a slice assignment compiles numba's shape-error text (~3 s).
    for i in range(3):
        for j in range(3):
            covariance[i, j] = work[0, i, j]


@inlined
def ekf_step(
    estimate: FloatArray,
    covariance: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    params: EkfTuning,
    work: FloatArray,
    gate: float = math.inf,
) -> bool:
    """Advance ``estimate`` and ``covariance`` (3x3) in place: x_{k|k} -> x_{k+1|k+1}.

    ``params.process_var``/``params.measurement_var`` are the diagonals of the
    process and measurement noise covariances; ``work`` is scratch of shape
    (4, 3, 3). A measurement whose r^T S^-1 r exceeds ``gate`` is not used:
    returns True then (the prediction alone), else False.
    """
    mask = params.mask
    measurement_var = params.measurement_var
    p = covariance
    pp = work[0]
    px, py, pth = _predict(estimate, p, v, omega, dt, params.process_var, work)
    # S = C P C^T + Rn on the full pose, unmeasured rows made inert.
    s = work[1]
    for i in range(3):
        for j in range(3):
            s[i, j] = pp[i, j] * mask[i] * mask[j]
        s[i, i] += measurement_var[i] if mask[i] > 0.0 else 1.0
    # K = P C^T S^-1 (3x3 with zero columns for unmeasured states).
    c00 = s[1, 1] * s[2, 2] - s[1, 2] * s[2, 1]
    c01 = s[1, 2] * s[2, 0] - s[1, 0] * s[2, 2]
    c02 = s[1, 0] * s[2, 1] - s[1, 1] * s[2, 0]
    det = s[0, 0] * c00 + s[0, 1] * c01 + s[0, 2] * c02
    inv = work[3]
    inv[0, 0] = c00 / det
    inv[1, 0] = c01 / det
    inv[2, 0] = c02 / det
    inv[0, 1] = (s[0, 2] * s[2, 1] - s[0, 1] * s[2, 2]) / det
    inv[1, 1] = (s[0, 0] * s[2, 2] - s[0, 2] * s[2, 0]) / det
    inv[2, 1] = (s[0, 1] * s[2, 0] - s[0, 0] * s[2, 1]) / det
    inv[0, 2] = (s[0, 1] * s[1, 2] - s[0, 2] * s[1, 1]) / det
    inv[1, 2] = (s[0, 2] * s[1, 0] - s[0, 0] * s[1, 2]) / det
    inv[2, 2] = (s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]) / det
    k = work[2]
    for i in range(3):
        for j in range(3):
            k[i, j] = (
                pp[i, 0] * mask[0] * inv[0, j]
                + pp[i, 1] * mask[1] * inv[1, j]
                + pp[i, 2] * mask[2] * inv[2, j]
            ) * mask[j]
    r0 = (measurement[0] - px) * mask[0]
    r1 = (measurement[1] - py) * mask[1]
    r2 = wrap_angle(measurement[2] - pth) * mask[2]
    # Innovation gate: the squared Mahalanobis distance r^T S^-1 r (unmeasured
    # states have r = 0). A rejected measurement leaves the prediction.
    distance2 = (
        r0 * (inv[0, 0] * r0 + inv[0, 1] * r1 + inv[0, 2] * r2)
        + r1 * (inv[1, 0] * r0 + inv[1, 1] * r1 + inv[1, 2] * r2)
        + r2 * (inv[2, 0] * r0 + inv[2, 1] * r1 + inv[2, 2] * r2)
    )
    if distance2 > gate:
        estimate[0] = px
        estimate[1] = py
        estimate[2] = pth
        for i in range(3):
            for j in range(3):
                p[i, j] = pp[i, j]
        return True
    estimate[0] = px + k[0, 0] * r0 + k[0, 1] * r1 + k[0, 2] * r2
    estimate[1] = py + k[1, 0] * r0 + k[1, 1] * r1 + k[1, 2] * r2
    estimate[2] = pth + k[2, 0] * r0 + k[2, 1] * r1 + k[2, 2] * r2
    # Joseph form: P = (I - K C) P_pred (I - K C)^T + K Rn K^T.
    ikc = work[1]
    for i in range(3):
        for j in range(3):
            ikc[i, j] = (1.0 if i == j else 0.0) - k[i, j] * mask[j]
    for i in range(3):
        for j in range(3):
            inv[i, j] = ikc[i, 0] * pp[0, j] + ikc[i, 1] * pp[1, j] + ikc[i, 2] * pp[2, j]
    for i in range(3):
        for j in range(3):
            value = inv[i, 0] * ikc[j, 0] + inv[i, 1] * ikc[j, 1] + inv[i, 2] * ikc[j, 2]
            for n in range(3):
                if mask[n] > 0.0:
                    value += k[i, n] * measurement_var[n] * k[j, n]
            p[i, j] = value
    for i in range(3):
        for j in range(i + 1, 3):
            mean = 0.5 * (p[i, j] + p[j, i])
            p[i, j] = mean
            p[j, i] = mean
    return False


# --- the estimator as the loop runs it -----------------------------------------


@inlined
def next_estimate(
    tuning: EkfTuning,
    memory: EkfMemory,
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    measured: bool,
) -> int:
    """x_{k|k} -> x_{k+1|k+1}; a sample without a measurement is the prediction
    alone. No iterations to count: 0."""
    if measured:
        # A lone outlier is gated; after MAX_REJECTED in a row the estimate,
        # not the sensor, is off: every measurement is taken until one passes.
        gated = memory.gated
        gate = tuning.innovation_gate if gated[0] < MAX_REJECTED else math.inf
        if ekf_step(
            estimate, memory.covariance, v, omega, dt, measurement, tuning, memory.work, gate
        ):
            gated[0] += 1.0
        elif gate < math.inf:
            gated[0] = 0.0
    else:
        ekf_predict(estimate, memory.covariance, v, omega, dt, tuning, memory.work)
    return 0


@inlined
def spread(memory: EkfMemory, out: FloatArray) -> None:
    """The square roots of P's diagonal: the filter's own error std [m, m, rad]."""
    for i in range(3):
        out[i] = math.sqrt(memory.covariance[i, i])


def tuning_of(settings: Ekf, measurements: Measurements) -> EkfTuning:
    measurement_var = np.maximum(measurements.noise_std, MEASUREMENT_STD_FLOOR) ** 2
    if settings.measurement_std is not None:
        for name, std in settings.measurement_std.items():
            measurement_var[STATES.index(name)] = std * std  # not pow(): exact
    initial, process = settings.initial_std, settings.process_std
    return EkfTuning(
        mask=measurements.mask,
        process_var=np.array([process.x, process.y, process.theta]) ** 2,
        measurement_var=measurement_var,
        innovation_gate=(
            math.inf if settings.innovation_gate is None else float(settings.innovation_gate)
        ),
        initial_var=np.array([initial.x, initial.y, initial.theta]) ** 2,
    )


def new_memory(tuning: EkfTuning, initial_estimate: FloatArray) -> EkfMemory:
    return EkfMemory(
        covariance=np.diag(tuning.initial_var).astype(np.float64),
        work=np.zeros((4, 3, 3)),
        gated=np.zeros(1),
    )


def ekf_tuning(
    mask: FloatArray,
    process_var: FloatArray,
    measurement_var: FloatArray,
    innovation_gate: float = np.inf,
) -> EkfTuning:
    """The filter's record from plain numbers: for tests and notebooks."""
    return EkfTuning(mask, process_var, measurement_var, innovation_gate, np.ones(3))


# Registered by wmr_mission.estimators.
def constraint_margin(tuning: EkfTuning) -> float:
    """[m] Three standard deviations of the position's error: a measured
    coordinate's filtered variance stays below its measurement variance (an
    update never leaves P above R there), so three measurement std bound it;
    an unmeasured one is bounded by nothing the filter knows ahead, and its
    initial std stands in."""
    measured = tuning.mask[0] and tuning.mask[1]
    variance = tuning.measurement_var if measured else tuning.initial_var
    return 3.0 * math.sqrt(max(float(variance[0]), float(variance[1])))


ESTIMATOR = EstimatorType(
    settings=Ekf,
    tuning_record=EkfTuning,
    tuning_of=tuning_of,
    new_memory=new_memory,
    step=next_estimate,
    constraint_margin=constraint_margin,
    spread=spread,
)
