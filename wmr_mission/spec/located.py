"""Where in a mission file a run's failure was written: the key a failed
run's last line points at (``FILE:LINE:COL``), as a mission's errors do, so
that an editor or a CI log links a timeout to its ``timeout`` and a missed
threshold to the ``expect`` line that set it."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

from wmr_mission.spec.repeats import DataPath

__all__ = ["failure_path"]


def failure_path(
    data: Any, outcome: str, phase: str | None, metric: str | None = None
) -> DataPath | None:
    """The data path of what a run that ended with ``outcome`` failed on, in
    the mission as written (``data``: its plain data):

    - a missed threshold (``expect-failed``; ``metric`` the first missed
      check's, ``phase`` its phase, None for a mission-wide one): the
      ``expect`` key that set it, the phase's own before the mission's (a
      formula: its place in the ``temporal`` list; an ``auto`` bound written
      nowhere: the phase's name);
    - a timeout: the phase's ``timeout``;
    - another failure in a phase (a divergence, a breach, ...): the phase's name.

    ``phase`` is the phase's name as run (a repeated phase's ``name#lap``).
    None where nothing written names it (a mission built from data, a run
    that was stopped)."""
    if not isinstance(data, Mapping):
        return None
    at = None if phase is None else _written_phases(data).get(phase.split("#", 1)[0])
    if outcome == "expect-failed" and metric is not None:
        if at is not None:
            found = _expect_key(_at(data, at).get("expect"), metric)
            if found is not None:
                return (*at, "expect", *found)
        found = _expect_key(data.get("expect"), metric)
        if found is not None:
            return ("expect", *found)
    if at is None:
        return None
    if outcome == "timeout" and "timeout" in _at(data, at):
        return (*at, "timeout")
    return (*at, "name")


def _expect_key(expect: Any, metric: str) -> DataPath | None:
    """Where ``metric`` (a formula's text, or ``name`` or ``name.state``) is
    bounded in an ``expect`` mapping as written, if it is."""
    if not isinstance(expect, Mapping):
        return None
    formulas = expect.get("temporal")
    if isinstance(formulas, list) and metric in formulas:
        return ("temporal", formulas.index(metric))
    name, _, state = metric.partition(".")
    bound = expect.get(name)
    if bound is None:
        return None
    if state and isinstance(bound, Mapping) and bound.get(state) is not None:
        return (name, state)
    return (name,)


def _written_phases(data: Mapping[str, Any]) -> dict[str, DataPath]:
    """Each phase's path by its name, those of a repeat group's inside it."""
    return dict(_phases(data.get("phases"), ("phases",)))


def _phases(steps: Any, at: DataPath) -> Iterator[tuple[str, DataPath]]:
    for number, step in enumerate(steps if isinstance(steps, list) else ()):
        if not isinstance(step, Mapping):
            continue
        repeat = step.get("repeat")
        if isinstance(repeat, Mapping):
            yield from _phases(repeat.get("phases"), (*at, number, "repeat", "phases"))
        elif isinstance(step.get("name"), str):
            yield step["name"], (*at, number)


def _at(data: Mapping[str, Any], path: DataPath) -> Mapping[str, Any]:
    """The mapping at ``path`` of ``data`` (a phase's, found by :func:`_phases`)."""
    found: Any = data
    for part in path:
        found = found[part]
    return found if isinstance(found, Mapping) else {}
