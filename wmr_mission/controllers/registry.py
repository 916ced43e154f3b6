"""What a controller is, and the registry of them.

A controller type is one module holding

* its settings: the model of the mission's ``controller:`` section, a subclass
  of :class:`ControllerSettings` with ``type: Literal[NAME]``;
* its tuning record: a ``NamedTuple`` of numbers and arrays, built once per run
  by ``tuning_of(settings, plant)``, which its kernel reads; the type of this
  record says which step a loop was compiled for;
* ``memory_size``: how many numbers it carries from sample to sample within a
  phase (the runner zeroes them at each phase's entry), and
  ``new_scratch(tuning)``: what it works in, made for each run (any
  ``NamedTuple`` of arrays, or of a plug-in's objects);
* its control law, a kernel (wmr_mission.kernels.jit): ``step(tuning, phase,
  aim_now, aim, estimate, estimate_prev, u_prev, plant, memory, scratch, u)``
  writes u_k = (v, omega) into ``u``. ``phase`` is the phase as the loop runs
  it (wmr_mission.kernels.loop.EnteredPhase): ``phase.tracking`` tells a path
  to follow, given at t_k and t_{k+1} by ``aim_now`` and ``aim`` (x, y, unit
  tangent x, y), from a pose to reach, ``phase.target``; its constraint rows
  are ``phase.constraint_kinds`` and ``phase.constraint_params``. ``plant`` is
  wmr_mission.kernels.records.Plant: the period and the input limits.

and one registration: ``CONTROLLERS.register(ControllerType(...))``. The runner
binds the step into the loop (wmr_mission.kernels.variants).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final, NamedTuple

from wmr_mission.fields import Model, Registry
from wmr_mission.kernels.records import Plant

DEFAULT: Final = "paper"


class ControllerSettings(Model):
    """What every controller's settings hold."""

    type: str

    def position_noise_budget(self, dt: float, speed_limit: float, turn_limit: float) -> float:
        """[m] The standard deviation of the position estimate's noise this law
        turns into at most 1 % of the turn-rate limit of jitter: the estimator's
        defaults filter the sensors' noise down to it. inf: none stated."""
        return math.inf


@dataclass(frozen=True)
class ControllerType:
    """One controller a mission may name (see the module)."""

    settings: type[ControllerSettings]
    tuning_record: type[NamedTuple]
    tuning_of: Callable[[Any, Plant], Any]
    memory_size: int
    new_scratch: Callable[[Any], Any]
    step: Callable[..., None]
    # False for a step numba cannot compile (plain Python objects): a mission
    # naming it runs its loop as plain Python.
    compiles: bool = True
    # True for a type that runs code the mission names (``type: python``): its
    # loop is compiled only when numba can type the plug-in, never cached, and
    # an exception out of it ends the run ``failed`` (wmr_mission.sim.runner).
    plugin: bool = False


CONTROLLERS: Registry[ControllerType] = Registry("controller", default=DEFAULT)
