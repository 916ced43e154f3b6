"""The paper's two-phase constrained estimator, eqs. (4)-(12).

Phase I (eqs. (5)-(7)) predicts with the nonlinear model and corrects with a
gain ``L`` that puts the eigenvalues of ``(I - L C) A`` at configured poles.
The gain is in closed form, exploiting ``A = I + a e3^T`` (eq. (1) couples the
states only through the heading), so no pole placement runs per sample:

* heading measured: each measured state's error decays at its own pole and
  the heading innovation removes the heading-to-position coupling, so
  ``(I - L C) A = diag(p_x or 1, p_y or 1, p_theta)`` exactly (1 for an
  unmeasured, hence unobservable, position);
* heading not measured: the heading is observed through the measured
  positions along ``c = (a13, a23)`` (masked) while the robot moves; the
  heading/along-``c`` pair gets the poles ``(p_theta, p_pos)`` and the
  position error across ``c`` decays at ``p_pos`` (``p_pos`` the mean of the
  measured positions' poles). At rest the heading is unobservable: its
  eigenvalue is 1 and no heading correction is made. Between the two, when
  the robot moves less per sample than ``motion_floor`` (the position noise),
  one sample says little about the heading: its pole moves from ``p_theta``
  towards 1 as ``1 - (1 - p_theta) |c|^2 / motion_floor^2``, so the heading
  correction per metre of innovation stays below ``1 / motion_floor`` instead
  of growing as ``1 / |c|``. ``c`` lies across the motion: the along-``c``
  position is the cross-track one, filtered by the heading's pole as much as
  by the positions', so under noise the defaults slow the pair as one
  (:func:`quiet_pair_pole`).

Phase II (eqs. (8)-(12)) saturates each output estimation error that left its
bounds of eq. (4) to the violated bound. The measurement is a selection of
states, so ``D`` of eq. (12) selects the violated outputs and ``H = D^T`` makes
``I - H D`` zero on them: the iteration of eq. (10) lands on the bound in one
step, and ``(I - H D) A_c`` is contracting because it only removes directions.
The loop still checks and counts, up to ``max_iterations``.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, NamedTuple, Self

import numpy as np
from pydantic import AfterValidator, Field, Strict
from pydantic_core import PydanticCustomError

from wmr_mission.basics import STATES, FloatArray, StateName
from wmr_mission.estimators.registry import EstimatorSettings, EstimatorType, Measurements
from wmr_mission.fields import Model, Number, Positive
from wmr_mission.kernels.jit import inlined, kernel
from wmr_mission.kernels.model import jacobian_terms, step, wrap_angle

# --- settings: the mission's `estimator: {type: constrained-observer, ...}` ----


def _check_bound(bound: tuple[float, float]) -> tuple[float, float]:
    lower, upper = bound
    if not lower < 0 < upper:
        raise PydanticCustomError(
            "output_error_bound",
            "an output-error bound is [lower, upper] with lower < 0 < upper, "
            "got [{lower}, {upper}]",
            {"lower": lower, "upper": upper},
        )
    return bound


OutputErrorBound = Annotated[tuple[Number, Number], AfterValidator(_check_bound)]
Pole = Annotated[Number, Field(ge=0, lt=1)]


# Default output-error bound of eq. (4) [m or rad]: the larger of this and
# BOUND_NOISE_RATIO times the state's noise std, so that phase II acts on
# estimation errors, not on the noise (docs/paper-notes.md, eq. (4)).
DEFAULT_BOUND = 0.05
BOUND_NOISE_RATIO = 5.0


def _default_bounds() -> dict[StateName, tuple[float, float]]:
    return dict.fromkeys(STATES, (-DEFAULT_BOUND, DEFAULT_BOUND))


def default_bound(noise_std: float) -> float:
    """Half-width of the default output-error bound for a state with this noise."""
    return max(DEFAULT_BOUND, BOUND_NOISE_RATIO * noise_std)


# The chi-square distribution's 1 - 1e-6 quantile for 1, 2 and 3 degrees of
# freedom: the sensors' noise alone exceeds it once in a million samples, and a
# robot's disturbances (delay, lag, slip: missions/controllers.yaml) rarely
# add enough to it; the 0.999 quantile (16.27 for 3) gated them too
# (docs/paper-notes.md, "Outliers gated").
CHI_SQUARE_GATE = (23.93, 27.63, 30.66)
# A gated measurement is a lone outlier; after this many in a row the estimate,
# not the sensor, is taken to be off and every measurement is used again.
MAX_REJECTED = 3


def quiet_pole(noise_std: float, budget: float, pole: float) -> float:
    """The position pole whose estimate's noise std is at most ``budget`` [m]
    for white measurement noise ``noise_std``: a pole ``p`` passes
    ``sqrt((1 - p) / (1 + p))`` of it, so ``p = (1 - rho) / (1 + rho)`` with
    ``rho = (budget / noise_std)^2``; never faster than ``pole``. Rounded to 6
    decimals, as the mission would write it."""
    if not math.isfinite(budget) or noise_std <= 0.0:
        return pole
    rho = (budget / noise_std) ** 2
    return max(pole, round((1.0 - rho) / (1.0 + rho), 6))


def cross_track_share(pole: float) -> float:
    """The share of white position noise's variance the cross-track estimate
    keeps with the heading unmeasured and both poles of the (cross-track,
    heading) pair at ``pole``: that pair is an alpha-beta filter with
    ``alpha = 1 - pole^2``, ``beta = (1 - pole)^2``, whose filtered position
    keeps ``(2 alpha^2 + 2 beta - 3 alpha beta) / (alpha (4 - 2 alpha - beta))``
    of it, about ``1.25 (1 - pole)`` near 1 (a single pole keeps ``(1 - pole) /
    (1 + pole)``, about half that)."""
    alpha, beta = 1.0 - pole * pole, (1.0 - pole) ** 2
    return (2.0 * alpha * alpha + 2.0 * beta - 3.0 * alpha * beta) / (
        alpha * (4.0 - 2.0 * alpha - beta)
    )


def quiet_pair_pole(noise_std: float, budget: float, pole: float) -> float:
    """With the heading unmeasured: the pole of the positions and the heading
    whose cross-track estimate's noise std is at most ``budget`` [m] for white
    position noise ``noise_std``. The cross-track error and the heading form
    a pair whose poles are ``(p_theta, p_pos)`` (observer_gain): a heading
    pole of 0.9 keeps the cross-track estimate's noise at 0.23 of the
    sensor's whatever the position poles, so both are slowed, to one pole,
    found by bisection on :func:`cross_track_share`; never faster than
    ``pole``. Rounded up to 6 decimals, as the mission would write it."""
    if not math.isfinite(budget) or noise_std <= 0.0:
        return pole
    rho = (budget / noise_std) ** 2
    if cross_track_share(pole) <= rho:
        return pole
    fast, slow = pole, 1.0
    for _ in range(60):
        middle = 0.5 * (fast + slow)
        if cross_track_share(middle) <= rho:
            slow = middle
        else:
            fast = middle
    return min(math.ceil(slow * 1e6) / 1e6, 0.999999)


class StatePoles(Model):
    """Eigenvalues of the observer error dynamics (I - L C) A, per state."""

    x: Pole = Field(default=0.9, description="Pole for x, in [0, 1).")
    y: Pole = Field(default=0.9, description="Pole for y, in [0, 1).")
    theta: Pole = Field(default=0.9, description="Pole for theta, in [0, 1).")


class ConstrainedObserver(EstimatorSettings):
    """The paper's two-phase constrained estimator, eqs. (4)-(12)."""

    type: Literal["constrained-observer"] = Field(
        default="constrained-observer", description="Estimator kind (the default)."
    )
    poles: StatePoles = Field(
        default_factory=lambda: StatePoles.defaults(),
        description=(
            "Observer poles, phase I (eq. 7); default 0.9, and with noisy positions (no "
            "robot.disturbances) x and y slow enough that the estimate's noise takes at most "
            "1 % of the turn-rate limit through the tracking law; with the heading unmeasured, "
            "the heading too, as the cross-track position and the heading are filtered as a "
            "pair. With the heading unmeasured, its pole relaxes towards 1 while the robot "
            "moves less per sample than sensors.noise_std of the measured positions "
            "(docs/paper-notes.md, eq. 6-7)."
        ),
    )
    output_error_bounds: dict[StateName, OutputErrorBound] | None = Field(
        default_factory=_default_bounds,
        description=(
            "Eq. (4): [lower, upper] bounds on each measured state's output error "
            "[m or rad], lower < 0 < upper; keys must be measured states; null = no phase II. "
            "Default on every measured state: +-max(0.05, 5 sensors.noise_std)."
        ),
    )
    max_iterations: Annotated[int, Strict(), Field(ge=1, le=1000)] = Field(
        default=10, description="Phase II iterations per sample, 1..1000."
    )
    innovation_gate: Positive | None = Field(
        default=None,
        description=(
            "Reject a measurement whose squared innovation in noise std, sum (r_i / "
            "sensors.noise_std_i)^2 over the noisy measured states, exceeds this (a lone "
            "outlier: at most 3 in a row; then every measurement is taken until one is "
            "within it). null = no gate. Default with noisy sensors: the chi-square 1 - 1e-6 "
            "quantile for as many states (30.66 for 3)."
        ),
    )

    def with_sensors(
        self, measured_noise: dict[str, float], position_budget: float = math.inf
    ) -> Self:
        """Defaults that follow the sensors: output-error bounds on the measured
        states only, each wide enough that the state's noise alone rarely
        leaves it; with noisy sensors, an innovation gate and position poles
        that filter the position noise down to ``position_budget`` [m]
        (docs/paper-notes.md, "Eqs. (6)-(7) under position noise")."""
        update: dict[str, object] = {}
        if "output_error_bounds" not in self.model_fields_set:
            update["output_error_bounds"] = {
                state: (-default_bound(std), default_bound(std))
                for state, std in measured_noise.items()
            }
        noisy = sum(std > 0.0 for std in measured_noise.values())
        if noisy and "innovation_gate" not in self.model_fields_set:
            update["innovation_gate"] = CHI_SQUARE_GATE[noisy - 1]
        if "poles" not in self.model_fields_set:
            # read as fields, not dumped: a dump builds the model's serializer first
            noisy_positions = {
                state: measured_noise[state]
                for state in ("x", "y")
                if measured_noise.get(state, 0.0) > 0.0
            }
            # With the heading unmeasured the cross-track position is filtered
            # by the heading's pole too: the pair is slowed as one.
            quiet = quiet_pole if "theta" in measured_noise else quiet_pair_pole
            poles = {
                state: quiet(std, position_budget, getattr(self.poles, state))
                for state, std in noisy_positions.items()
            }
            if poles and "theta" not in measured_noise:
                poles["theta"] = quiet(
                    max(noisy_positions.values()), position_budget, self.poles.theta
                )
            if poles:
                update["poles"] = self.poles.model_copy(update=poles)
        return self.model_copy(update=update) if update else self


