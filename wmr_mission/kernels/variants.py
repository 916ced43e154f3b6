"""The estimator and the control law the loop runs, chosen by the type of their
tuning record.

:func:`estimator_step` and :func:`control_step` are what the loop
(wmr_mission.kernels.loop) calls once per sample. Each looks up the step of
the variant whose tuning record it is handed: in plain Python a dictionary
lookup (the runner replaces it by the step itself, wmr_mission.kernels.jit.plain);
compiled, numba resolves it once per record type (``overload``), so the loop
is compiled, and cached, for the variants a mission names, with their steps
compiled into it. The tables are filled by registration
(wmr_mission.estimators.registry, wmr_mission.controllers.registry).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import jit
from wmr_mission.kernels.records import Plant

# Tuning record type -> the variant's step (a kernel).
ESTIMATOR_STEPS: dict[type, Callable[..., int]] = {}
CONTROL_STEPS: dict[type, Callable[..., None]] = {}


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
    step = ESTIMATOR_STEPS[type(tuning)]
    return step(tuning, memory, estimate, v, omega, dt, measurement, measured)


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
    step = CONTROL_STEPS[type(tuning)]
    step(tuning, phase, aim_now, aim, estimate, estimate_prev, u_prev, plant, memory, scratch, u)


def _teach_numba() -> None:
    """Compiled, each call becomes the step of the record type it is handed."""
    from numba.extending import overload

    @overload(estimator_step, inline="always")
    def _estimator_step(
        tuning: Any,
        memory: Any,
        estimate: Any,
        v: Any,
        omega: Any,
        dt: Any,
        measurement: Any,
        measured: Any,
    ) -> Any:
        step = ESTIMATOR_STEPS.get(getattr(tuning, "instance_class", None))  # type: ignore[arg-type]
        if step is None:
            return None

        def implementation(
            tuning: Any,
            memory: Any,
            estimate: Any,
            v: Any,
            omega: Any,
            dt: Any,
            measurement: Any,
            measured: Any,
        ) -> Any:
            return step(tuning, memory, estimate, v, omega, dt, measurement, measured)

        return implementation

    @overload(control_step, inline="always")
    def _control_step(
        tuning: Any,
        phase: Any,
        aim_now: Any,
        aim: Any,
        estimate: Any,
        estimate_prev: Any,
        u_prev: Any,
        plant: Any,
        memory: Any,
        scratch: Any,
        u: Any,
    ) -> Any:
        step = CONTROL_STEPS.get(getattr(tuning, "instance_class", None))  # type: ignore[arg-type]
        if step is None:
            return None

        def implementation(
            tuning: Any,
            phase: Any,
            aim_now: Any,
            aim: Any,
            estimate: Any,
            estimate_prev: Any,
            u_prev: Any,
            plant: Any,
            memory: Any,
            scratch: Any,
            u: Any,
        ) -> Any:
            step(
                tuning, phase, aim_now, aim, estimate, estimate_prev, u_prev, plant, memory,
                scratch, u,
            )  # fmt: skip

        return implementation


jit.when_loaded(_teach_numba)
