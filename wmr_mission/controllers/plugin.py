"""``python``: a controller written in Python, named by the mission.

``controller: {type: python, entry: "module:callable", params: {...}}``. A run
imports the entry (wmr_mission.plugins.load_entry) and calls
``callable(params, setup)`` once, before its first sample; ``setup`` is a
:class:`ControllerSetup`. It returns the plug-in: any object with

    step(t, estimate, reference) -> (v, omega)

called once per sample k: ``t`` the mission time t_k [s], ``estimate`` the
estimate x_{k|k} (an array x, y, theta: read it, do not keep or write it),
``reference`` a :class:`Reference`. The input it returns goes through the
actuator limits, as every controller's does.

A plug-in of plain Python runs in a plain-Python loop. An instance of a numba
``@jitclass`` (its ``step`` compiled) runs inside the compiled loop, compiled
afresh in each process (never cached: its source is not the package's). An
exception raised by ``step``, or a return that is not two numbers, ends the
run ``failed`` with the plug-in's message and the sample (wmr_mission.sim.runner).
docs/controllers.md has worked examples.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np
from pydantic import Field

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.controllers.reference_motion import reference_motion
from wmr_mission.controllers.registry import ControllerSettings, ControllerType
from wmr_mission.kernels.jit import inlined
from wmr_mission.kernels.loop import EnteredPhase
from wmr_mission.kernels.model import is_number, saturate
from wmr_mission.kernels.records import Plant
from wmr_mission.plugins import Entry, Params, load_entry


class PythonController(ControllerSettings):
    """A controller from Python: ``entry`` names ``callable(params, setup)``."""

    type: Literal["python"] = Field(description="Controller kind: a plug-in written in Python.")
    entry: Entry
    params: Params = Field(default_factory=dict)


@dataclass(frozen=True)
class ControllerSetup:
    """What a controller plug-in is made with, besides its params."""

    dt: float  # [s] sampling period
    speed_limit: float  # [m/s] |v| allowed
    turn_rate_limit: float  # [rad/s] |omega| allowed


class Reference(NamedTuple):
    """The phase's reference at sample k, as a controller plug-in reads it."""

    tracking: bool  # a path to follow (track); else a pose to reach (regulate, hold)
    x: float  # [m] tracking: the path at t_k; else the target
    y: float  # [m]
    theta: float  # [rad] tracking: the path's heading at t_k; else the target heading
    v: float  # [m/s] tracking: the path's speed over [t_k, t_k+1]; else 0
    omega: float  # [rad/s] tracking: the path's turn rate over [t_k, t_k+1]; else 0
    constraint_kinds: IntArray  # the phase's constraint rows (docs/architecture.md)
    constraint_params: FloatArray


class PluginTuning(NamedTuple):
    entry: str
    params: str  # as JSON: the plug-in is made afresh for each run (new_scratch)
    setup: tuple[float, float, float]  # ControllerSetup's fields


class PluginScratch(NamedTuple):
    plugin: Any  # what callable(params, setup) returned
    estimate: FloatArray  # (3,) the estimate handed to the plug-in (a copy)
    samples: IntArray  # (1,) steps taken: t_k = k dt


@inlined
def next_input(
    tuning: PluginTuning,
    phase: EnteredPhase,
    aim_now: FloatArray,
    aim: FloatArray,
    estimate: FloatArray,
    estimate_prev: FloatArray,
    u_prev: FloatArray,
    plant: Plant,
    memory: FloatArray,
    scratch: PluginScratch,
    u: FloatArray,
) -> None:
    """u_k: the plug-in's step, then the actuator limits."""
    k = scratch.samples[0]
    scratch.samples[0] = k + 1
    if phase.tracking:
        x, y, theta, v, omega = reference_motion(aim_now, aim, plant.dt)
    else:
        x, y, theta = phase.target[0], phase.target[1], phase.target[2]
        v = 0.0
        omega = 0.0
    reference = Reference(
        phase.tracking, x, y, theta, v, omega, phase.constraint_kinds, phase.constraint_params
    )
    seen = scratch.estimate
    seen[0] = estimate[0]
    seen[1] = estimate[1]
    seen[2] = estimate[2]
    chosen = scratch.plugin.step(k * plant.dt, seen, reference)
    if len(chosen) != 2:
        raise ValueError("a controller plug-in's step returns two numbers (v, omega)")
    if not (is_number(chosen[0]) and is_number(chosen[1])):
        raise TypeError("a controller plug-in's step returns two numbers (v, omega), not text")
    v_chosen = float(chosen[0])
    omega_chosen = float(chosen[1])
    if not (math.isfinite(v_chosen) and math.isfinite(omega_chosen)):
        # Not limited (that would make it finite): the loop reports the divergence.
        u[0] = v_chosen
        u[1] = omega_chosen
        return
    u[0], u[1] = saturate(v_chosen, omega_chosen, u_prev[0], u_prev[1], plant.limits, plant.dt)


def tuning_of(settings: PythonController, plant: Plant) -> PluginTuning:
    setup = (float(plant.dt), float(plant.limits[0]), float(plant.limits[1]))
    return PluginTuning(settings.entry, json.dumps(settings.params), setup)


def new_scratch(tuning: PluginTuning) -> PluginScratch:
    """The plug-in, made for one run."""
    make = load_entry(tuning.entry)
    return PluginScratch(
        plugin=make(json.loads(tuning.params), ControllerSetup(*tuning.setup)),
        estimate=np.zeros(3),
        samples=np.zeros(1, dtype=np.int64),
    )


# Registered by wmr_mission.controllers.
CONTROLLER = ControllerType(
    settings=PythonController,
    tuning_record=PluginTuning,
    tuning_of=tuning_of,
    memory_size=0,
    new_scratch=new_scratch,
    step=next_input,
    plugin=True,
)
