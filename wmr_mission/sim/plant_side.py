"""The plant side of a run, when it is not our simulator (wmr_mission.backends).

A run has two sides: the mission's (phases, estimator, controller, recording)
and the plant's: apply (v, omega), read a timestamped measurement, say what
time it is. Our simulator's plant is the compiled loop's own (eq. (1), the
disturbances, the sensors: wmr_mission.kernels.disturbances). Another plant
replaces those three kernels of the loop, ``applied_input``, ``plant_step``
and ``sense``, by functions of the same signatures, and the loop runs as
plain Python (wmr_mission.kernels.jit.plain), as it does with the reference
step.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol

from wmr_mission.basics import FloatArray


class PlantStopped(Exception):
    """Raised by a plant side inside the loop: the run stops and fails, with
    this message as its cause (a robot whose measurements stopped)."""


class PlantSide(Protocol):
    """What the runner asks of a plant that is not the loop's own."""

    def substitutes(self) -> Mapping[Any, Callable[..., Any]]:
        """The loop's kernels replaced: ``applied_input``, ``plant_step``, ``sense``
        (wmr_mission.kernels.disturbances) to functions of the same signatures."""
        ...

    def start(self, state: FloatArray) -> None:
        """Just before sample 0: the true state filled in where the plant knows
        it (a robot's first odometry), its clock started."""
        ...

    def stop(self) -> None:
        """On every way out of the run (success, failure, a signal, an
        exception): the plant told to stop moving. Safe to call twice."""
        ...

    def confirm_stop(self) -> None:
        """Once the run's record is written: wait, a bounded time, for the plant
        to confirm the stop (a robot's acknowledgement of the zero command),
        which :meth:`report` then says. Safe to call twice."""
        ...

    def report(self) -> dict[str, Any] | None:
        """What a real-time run measured (summary.json's ``realtime``), else None."""
        ...

    def describe(self) -> dict[str, Any]:
        """The backend, its versions and settings (manifest.json's ``backend``)."""
        ...
