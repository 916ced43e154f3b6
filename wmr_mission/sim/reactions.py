"""Reactions: what the run does next when a phase times out, breaches the
geofence or misses a verdict.

A decision taken between chunks of the compiled loop, which stays as it is:
the runner hands each phase's end (its exit condition, a timeout, a breach
seen in the samples just recorded, a verdict missed over its samples) to
:class:`Reactor`, which says which phase to enter and how, or how the run
ends. Every count is per run and never
reset, so a run enters at most a bounded number of phases (the proof of
wmr_mission.spec.graph).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Final, Literal, NamedTuple

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.geometry.regions import (
    CircleRegion,
    EllipseRegion,
    RegionSpec,
    ellipse_geometry,
    region_value,
)
from wmr_mission.output.result import RunResult
from wmr_mission.spec.models import (
    Contingency,
    Hold,
    HoldPhase,
    Mission,
    Phase,
    Regulate,
    RegulatePhase,
    Settled,
    Until,
)
from wmr_mission.spec.reactions import (
    BUILT_IN_CONTINGENCIES,
    BUILT_IN_TIMEOUT,
    Goto,
    Retry,
    reaction_text,
)
from wmr_mission.verdicts.metrics import check_expectations, summarize, unmet

__all__ = [
    "Breach",
    "Decision",
    "ReactionPlan",
    "Reactor",
    "Zone",
    "breach_at",
    "built_in_contingency",
    "contingency_phases",
    "missed_verdicts",
    "reaction_plan",
]

# The built-in contingencies' phases end settled within these tolerances, or
# at their timeout. Made as validating them makes them, without building the
# model's validator for it at every run's start (docs/performance.md, Start-up).
_SETTLED: Final = Settled.model_construct(position=0.05, heading=0.05)

Event = Literal["timeout", "breach", "verdict"]
_EVENT_INDEX: Final = {"timeout": 0, "breach": 1, "verdict": 2}


def built_in_contingency(name: str, mission: Mission) -> Contingency:
    """``hold``: regulate to the pose where it was called; ``return-home``: to the
    initial pose. Both are failsafes: the mission then fails, the robot at rest."""
    until = Until(settled=_SETTLED)
    phase: Phase
    if name == "hold":
        phase = HoldPhase(name="hold", hold=Hold(), until=until, timeout=BUILT_IN_TIMEOUT)
    else:
        home = mission.robot.initial_state
        phase = RegulatePhase(
            name="return-home",
            regulate=Regulate(target=home),
            until=until,
            timeout=BUILT_IN_TIMEOUT,
        )
    return Contingency(phases=[phase], then="fail")


def _reactions_of(phase: Phase, mission: Mission | None) -> tuple[Any, Any, Any]:
    """The reactions to a timeout, a breach and a missed verdict of ``phase``:
    its own, else the mission's (``mission`` is None for a contingency's phase);
    the specific one before ``on_failure``; a timeout fails by default, a
    verdict without ``on_failure`` is judged after the run only."""
    levels = [phase] if mission is None else [phase, mission]
    timeout = next(
        (r for level in levels for r in (level.on_timeout, level.on_failure) if r is not None),
        "fail",
    )
    breach = next(
        (r for level in levels for r in (level.on_breach, level.on_failure) if r is not None),
        None if mission is None else "fail",
    )
    verdict = next((level.on_failure for level in levels if level.on_failure is not None), None)
    return timeout, breach, verdict


def used_contingencies(mission: Mission) -> list[str]:
    """The contingencies some reaction names (a written one, or a built-in), in the
    order first named; a contingency's own reactions count too."""
    found: list[str] = []
    written = mission.contingencies

    def visit(reaction: Any) -> None:
        name = reaction.retry.then if isinstance(reaction, Retry) else reaction
        if not isinstance(name, str) or name in found:
            return
        if name in written or name in BUILT_IN_CONTINGENCIES:
            found.append(name)

    levels: list[Any] = [mission, *_written_phases(mission)]
    for contingency in written.values():
        levels.extend(contingency.phases)
    for level in levels:
        for reaction in (level.on_timeout, level.on_breach, level.on_failure):
            if reaction is not None:
                visit(reaction)
    return found


def _written_phases(mission: Mission) -> list[Phase]:
    from wmr_mission.spec.repeats import run_order

    return [run.phase for run in run_order(mission)]


def contingency_phases(mission: Mission) -> list[tuple[str, Phase]]:
    """The phases of every contingency a reaction names, labelled for the run's
    records, in the order they are planned after the mission's phases."""
    phases: list[tuple[str, Phase]] = []
    for name in used_contingencies(mission):
        contingency = mission.contingencies.get(name) or built_in_contingency(name, mission)
        phases.extend((phase.name, phase) for phase in contingency.phases)
    return phases