# --- the kernels ---------------------------------------------------------------


class ObserverTuning(NamedTuple):
    """What the observer's kernels read."""

    mask: FloatArray  # 1.0 for each measured state (x, y, theta)
    poles: FloatArray  # eigenvalues of (I - L C) A per state, phase I
    motion_floor: float  # [m] motion per sample below which the heading pole relaxes
    lower: FloatArray  # output-error bounds of eq. (4) (phase II)
    upper: FloatArray
    use_bounds: bool
    max_iterations: int
    noise_std: FloatArray = np.zeros(3)  # [m, m, rad] of the sensors: the gate's scale
    innovation_gate: float = math.inf  # largest accepted sum (r_i / noise_std_i)^2
    # False: slow poles act from the first measurement (an unmeasured heading's
    # estimate that starts at the true pose: no initial error to take out)
    ramp: bool = True


class ObserverMemory(NamedTuple):
    gain: FloatArray  # (3, 3) L of eq. (6), scratch
    poles: FloatArray  # (3,) this sample's poles: the configured ones, ramped in
    # [measurements taken, gated in a row] (floats: one array type for the loop)
    counts: FloatArray


# A position pole slower than this (the default) starts at it and slows as a
# running mean does, 1 - 1 / (k + RAMP_START) at the k-th measurement, until it
# reaches its own: the initial estimate's error goes as fast as by default.
RAMP_POLE = 0.9
RAMP_START = 1.0 / (1.0 - RAMP_POLE)
# With the heading unmeasured the cross-track position and the heading, a
# position and its rate, ramp together as a running fit of a line does: its
# poles' real parts go as 1 - 2 / k, twice a running mean's pace (from the same
# 0.9). On the users' missions that start off (scripts/heading_unmeasured.py
# --initial-estimate-off) 43 of the observer's 80 runs miss a verdict at this
# pace, 51 at a running mean's.
PAIR_PACE = 2.0


