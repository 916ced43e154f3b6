"""``python``: an estimator written in Python, named by the mission.

``estimator: {type: python, entry: "module:callable", params: {...}}``. A run
imports the entry (wmr_mission.plugins.load_entry) and calls
``callable(params, setup)`` once, before its first sample; ``setup`` is an
:class:`EstimatorSetup` (the initial estimate among it). It returns the
plug-in: any object with

    step(measurement, applied) -> estimate

called once per sample: ``measurement`` the sensors' reading of sample k+1
(an array x, y, theta, NaN where a state is not measured), or ``None`` when
there is none (the period between measurements, a dropout); ``applied`` the
input (v, omega) the robot was sent over the sample (an array). It returns
x_{k+1|k+1}: three numbers x, y, theta. The arrays it is given are the loop's
own: read them, do not keep or write them.

A plug-in of plain Python runs in a plain-Python loop; an instance of a numba
``@jitclass`` runs inside the compiled loop, compiled afresh in each process.
An exception raised by ``step``, or a return that is not three numbers, ends
the run ``failed`` with the plug-in's message and the sample
(wmr_mission.sim.runner). docs/controllers.md has a worked example.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np
from pydantic import Field

from wmr_mission.basics import FloatArray
from wmr_mission.estimators.registry import EstimatorSettings, EstimatorType, Measurements
from wmr_mission.kernels.jit import inlined
from wmr_mission.kernels.model import is_number
from wmr_mission.plugins import Entry, Params, load_entry


class PythonEstimator(EstimatorSettings):
    """An estimator from Python: ``entry`` names ``callable(params, setup)``."""

    type: Literal["python"] = Field(description="Estimator kind: a plug-in written in Python.")
    entry: Entry
    params: Params = Field(default_factory=dict)


@dataclass(frozen=True)
class EstimatorSetup:
    """What an estimator plug-in is made with, besides its params."""

    dt: float  # [s] sampling period
    measured: tuple[bool, bool, bool]  # which of x, y, theta the sensors measure
    noise_std: tuple[float, float, float]  # [m, m, rad] of each measured state, 0 elsewhere
    initial_estimate: tuple[float, float, float]  # x_{0|0} [m, m, rad]


class PluginTuning(NamedTuple):
    entry: str
    params: str  # as JSON: the plug-in is made afresh for each run (new_memory)
    dt: float
    mask: FloatArray  # 1.0 for each measured state
    noise_std: FloatArray


class PluginMemory(NamedTuple):
    plugin: Any  # what callable(params, setup) returned
    measurement: FloatArray  # (3,) handed to the plug-in: NaN where not measured
    applied: FloatArray  # (2,) handed to the plug-in


@inlined
def next_estimate(
    tuning: PluginTuning,
    memory: PluginMemory,
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    measured: bool,
) -> int:
    """x_{k+1|k+1}: the plug-in's step."""
    applied = memory.applied
    applied[0] = v
    applied[1] = omega
    if measured:
        seen = memory.measurement
        for n in range(3):
            seen[n] = measurement[n] if tuning.mask[n] > 0.0 else math.nan
        updated = memory.plugin.step(seen, applied)
    else:
        updated = memory.plugin.step(None, applied)
    if len(updated) != 3:
        raise ValueError("an estimator plug-in's step returns three numbers (x, y, theta)")
    if not (is_number(updated[0]) and is_number(updated[1]) and is_number(updated[2])):
        raise TypeError("an estimator plug-in's step returns three numbers (x, y, theta), not text")
    estimate[0] = float(updated[0])
    estimate[1] = float(updated[1])
    estimate[2] = float(updated[2])
    return 0


def tuning_of(settings: PythonEstimator, measurements: Measurements) -> PluginTuning:
    return PluginTuning(
        settings.entry,
        json.dumps(settings.params),
        float(measurements.dt),
        measurements.mask,
        measurements.noise_std,
    )


def new_memory(tuning: PluginTuning, initial_estimate: FloatArray) -> PluginMemory:
    """The plug-in, made for one run."""
    make = load_entry(tuning.entry)
    mask, noise, start = tuning.mask, tuning.noise_std, initial_estimate
    setup = EstimatorSetup(
        dt=tuning.dt,
        measured=(bool(mask[0]), bool(mask[1]), bool(mask[2])),
        noise_std=(float(noise[0]), float(noise[1]), float(noise[2])),
        initial_estimate=(float(start[0]), float(start[1]), float(start[2])),
    )
    return PluginMemory(
        plugin=make(json.loads(tuning.params), setup),
        measurement=np.zeros(3),
        applied=np.zeros(2),
    )


# Registered by wmr_mission.estimators.
ESTIMATOR = EstimatorType(
    settings=PythonEstimator,
    tuning_record=PluginTuning,
    tuning_of=tuning_of,
    new_memory=new_memory,
    step=next_estimate,
    plugin=True,
)