class Zone(NamedTuple):
    """A geofence zone: its region and the side the robot keeps to."""

    name: str
    region: RegionSpec
    keep: Literal["in", "out"]


class ContingencySpan(NamedTuple):
    first: int  # index of its first phase in the plan
    last: int
    then: str | Goto
    times: int


class ReactionPlan(NamedTuple):
    """The reactions of a planned mission, in phase indices."""

    main_count: int  # the mission's phases come first; contingencies' after them
    # per phase: the reactions to a timeout, to a breach (None: not watched) and
    # to a missed verdict (None: judged after the run only)
    reactions: tuple[tuple[Any, Any, Any], ...]
    contingency_of: tuple[str | None, ...]
    contingencies: dict[str, ContingencySpan]
    goto: dict[str, int]  # a top-level phase's name -> its index
    zones: tuple[Zone, ...] = ()
    margin: float = 0.0
    # the mission as written with its defaults, whose `expect` judges a phase
    # at its end where it reacts to a missed verdict (None: none does)
    written: dict[str, Any] | None = None

    def watches(self, index: int) -> bool:
        return bool(self.zones) and self.reactions[index][1] is not None

    def judges(self, index: int) -> bool:
        return self.reactions[index][2] is not None


def reaction_plan(mission: Mission, main_labels: list[str]) -> ReactionPlan | None:
    """The mission's reactions planned, or None when it has none (the run is then
    exactly a run without reactions)."""
    written = (mission.on_timeout, mission.on_breach, mission.on_failure)
    phases = _written_phases(mission)
    if (
        mission.geofence is None
        and all(r is None for r in written)
        and all(
            r in (None, "fail", "next")
            for p in phases
            for r in (p.on_timeout, p.on_breach, p.on_failure)
        )
    ):
        return None
    reactions: list[tuple[Any, Any, Any]] = [_reactions_of(p, mission) for p in phases]
    contingency_of: list[str | None] = [None] * len(phases)
    spans: dict[str, ContingencySpan] = {}
    for name in used_contingencies(mission):
        contingency = mission.contingencies.get(name) or built_in_contingency(name, mission)
        first = len(reactions)
        for phase in contingency.phases:
            reactions.append(_reactions_of(phase, None))
            contingency_of.append(name)
        spans[name] = ContingencySpan(
            first, len(reactions) - 1, contingency.then, contingency.times
        )
    # a phase written in a repeat is labelled name#lap: not a goto's target
    top = {label: i for i, label in enumerate(main_labels) if "#" not in label}
    zones: list[Zone] = []
    margin = 0.0
    if mission.geofence is not None:
        fence = mission.geofence
        zones = [Zone(n, mission.regions[n], "in") for n in fence.keep_in]
        zones += [Zone(n, mission.regions[n], "out") for n in fence.keep_out]
        margin = float(fence.margin)
    judged = any(r[2] is not None for r in reactions)
    return ReactionPlan(
        written=mission.model_dump(mode="json") if judged else None,
        main_count=len(phases),
        reactions=tuple(reactions),
        contingency_of=tuple(contingency_of),
        contingencies=spans,
        goto=top,
        zones=tuple(zones),
        margin=margin,
    )


def depth(zone: Zone, x: FloatArray, y: FloatArray) -> FloatArray:
    """[m] how far each point is on the wrong side of ``zone`` (negative: the right
    side). Exact for circles, and beyond a straight edge of a box, polygon or
    half-plane (near a corner, a lower bound); for an ellipse, the scaled
    value times the smaller semi-axis, a lower bound."""
    value = region_value(zone.region, x, y)
    if isinstance(zone.region, EllipseRegion | CircleRegion):
        _, _, a, b, _ = ellipse_geometry(zone.region)
        value = (np.sqrt(np.maximum(value + 1.0, 0.0)) - 1.0) * min(a, b)
    return value if zone.keep == "in" else -value


class Breach(NamedTuple):
    sample: int  # the first row breaching, by index in the recording
    time: float  # [s] its time
    zone: str
    depth: float  # [m] on the wrong side of the zone's boundary
    position: Literal["true", "estimate"]


def breach_at(plan: ReactionPlan, floats: FloatArray, start: int, stop: int) -> Breach | None:
    """The first recorded sample in ``start..stop`` whose true or estimated
    position is deeper than the margin in a zone, or None."""
    if stop <= start:
        return None
    rows = floats[start:stop]
    first: Breach | None = None
    for zone in plan.zones:
        for position, (cx, cy) in (("true", (1, 2)), ("estimate", (4, 5))):
            d = depth(zone, rows[:, cx], rows[:, cy])
            hits = np.flatnonzero(d > plan.margin)
            if hits.size and (first is None or start + int(hits[0]) < first.sample):
                j = int(hits[0])
                first = Breach(
                    start + j,
                    round(float(rows[j, 0]), 9),
                    zone.name,
                    float(d[j]),
                    position,  # type: ignore[arg-type]
                )
    return first