# Below this |c| (metres moved per sample along the measured positions) the
# heading is treated as unobservable at that sample: no heading correction.
MIN_HEADING_OBSERVABILITY = 1e-12
# Output errors within this of a bound count as on it (phase II).
BOUND_SLACK = 1e-12


@kernel
def observer_gain(
    a13: float,
    a23: float,
    mask: FloatArray,
    poles: FloatArray,
    motion_floor: float,
    gain: FloatArray,
) -> None:
    """Write the 3x3 gain ``L`` of eq. (6) into ``gain``.

    Columns are the innovations of x, y, theta; columns of unmeasured states
    are zero. ``mask`` holds 1.0 for measured states, ``poles`` the configured
    eigenvalues of ``(I - L C) A`` for x, y, theta; ``motion_floor`` [m] the
    motion per sample below which the heading pole relaxes towards 1 (heading
    unmeasured only).
    """
    for i in range(3):
        for j in range(3):
            gain[i, j] = 0.0
    mx = mask[0]
    my = mask[1]
    if mask[2] > 0.0:
        gain[2, 2] = 1.0 - poles[2]
        # Measured position i: error decays at p_i; the heading innovation
        # carries p_i * a_i3 to cancel the coupling term of A.
        # Unmeasured position i: only the coupling is cancelled (eigenvalue 1).
        if mx > 0.0:
            gain[0, 0] = 1.0 - poles[0]
            gain[0, 2] = poles[0] * a13
        else:
            gain[0, 2] = a13
        if my > 0.0:
            gain[1, 1] = 1.0 - poles[1]
            gain[1, 2] = poles[1] * a23
        else:
            gain[1, 2] = a23
        return
    if mx + my == 0.0:
        return
    p_pos = (poles[0] * mx + poles[1] * my) / (mx + my)
    cx = a13 * mx
    cy = a23 * my
    n2 = cx * cx + cy * cy
    if n2 <= MIN_HEADING_OBSERVABILITY * MIN_HEADING_OBSERVABILITY:
        gain[0, 0] = (1.0 - p_pos) * mx
        gain[1, 1] = (1.0 - p_pos) * my
        return
    # Along c the pair (position, heading) has the 2x2 error matrix
    # [[p_s, p_s n], [-k n, 1 - k n^2]]: det = p_s, trace = p_s + 1 - k n^2.
    # Poles (p_theta, p_pos) need p_s = p_theta p_pos, k n^2 = (1-p_theta)(1-p_pos).
    p_theta = poles[2]
    floor2 = motion_floor * motion_floor
    if n2 < floor2:
        p_theta = 1.0 - (1.0 - p_theta) * n2 / floor2
    p_along = p_theta * p_pos
    k = (1.0 - p_theta) * (1.0 - p_pos) / n2
    # L_pos = I - P with P = p_pos (I - c c^T / n2) + p_along c c^T / n2, masked.
    d = (p_pos - p_along) / n2
    gain[0, 0] = (1.0 - p_pos + d * cx * cx) * mx
    gain[0, 1] = d * cx * cy * mx * my
    gain[1, 0] = d * cx * cy * mx * my
    gain[1, 1] = (1.0 - p_pos + d * cy * cy) * my
    gain[2, 0] = k * cx
    gain[2, 1] = k * cy


