"""The phases of a mission in the order they run, with repeats written out.

A ``repeat`` group runs its phases ``times`` times; each run is a lap. Checks
and the compiler both walk this list, so a repeated phase is validated and run
like any other. A phase inside a repeat is known in the run's records as
``name#lap`` (``#`` cannot appear in a phase name, so the labels stay unique).
"""

from __future__ import annotations

from typing import Final, NamedTuple

from wmr_mission.spec.models import Mission, Phase, RepeatPhase

__all__ = ["MAX_RUN_PHASES", "DataPath", "RunPhase", "label", "run_count", "run_order"]

MAX_RUN_PHASES: Final = 100_000
"""Most phases a mission may run, repeats written out."""

DataPath = tuple[str | int, ...]


class RunPhase(NamedTuple):
    phase: Phase
    where: DataPath  # where the phase is written in the file
    lap: int | None  # 1, 2, ... inside a repeat; None outside

    @property
    def label(self) -> str:
        return label(self.phase.name, self.lap)


def label(name: str, lap: int | None) -> str:
    """The name of a phase in the run's records: ``name``, or ``name#lap`` in a repeat."""
    return name if lap is None else f"{name}#{lap}"


def run_count(mission: Mission) -> int:
    """How many phases the mission runs, repeats written out."""
    return sum(
        step.repeat.times * len(step.repeat.phases) if isinstance(step, RepeatPhase) else 1
        for step in mission.phases
    )


def run_order(mission: Mission) -> list[RunPhase]:
    """Every phase in the order it runs; a repeat's phases once per lap."""
    order: list[RunPhase] = []
    for index, step in enumerate(mission.phases):
        if not isinstance(step, RepeatPhase):
            order.append(RunPhase(step, ("phases", index), None))
            continue
        for lap in range(1, step.repeat.times + 1):
            for number, phase in enumerate(step.repeat.phases):
                order.append(RunPhase(phase, ("phases", index, "repeat", "phases", number), lap))
    return order