class Decision(NamedTuple):
    """What follows a phase's end: enter ``enter`` (``how``: fresh, or resume its
    path), or end the run (``enter`` None) with ``failure`` (None: success)."""

    enter: int | None
    how: Literal["fresh", "resume"] = "fresh"
    failure: str | None = None  # what failed: "timeout", "breach" or "verdict"
    reaction: str | None = None  # the reaction that fired, as written
    contingency: str | None = None  # the contingency it entered


@dataclass
class Reactor:
    """The decisions of one run, with its counts."""

    plan: ReactionPlan
    retries: dict[tuple[int, str], int] = field(default_factory=dict)
    runs: dict[str, int] = field(default_factory=dict)
    # The phase that called each contingency, and why (for resume, next, fail).
    callers: dict[str, tuple[int, str]] = field(default_factory=dict)

    def completed(self, index: int) -> Decision:
        """Phase ``index`` met its exit condition (or reacted `next`).

        A loop, not a recursion: a chain of contingencies ending `then: next`
        goes on from each caller in turn, as deep as the mission nests them."""
        plan = self.plan
        chained = False  # a contingency ended `then: next`: the caller goes on
        while True:
            name = plan.contingency_of[index]
            if name is None:
                decision = Decision(index + 1 if index + 1 < plan.main_count else None)
                break
            span = plan.contingencies[name]
            if index < span.last:
                decision = Decision(index + 1)
                break
            caller, cause = self.callers[name]
            then = span.then
            if then == "next":
                index, chained = caller, True
                continue
            if isinstance(then, Goto):
                decision = Decision(plan.goto[then.goto], reaction=f"then: goto: {then.goto}")
            elif then == "resume":
                decision = Decision(caller, "resume", reaction="then: resume")
            elif then == "end":
                decision = Decision(None, reaction="then: end")
            else:
                decision = Decision(None, failure=cause, reaction="then: fail")
            break
        return replace_reaction(decision, "then: next") if chained else decision

    def react(self, index: int, event: Event) -> Decision:
        """Phase ``index`` timed out, breached or missed a verdict: its reaction decides."""
        reaction = self.plan.reactions[index][_EVENT_INDEX[event]]
        written = reaction_text(reaction)
        if isinstance(reaction, Retry):
            used = self.retries.get((index, event), 0)
            if used < reaction.retry.times:
                self.retries[(index, event)] = used + 1
                return Decision(index, reaction=f"{written} ({used + 1} of {reaction.retry.times})")
            decision = self._apply(index, event, reaction.retry.then)
            return replace_reaction(decision, f"{written} spent: {decision.reaction}")
        return self._apply(index, event, reaction)

    def _apply(self, index: int, event: Event, reaction: Any) -> Decision:
        written = reaction_text(reaction)
        if isinstance(reaction, Goto):
            return Decision(self.plan.goto[reaction.goto], reaction=written)
        if reaction == "fail":
            return Decision(None, failure=event, reaction=written)
        if reaction == "next":
            return replace_reaction(self.completed(index), written)
        span = self.plan.contingencies[reaction]
        used = self.runs.get(reaction, 0)
        if used >= span.times:
            return Decision(None, failure=event, reaction=f"{written} (spent: {span.times} runs)")
        self.runs[reaction] = used + 1
        self.callers[reaction] = (index, event)
        return Decision(span.first, reaction=written, contingency=reaction)


def missed_verdicts(result: RunResult, written: dict[str, Any]) -> list[str]:
    """The `expect` thresholds of a phase's one entry, ``result`` (its samples
    alone), that it missed, as summary.json words them."""
    summary = summarize(result, written)
    checks = check_expectations(summary, written)
    return unmet([c for c in checks if c.phase is not None])


def replace_reaction(decision: Decision, reaction: str) -> Decision:
    return decision._replace(reaction=reaction)


def nearest_ahead(sample: Any, left_local: int, horizon: int, dt: float, x: float, y: float) -> int:
    """The phase-local sample, at or after ``left_local`` and within ``horizon``
    samples of it, where a path ``sample(t) -> (x, y, dx, dy)`` passes nearest
    to ``(x, y)``: where a resumed track phase rejoins its path."""
    t = (left_local + np.arange(max(1, horizon), dtype=np.float64)) * dt
    px, py, _, _ = sample(t)
    distance = np.hypot(np.asarray(px) - x, np.asarray(py) - y)
    return left_local + int(np.argmin(distance)) if np.isfinite(distance).any() else left_local