@inlined
def observer_step(
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    params: ObserverTuning,
    gain: FloatArray,
    poles: FloatArray,
) -> int:
    """Advance ``estimate`` (x_{k|k} -> x_{k+1|k+1}) in place with input u_k and
    measurement xi_{k+1}; ``gain`` receives L for the eigenvalues ``poles``.
    Returns the number of phase-II iterations run."""
    mask = params.mask
    # Read once: the writes to ``gain`` below could alias ``estimate`` for the
    # compiler, which would then read the heading again and recompute its sine.
    x, y, theta = estimate[0], estimate[1], estimate[2]
    # Phase I. eq. (7): A at the filtered estimate x_{k|k}.
    a13, a23, _, _, _, _ = jacobian_terms(theta, v, omega, dt)
    observer_gain(a13, a23, mask, poles, params.motion_floor, gain)
    # eq. (5): prediction.
    px, py, pth = step(x, y, theta, v, omega, dt)
    # eq. (6): innovation of the measured outputs (heading residual wrapped).
    rx = (measurement[0] - px) * mask[0]
    ry = (measurement[1] - py) * mask[1]
    rth = wrap_angle(measurement[2] - pth) * mask[2]
    estimate[0] = px + gain[0, 0] * rx + gain[0, 1] * ry + gain[0, 2] * rth
    estimate[1] = py + gain[1, 0] * rx + gain[1, 1] * ry + gain[1, 2] * rth
    estimate[2] = pth + gain[2, 0] * rx + gain[2, 1] * ry + gain[2, 2] * rth
    if not params.use_bounds:
        return 0
    lower = params.lower
    upper = params.upper
    # Phase II, eqs. (8)-(11): iterate on the outputs whose error left eq. (4).
    iterations = 0
    while iterations < params.max_iterations:
        violated = False
        for i in range(3):
            if mask[i] == 0.0:
                continue
            error = measurement[i] - estimate[i]
            if i == 2:
                error = wrap_angle(error)
            # Rounding of the previous update must not count as a violation.
            if error > upper[i] + BOUND_SLACK:
                # z - h'(x) with z saturated to the upper bound, H = D^T.
                estimate[i] += error - upper[i]
                violated = True
            elif error < lower[i] - BOUND_SLACK:
                estimate[i] += error - lower[i]
                violated = True
        if not violated:
            break
        iterations += 1
    return iterations


