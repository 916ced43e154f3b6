"""Where a mission wrote its phases, and what a run's failure was written
as: the key a failed run's last line points at (``FILE:LINE:COL``), as a
mission's errors do, so that an editor or a CI log links a timeout to its
``timeout`` and a missed threshold to the ``expect`` line that set it."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

from wmr_mission.spec.repeats import DataPath

__all__ = ["failure_path", "written_phases"]


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
    """Each phase's path by its name."""
    return {str(phase.get("name")): path for path, phase in written_phases(data)}


def written_phases(data: Any) -> Iterator[tuple[DataPath, Mapping[str, Any]]]:
    """Each phase of a mission as written (its plain data, or its resolved
    form) with its data path: the mission's, those of a repeat group in its
    place, then each contingency's (a reaction runs them)."""
    if not isinstance(data, Mapping):
        return
    for number, step in enumerate(data.get("phases") or ()):
        repeat = step.get("repeat") if isinstance(step, Mapping) else None
        # (None first: the test of a Mapping costs more than the rest of a step)
        if repeat is not None and isinstance(repeat, Mapping):
            for inner, phase in enumerate(repeat.get("phases") or ()):
                yield ("phases", number, "repeat", "phases", inner), phase
        elif isinstance(step, Mapping):
            yield ("phases", number), step
    contingencies = data.get("contingencies")
    for name, contingency in contingencies.items() if isinstance(contingencies, Mapping) else ():
        for number, phase in enumerate(contingency.get("phases") or ()):
            yield ("contingencies", name, "phases", number), phase


def _at(data: Mapping[str, Any], path: DataPath) -> Mapping[str, Any]:
    """The mapping at ``path`` of ``data`` (a phase's, found by :func:`_phases`)."""
    found: Any = data
    for part in path:
        found = found[part]
    return found if isinstance(found, Mapping) else {}
