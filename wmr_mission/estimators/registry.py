"""What an estimator is, and the registry of them.

An estimator type is one module holding

* its settings: the model of the mission's ``estimator:`` section, a subclass
  of :class:`EstimatorSettings` with ``type: Literal[NAME]``;
* its tuning record: a ``NamedTuple`` of numbers and arrays, built once per run
  by ``tuning_of(settings, measurements)``, which its kernel reads; the type of this
  record says which step a loop was compiled for;
* its memory: the arrays it carries from sample to sample (``new_memory(tuning,
  initial_estimate)``, any ``NamedTuple`` of arrays);
* its step, a kernel (wmr_mission.kernels.jit): ``step(tuning, memory,
  estimate, v, omega, dt, measurement, measured) -> int`` advances ``estimate``
  in place from x_{k|k} to x_{k+1|k+1} with the input applied over the sample
  and, when ``measured``, the measurement of sample k+1 (all three states:
  which ones the sensors measure is ``measurements.mask``); it returns a count the
  run records per sample (the constrained observer's phase-II iterations).

and one registration: ``ESTIMATORS.register(EstimatorType(...))``. The runner
binds the step into the loop (wmr_mission.kernels.variants): compiled, it is
compiled into it; as plain Python, it runs as Python.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final, NamedTuple, Self

from pydantic import Field

from wmr_mission.basics import FloatArray
from wmr_mission.fields import Model, Pose, Registry

DEFAULT: Final = "constrained-observer"


class EstimatorSettings(Model):
    """What every estimator's settings hold."""

    type: str
    initial_estimate: Pose | None = Field(
        default=None,
        description="Estimate at mission start [m, m, rad]; null = robot.initial_state.",
    )

    def with_sensors(
        self, measured_noise: dict[str, float], position_budget: float = math.inf
    ) -> Self:
        """These settings completed by what the sensors measure (the standard
        deviation of each measured state's noise) and by the controller's
        ``position_budget`` [m] (ControllerSettings.position_noise_budget):
        defaults that follow the sensors. As written by default."""
        return self


@dataclass(frozen=True)
class Measurements:
    """What the sensors give an estimator: which states they measure and how
    noisy each is (0 for a state not measured), from ``sensors:``."""

    mask: FloatArray  # 1.0 for each measured state (x, y, theta)
    noise_std: FloatArray  # [m, m, rad]
    dt: float  # [s] the sampling period


def no_error_bounds(tuning: Any) -> tuple[tuple[float, float], ...]:
    nan = float("nan")
    return ((nan, nan),) * 3


def no_margin(tuning: Any) -> float:
    return 0.0


@dataclass(frozen=True)
class EstimatorType:
    """One estimator a mission may name (see the module)."""

    settings: type[EstimatorSettings]
    tuning_record: type[NamedTuple]
    tuning_of: Callable[[Any, Measurements], Any]
    new_memory: Callable[[Any, FloatArray], Any]
    step: Callable[..., int]
    # The output-error bounds of eq. (4) the run reports per state (lower,
    # upper), NaN where there are none (the figures draw them).
    error_bounds: Callable[[Any], tuple[tuple[float, float], ...]] = no_error_bounds
    # [m] how far the estimated position may be from the true one: the margin
    # every zone is kept with (``Plant.constraint_margin``).
    constraint_margin: Callable[[Any], float] = no_margin
    # A kernel (memory, out) writing the standard deviation of the estimate's
    # error per state that the estimator holds (the EKF: its covariance), for
    # the estimation figure's +-3 std band (wmr_mission.output.covariance);
    # None where it holds none.
    spread: Callable[[Any, FloatArray], None] | None = None
    # False for a step numba cannot compile (plain Python objects): a mission
    # naming it runs its loop as plain Python.
    compiles: bool = True
    # True for a type that runs code the mission names (``type: python``): its
    # loop is compiled only when numba can type the plug-in, never cached, and
    # an exception out of it ends the run ``failed`` (wmr_mission.sim.runner).
    plugin: bool = False


ESTIMATORS: Registry[EstimatorType] = Registry("estimator", default=DEFAULT)