@kernel
def observer_predict(estimate: FloatArray, v: float, omega: float, dt: float) -> int:
    """A sample without a measurement (between periods, or lost): eq. (5)
    alone, no innovation and no phase II. Returns 0 phase-II iterations."""
    estimate[0], estimate[1], estimate[2] = step(
        estimate[0], estimate[1], estimate[2], v, omega, dt
    )
    return 0


def error_matrix(
    state: FloatArray,
    u: FloatArray,
    dt: float,
    mask: FloatArray,
    poles: FloatArray,
    motion_floor: float = 0.0,
) -> FloatArray:
    """``(I - L C) A`` of eq. (7) at (state, u): the phase-I error dynamics."""
    a13, a23, *_ = jacobian_terms(state[2], u[0], u[1], dt)
    gain = np.zeros((3, 3))
    observer_gain(a13, a23, mask, poles, motion_floor, gain)
    a = np.array([[1.0, 0.0, a13], [0.0, 1.0, a23], [0.0, 0.0, 1.0]])
    return np.asarray((np.eye(3) - gain @ np.diag(mask)) @ a)


# --- the estimator as the loop runs it -----------------------------------------


@inlined
def next_estimate(
    tuning: ObserverTuning,
    memory: ObserverMemory,
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    measured: bool,
) -> int:
    """x_{k|k} -> x_{k+1|k+1}: phases I and II with a measurement, the
    prediction of eq. (5) alone without one or with a gated one."""
    if not measured:
        return observer_predict(estimate, v, omega, dt)
    counts = memory.counts
    poles = tuning.poles
    ramping = tuning.ramp and (poles[0] > RAMP_POLE or poles[1] > RAMP_POLE)  # noisy positions
    if ramping:
        ramped = memory.poles
        for i in range(3):
            ramped[i] = poles[i]
        # an unmeasured heading's slowed pole ramps too, with the positions' (PAIR_PACE)
        pair = tuning.mask[2] == 0.0 and poles[2] > RAMP_POLE  # the heading slowed too
        pace = PAIR_PACE if pair else 1.0
        for i in range(3 if pair else 2):
            if ramped[i] > RAMP_POLE:
                ramped[i] = min(ramped[i], 1.0 - pace / (counts[0] + pace * RAMP_START))
        poles = ramped
    gated = tuning.innovation_gate < math.inf  # noisy sensors only
    within = True
    if gated:
        # A lone outlier is dropped before it reaches the estimate (and, through
        # phase II, drags it to within its bound of the outlier). Nothing is
        # written between this prediction and observer_step's, so the compiled
        # loop computes it once (the counts are written after).
        px, py, pth = step(estimate[0], estimate[1], estimate[2], v, omega, dt)
        residual = (measurement[0] - px, measurement[1] - py, wrap_angle(measurement[2] - pth))
        distance2 = 0.0
        for i in range(3):
            std = tuning.noise_std[i]
            if tuning.mask[i] > 0.0 and std > 0.0:
                distance2 += (residual[i] / std) ** 2
        within = distance2 <= tuning.innovation_gate
        if not within and counts[1] < MAX_REJECTED:
            counts[1] += 1.0
            return observer_predict(estimate, v, omega, dt)
    iterations = observer_step(estimate, v, omega, dt, measurement, tuning, memory.gain, poles)
    if gated and within:
        counts[1] = 0.0
    if ramping:
        counts[0] += 1.0  # measurements taken: the ramp's clock
    return iterations


