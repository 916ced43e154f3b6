"""Whether a run needed its reactions: summary.json's ``recovery``.

A run's ``outcome`` says how it ended; ``recovery`` says, separately, whether
it got there through a reaction (a retry, a goto, a contingency, a timeout
that went on to the next phase): ``success``, ``success-after-recovery`` or
``failure``, with the exit code of ``wmr-mission run`` for each
(docs/run-directory.md).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any, Final, Protocol

__all__ = ["EXIT_CODES", "fired", "recovery_record"]

EXIT_CODES: Final = {"success": 0, "success-after-recovery": 0, "failure": 1}


class _Transition(Protocol):  # wmr_mission.record.Transition
    @property
    def reaction(self) -> str | None: ...


def fired(transition: _Transition) -> list[str]:
    """The reaction a transition records that ran, by kind: ``retry``,
    ``goto``, ``next``, ``fail`` or a contingency's name. A retry whose count
    is spent did not run: what followed it did (``retry: 2 spent: next`` is a
    ``next``); a contingency whose runs are spent did not run either: the
    mission failed (``detour (spent: 1 runs)`` is a ``fail``)."""
    reaction = transition.reaction
    if reaction is None or reaction.startswith("then:"):
        return []  # a contingency's end is part of the contingency
    if "(spent:" in reaction:
        return ["fail"]
    ran = reaction.split(" spent: ")[-1]
    return [ran.split(":", 1)[0].split(" ", 1)[0]]


def recovery_record(transitions: Sequence[_Transition], succeeded: bool) -> dict[str, Any]:
    """Of a run's ``transitions``: ``result`` (success, success-after-recovery,
    failure), ``exit_code``, ``reactions`` (how many fired) and ``fired`` (how
    often each kind fired)."""
    counts: Counter[str] = Counter()
    reactions = 0
    for transition in transitions:
        kinds = fired(transition)
        reactions += bool(kinds)
        counts.update(kinds)
    if not succeeded:
        verdict = "failure"
    elif reactions:
        verdict = "success-after-recovery"
    else:
        verdict = "success"
    return {
        "result": verdict,
        "exit_code": EXIT_CODES[verdict],
        "reactions": reactions,
        "fired": dict(sorted(counts.items())),
    }
