"""The estimator's and the controller's step, as the loop names them.

The loop (wmr_mission.kernels.loop) calls :func:`estimator_step` and
:func:`control_step` once per sample. The runner binds both names to the steps
of the mission's estimator and controller, chosen through their registries
(wmr_mission.estimators, wmr_mission.controllers), in a copy of the loop of
their own (``jit.bind``); compiled, the copy is compiled, and cached, once per
estimator and controller, their steps inlined into it. Unbound, these are only
the signatures.
"""

from __future__ import annotations

from typing import Any

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.records import Plant


def estimator_step(
    tuning: Any,
    memory: Any,
    estimate: FloatArray,
    v: float,
    omega: float,
    dt: float,
    measurement: FloatArray,
    measured: bool,
) -> int:
    """x_{k|k} -> x_{k+1|k+1} in place (wmr_mission.estimators.registry)."""
    raise NotImplementedError("the runner binds the mission's estimator here")


def estimator_spread(memory: Any, out: FloatArray) -> None:
    """The standard deviation of the estimate's error per state that the
    estimator holds, into ``out`` (wmr_mission.output.covariance binds it)."""
    raise NotImplementedError("the estimation figure binds the run's estimator here")


def control_step(
    tuning: Any,
    phase: Any,
    aim_now: FloatArray,
    aim: FloatArray,
    estimate: FloatArray,
    estimate_prev: FloatArray,
    u_prev: FloatArray,
    plant: Plant,
    memory: FloatArray,
    scratch: Any,
    u: FloatArray,
) -> None:
    """u_k into ``u`` (wmr_mission.controllers.registry)."""
    raise NotImplementedError("the runner binds the mission's controller here")
