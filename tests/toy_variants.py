"""A toy estimator and a toy control law from outside the package, each one
module's worth of code plus one registration (docs/architecture.md, the recipes).

Importing this module registers both:

* estimator ``toy-measured-pose``: each measured state's estimate moves
  ``blend`` of the way from the model's prediction to the measurement; a
  sample without a measurement is the prediction alone. It counts the
  measurements it took in its memory and returns 1 for a sample with one
  (the run records it as ``phase2_iterations``).
* controller ``toy-turns``: drives at a constant ``speed`` and turns at
  ``turn_rate``, reversing the turn after ``turn_samples`` samples of each
  phase (its memory, zeroed at each phase's entry, counts them); the limits
  saturate both.
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

import numpy as np
from pydantic import Field

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.controllers.registry import CONTROLLERS, ControllerSettings, ControllerType
from wmr_mission.estimators.registry import (
    ESTIMATORS,
    EstimatorSettings,
    EstimatorType,
    Measurements,
)
from wmr_mission.kernels.jit import inlined
from wmr_mission.kernels.model import saturate, step, wrap_angle
from wmr_mission.kernels.records import Plant

# --- the estimator ---------------------------------------------------------------


class MeasuredPose(EstimatorSettings):
    """Toy: the estimate drawn towards each measurement."""

    type: Literal["toy-measured-pose"] = Field(description="Estimator kind.")
    blend: float = Field(default=1.0, ge=0, le=1, description="Share of the innovation taken.")


class MeasuredPoseTuning(NamedTuple):
    mask: FloatArray
    blend: float


class MeasuredPoseMemory(NamedTuple):
    updates: IntArray  # (1,) measurements taken


@inlined
def next_estimate(
    tuning: MeasuredPoseTuning,
    memory: MeasuredPoseMemory,
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    measured: bool,
) -> int:
    px, py, pth = step(estimate[0], estimate[1], estimate[2], v, omega, dt)
    estimate[0], estimate[1], estimate[2] = px, py, pth
    if not measured:
        return 0
    blend = tuning.blend
    estimate[0] = px + blend * (measurement[0] - px) * tuning.mask[0]
    estimate[1] = py + blend * (measurement[1] - py) * tuning.mask[1]
    estimate[2] = pth + blend * wrap_angle(measurement[2] - pth) * tuning.mask[2]
    memory.updates[0] += 1
    return 1


@inlined
def spread(memory: MeasuredPoseMemory, out: FloatArray) -> None:
    """Toy: an error std that shrinks with each measurement taken."""
    for i in range(3):
        out[i] = 1.0 / (1.0 + memory.updates[0])


def estimator_tuning(settings: MeasuredPose, measurements: Measurements) -> MeasuredPoseTuning:
    return MeasuredPoseTuning(measurements.mask, float(settings.blend))


def estimator_memory(
    tuning: MeasuredPoseTuning, initial_estimate: FloatArray
) -> MeasuredPoseMemory:
    return MeasuredPoseMemory(np.zeros(1, dtype=np.int64))


ESTIMATOR = EstimatorType(
    settings=MeasuredPose,
    tuning_record=MeasuredPoseTuning,
    tuning_of=estimator_tuning,
    new_memory=estimator_memory,
    step=next_estimate,
    spread=spread,
)

# --- the control law ---------------------------------------------------------------


class Turns(ControllerSettings):
    """Toy: constant speed, a turn reversed after some samples of each phase."""

    type: Literal["toy-turns"] = Field(description="Controller kind.")
    speed: float = Field(description="[m/s]")
    turn_rate: float = Field(description="[rad/s]")
    turn_samples: int = Field(ge=1, description="Samples of each phase before the turn reverses.")


class TurnsTuning(NamedTuple):
    speed: float
    turn_rate: float
    turn_samples: int


class TurnsScratch(NamedTuple):
    last: FloatArray  # (2,) the input before the limits


@inlined
def next_input(
    tuning: TurnsTuning,
    phase: Any,
    aim_now: FloatArray,
    aim: FloatArray,
    estimate: FloatArray,
    estimate_prev: FloatArray,
    u_prev: FloatArray,
    plant: Plant,
    memory: FloatArray,
    scratch: TurnsScratch,
    u: FloatArray,
) -> None:
    turn = tuning.turn_rate if memory[0] < tuning.turn_samples else -tuning.turn_rate
    memory[0] += 1.0
    scratch.last[0] = tuning.speed
    scratch.last[1] = turn
    u[0], u[1] = saturate(tuning.speed, turn, u_prev[0], u_prev[1], plant.limits, plant.dt)


def controller_tuning(settings: Turns, plant: Plant) -> TurnsTuning:
    return TurnsTuning(float(settings.speed), float(settings.turn_rate), settings.turn_samples)


def controller_scratch(tuning: TurnsTuning) -> TurnsScratch:
    return TurnsScratch(np.zeros(2))


CONTROLLER = ControllerType(
    settings=Turns,
    tuning_record=TurnsTuning,
    tuning_of=controller_tuning,
    memory_size=1,
    new_scratch=controller_scratch,
    step=next_input,
)

# --- the registrations ---------------------------------------------------------------

ESTIMATORS.register(ESTIMATOR)
CONTROLLERS.register(CONTROLLER)