def tuning_of(settings: ConstrainedObserver, measurements: Measurements) -> ObserverTuning:
    lower = np.full(3, -math.inf)
    upper = np.full(3, math.inf)
    if settings.output_error_bounds:
        for name, (lo, hi) in settings.output_error_bounds.items():
            lower[STATES.index(name)] = lo
            upper[STATES.index(name)] = hi
    poles = settings.poles
    return ObserverTuning(
        mask=measurements.mask,
        poles=np.array([poles.x, poles.y, poles.theta]),
        # The measured positions' noise: one sample of them says little about
        # an unmeasured heading below it (docs/paper-notes.md, eqs. (6)-(7)).
        motion_floor=float(measurements.noise_std[:2].max()),
        lower=lower,
        upper=upper,
        use_bounds=bool(settings.output_error_bounds),
        max_iterations=settings.max_iterations,
        noise_std=measurements.noise_std * measurements.mask,
        innovation_gate=(
            math.inf if settings.innovation_gate is None else float(settings.innovation_gate)
        ),
        # The ramp takes out an initial error at the default pace; an estimate
        # that starts at the true pose has none, and with the heading unmeasured
        # the noise its first seconds let through turned a user's GPS route
        # (docs/paper-notes.md, "The heading unmeasured"). With the heading
        # measured it stays, as the heading noise's own jitter allows for it.
        ramp=bool(measurements.mask[2] > 0.0 or settings.initial_estimate is not None),
    )


def new_memory(tuning: ObserverTuning, initial_estimate: FloatArray) -> ObserverMemory:
    # Gated in a row starts at the most: the initial estimate may be off, so
    # every measurement is taken until one falls within the gate.
    return ObserverMemory(
        gain=np.zeros((3, 3)), poles=np.zeros(3), counts=np.array([0.0, MAX_REJECTED])
    )


def error_bounds(tuning: ObserverTuning) -> tuple[tuple[float, float], ...]:
    return tuple(
        (float(lo), float(hi)) if tuning.use_bounds and math.isfinite(lo) else (math.nan, math.nan)
        for lo, hi in zip(tuning.lower, tuning.upper, strict=True)
    )


def constraint_margin(tuning: ObserverTuning) -> float:
    """[m] The widest output-error bound of eq. (4) on x and y: phase II keeps
    the measured position within it of the estimate, so the true position is
    within it plus the noise. With the position unmeasured or unbounded, three
    noise std of the measured positions (0 without noise)."""
    widths = [
        max(-float(tuning.lower[i]), float(tuning.upper[i]))
        for i in range(2)
        if tuning.use_bounds and tuning.mask[i] and math.isfinite(tuning.lower[i])
    ]
    if len(widths) == 2:
        return max(widths)
    return 3.0 * tuning.motion_floor


def observer_tuning(
    mask: FloatArray,
    poles: FloatArray,
    motion_floor: float = 0.0,
    lower: FloatArray | None = None,
    upper: FloatArray | None = None,
    use_bounds: bool = False,
    max_iterations: int = 0,
) -> ObserverTuning:
    """The observer's record from plain numbers: for tests and notebooks."""
    return ObserverTuning(
        mask,
        poles,
        motion_floor,
        np.full(3, -np.inf) if lower is None else lower,
        np.full(3, np.inf) if upper is None else upper,
        use_bounds,
        max_iterations,
    )


# Registered by wmr_mission.estimators.
ESTIMATOR = EstimatorType(
    settings=ConstrainedObserver,
    tuning_record=ObserverTuning,
    tuning_of=tuning_of,
    new_memory=new_memory,
    step=next_estimate,
    error_bounds=error_bounds,
    constraint_margin=constraint_margin,
)
