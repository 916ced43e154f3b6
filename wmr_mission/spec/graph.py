"""The phase graph of a mission's reactions, proved before anything runs.

Nodes are the phases as they run (repeats written out) and the phases of
each contingency; edges are what may follow a phase: its exit condition met
(the next phase, or what follows a contingency), and each of its reactions.
Two kinds of edge are counted: a retry (``retry: {times: N}``) and entering a
contingency (its ``times``). Counts are per run and never reset, so a run
takes each counted edge at most its count and, between two counted edges,
only uncounted ones. :func:`prove` checks that the uncounted edges form no
cycle; then every path through the graph ends, after at most
``(1 + sum of the counts) * phases`` phase entries. No count is reset by
re-entering a phase (a loop inside a loop does not restart the inner loop's
count, the mistake that makes MAVLink ``DO_JUMP`` missions loop for ever).

The same graph bounds a run's length (:func:`worst_case_samples`): the longest
path of uncounted edges from the first phase, plus, for each count, that many
times the longest path of uncounted edges from where its edge leads.

The other proofs: every ``goto`` names a phase written at the top of
``phases``; every text reaction is fail, next or a contingency's name; every
contingency is named by some reaction; ``on_breach`` has a geofence to watch;
a contingency's phases each end by a time bound; a contingency that ends
``then: next`` never comes back to its own end to find what is next. Every
algorithm here is iterative: a graph of thousands of phases never recurses
on the Python stack.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Iterator
from typing import Any, Final, Literal, NamedTuple

from wmr_mission.basics import samples
from wmr_mission.fields import did_you_mean
from wmr_mission.spec.models import Contingency, Mission, Phase
from wmr_mission.spec.reactions import BUILT_IN_CONTINGENCIES, BUILT_IN_TIMEOUT, Goto, Retry
from wmr_mission.spec.repeats import DataPath, run_order

__all__ = ["GraphError", "prove", "worst_case_samples"]

_END: Final = -1
_FAIL: Final = -2


class GraphError(NamedTuple):
    path: DataPath
    message: str
    at_key: bool = False
    severity: Literal["error", "warning"] = "error"


def _times_out_only(phase: Phase) -> bool:
    """A phase without an exit condition that has a timeout: it ends by it alone."""
    return phase.timeout is not None and not any(v is not None for _, v in phase.until)


class _Node(NamedTuple):
    label: str
    phase: Phase
    where: DataPath
    contingency: str | None  # the contingency it belongs to


class _Edge(NamedTuple):
    to: int
    where: DataPath | None  # the reaction that makes it (None: the phase's own order)
    # A counted edge: what counts it (a retry, a contingency) and how many times it may be taken.
    counter: Hashable = None
    times: int = 0

    @property
    def counted(self) -> bool:
        return self.counter is not None


def _dotted(path: DataPath) -> str:
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")


class _Graph:
    def __init__(self, mission: Mission) -> None:
        self.mission = mission
        self.errors: list[GraphError] = []
        runs = run_order(mission)
        self.nodes = [_Node(r.label, r.phase, r.where, None) for r in runs]
        self.main_count = len(self.nodes)
        self.top = {r.label: i for i, r in enumerate(runs) if r.lap is None}
        self.in_repeat = {r.phase.name for r in runs if r.lap is not None}
        self.spans: dict[str, tuple[int, int, Contingency]] = {}
        for name, contingency in mission.contingencies.items():
            first = len(self.nodes)
            for j, phase in enumerate(contingency.phases):
                where = ("contingencies", name, "phases", j)
                self.nodes.append(_Node(phase.name, phase, where, name))
            self.spans[name] = (first, len(self.nodes) - 1, contingency)
        self.named: set[str] = set()  # contingencies some reaction names
        self.callers: dict[str, list[int]] = {}
        self.edges: list[list[_Edge]] = [[] for _ in self.nodes]
        self.after_next: dict[str, list[int]] = {}  # see `_after_next`

    # --- targets ---------------------------------------------------------

    def goto(self, goto: Goto, where: DataPath) -> int | None:
        target = self.top.get(goto.goto)
        if target is not None:
            return target
        name = goto.goto
        if name in self.in_repeat:
            why = f"phase {name!r} is inside a repeat; a goto enters a phase written at the top"
        elif any(n.label == name for n in self.nodes[self.main_count :]):
            why = f"phase {name!r} belongs to a contingency; a goto enters a mission phase"
        else:
            names = ", ".join(sorted(self.top)) or "none"
            hint = did_you_mean(name, sorted(self.top))
            why = f"no phase is named {name!r}{hint} (phases a goto may enter: {names})"
        self.errors.append(GraphError((*where, "goto"), why))
        return None

    def completed(self, index: int) -> list[tuple[int, DataPath | None]]:
        """Where a phase goes when it ends by its exit condition."""
        node = self.nodes[index]
        if node.contingency is None:
            return [(index + 1 if index + 1 < self.main_count else _END, None)]
        _, last, contingency = self.spans[node.contingency]
        if index < last:
            return [(index + 1, None)]
        then = contingency.then
        where: DataPath = ("contingencies", node.contingency, "then")
        if isinstance(then, Goto):
            target = self.goto(then, where)
            return [] if target is None else [(target, where)]
        if then == "end":
            return [(_END, where)]
        if then == "fail":
            return [(_FAIL, where)]
        if then == "resume":
            return [(c, where) for c in self.callers.get(node.contingency, [])]
        return [(to, where) for to in self._after_next(node.contingency)]

    def _ends_next(self, index: int) -> str | None:
        """The contingency whose last phase ``index`` is, when it ends `then: next`."""
        name = self.nodes[index].contingency
        if name is None or index != self.spans[name][1] or self.spans[name][2].then != "next":
            return None
        return name

    def _after_next(self, name: str) -> list[int]:
        """The phases that may follow contingency ``name`` ending `then: next`: what
        follows each phase that calls it, through the contingencies (themselves
        ending `then: next`) whose last phase does. A contingency met again on
        the way could follow its own end for ever (the run keeps its latest
        caller only): an error at its `then`. Depth first on a stack of our own."""
        if name in self.after_next:
            return self.after_next[name]
        found: dict[str, dict[int, None]] = {name: {}}
        stack = [(name, iter(self.callers.get(name, [])))]
        while stack:
            current, callers = stack[-1]
            for caller in callers:
                inner = self._ends_next(caller)
                if inner is None:
                    found[current].update((to, None) for to, _ in self.completed(caller))
                elif inner in self.after_next:
                    found[current].update((to, None) for to in self.after_next[inner])
                elif inner in found:  # on the stack: a loop of `then: next`
                    self.errors.append(
                        GraphError(
                            ("contingencies", inner, "then"),
                            f"then: next of contingency {inner!r} can lead back to its own end "
                            f"(its last phase {self.nodes[caller].label!r} is among what calls "
                            f"{current!r}), so no phase is next; end it otherwise: resume, end, "
                            "fail or {goto: PHASE}",
                        )
                    )
                else:
                    found[inner] = {}
                    stack.append((inner, iter(self.callers.get(inner, []))))
                    break
            else:
                stack.pop()
                self.after_next[current] = list(found.pop(current))
                if stack:
                    found[stack[-1][0]].update(dict.fromkeys(self.after_next[current]))
        return self.after_next[name]

    # --- edges -----------------------------------------------------------

    def reactions(self) -> None:
        """The reaction edges; a contingency's callers first, for `resume`."""
        mission = self.mission
        watched = mission.geofence is not None
        found: list[tuple[int, Any, DataPath, str]] = []
        for index, node in enumerate(self.nodes):
            levels: list[tuple[Any, DataPath]] = [(node.phase, node.where)]
            if node.contingency is None:
                levels.append((mission, ()))
            for event in ("on_timeout", "on_breach", "on_failure"):
                reaction, where = self._effective(levels, event)
                if event == "on_breach" and not watched:
                    continue
                if event == "on_failure":  # a missed verdict: none, judged after the run
                    if reaction is not None:
                        found.append((index, reaction, where, event))
                    continue
                if reaction is None:
                    reaction = "fail" if event == "on_timeout" or node.contingency is None else None
                if reaction is not None:
                    found.append((index, reaction, where, event))
        if not watched:
            for level, where in [(mission, ()), *((n.phase, n.where) for n in self.nodes)]:
                if level.on_breach is not None:
                    self.errors.append(
                        GraphError(
                            (*where, "on_breach"),
                            "on_breach has nothing to watch: give the mission a geofence "
                            "(keep_in, keep_out)",
                            at_key=True,
                        )
                    )
        for index, reaction, _, _ in found:
            name = reaction.retry.then if isinstance(reaction, Retry) else reaction
            if isinstance(name, str) and name not in ("fail", "next"):
                self.callers.setdefault(name, []).append(index)
        for index, reaction, where, _ in found:
            self._edges_of(index, reaction, where)

    @staticmethod
    def _effective(levels: list[tuple[Any, DataPath]], event: str) -> tuple[Any, DataPath]:
        for level, where in levels:
            for key in dict.fromkeys((event, "on_failure")):
                reaction = getattr(level, key)
                if reaction is not None:
                    return reaction, (*where, key)
        return None, ()

    def _edges_of(self, index: int, reaction: Any, where: DataPath) -> None:
        edges = self.edges[index]
        if isinstance(reaction, Retry):
            edges.append(_Edge(index, where, counter=where, times=reaction.retry.times))
            reaction, where = reaction.retry.then, (*where, "retry", "then")
        if isinstance(reaction, Goto):
            target = self.goto(reaction, where)
            if target is not None:
                edges.append(_Edge(target, where))
        elif reaction == "fail":
            edges.append(_Edge(_FAIL, where))
        elif reaction == "next":
            edges.extend(_Edge(to, where) for to, _ in self.completed(index))
        elif reaction in self.spans:
            self.named.add(reaction)
            first, _, contingency = self.spans[reaction]
            edges.append(_Edge(first, where, counter=reaction, times=contingency.times))
        elif reaction in BUILT_IN_CONTINGENCIES:
            # a failsafe: its one phase, then the run ends failed
            edges.append(_Edge(_FAIL, where, counter=reaction, times=1))
        elif reaction in ("goto", "retry"):
            form = "{goto: PHASE}" if reaction == "goto" else "{retry: {times: N}}"
            self.errors.append(GraphError(where, f"{reaction!r} needs its argument: {form}"))
        else:
            written = ", ".join(sorted(self.spans)) or "none written"
            names = ["fail", "next", *BUILT_IN_CONTINGENCIES, *sorted(self.spans)]
            hint = did_you_mean(str(reaction), names)
            self.errors.append(
                GraphError(
                    where,
                    f"{reaction!r} is not a reaction: fail, next, a contingency's name "
                    f"(hold, return-home; this mission's: {written}), {{goto: PHASE}} or "
                    f"{{retry: {{times: N}}}}{hint}",
                )
            )

    def order(self) -> None:
        """Each phase's edges to what follows its end by its exit condition; a
        phase with none (no `until`, or an empty one) but a timeout ends only
        by it, whose reaction (``on_timeout``) is its only way on (one with
        neither never ends, an error of its own)."""
        for index in range(len(self.nodes)):
            if _times_out_only(self.nodes[index].phase):
                continue
            for to, where in self.completed(index):
                self.edges[index].append(_Edge(to, where))

    # --- proofs ----------------------------------------------------------

    def free_edges(self) -> list[list[_Edge]]:
        """The uncounted edges between phases."""
        return [[e for e in edges if not e.counted and e.to >= 0] for edges in self.edges]

    def free_order(self) -> tuple[list[int], set[int]]:
        """The phases in an order of the uncounted edges (Kahn's), and those left
        out: the phases on or after a cycle of uncounted edges."""
        free = self.free_edges()
        indegree = [0] * len(self.nodes)
        for edges in free:
            for e in edges:
                indegree[e.to] += 1
        ready = [i for i, d in enumerate(indegree) if d == 0]
        order: list[int] = []
        while ready:
            i = ready.pop()
            order.append(i)
            for e in free[i]:
                indegree[e.to] -= 1
                if indegree[e.to] == 0:
                    ready.append(e.to)
        left = set(range(len(self.nodes))).difference(order)
        return order, left

    def unbounded_cycle(self) -> list[tuple[int, _Edge]] | None:
        """A cycle of uncounted edges, or None."""
        _, left = self.free_order()
        if not left:
            return None
        # Every phase left has an uncounted edge from a phase left (those Kahn's order
        # took out no longer count): walk such edges backwards until a phase repeats.
        free = self.free_edges()
        into: dict[int, tuple[int, _Edge]] = {}
        for i in left:
            for e in free[i]:
                if e.to in left:
                    into.setdefault(e.to, (i, e))
        i = min(left)
        seen: dict[int, int] = {}
        walk: list[tuple[int, _Edge]] = []
        while i not in seen:
            seen[i] = len(walk)
            before, edge = into[i]
            walk.append((before, edge))
            i = before
        cycle = walk[seen[i] :]
        cycle.reverse()
        return cycle

    def longest_run(self, dt: float) -> float:
        """The most samples a run takes (inf: no bound proved), see the module's text."""
        order, left = self.free_order()
        if left:
            return math.inf
        free = self.free_edges()
        bounds = [_entry_samples(node.phase, dt) for node in self.nodes]
        # From the first phase, at t = 0: a phase ending at a mission time ends no later
        # than that time, whenever it starts (at least one sample after).
        start: dict[int, float] = {0: 0.0} if self.nodes else {}
        first = 0.0
        for i in order:
            if i not in start:
                continue
            duration, by_time = bounds[i]
            end = start[i] + duration
            if by_time is not None:
                end = min(end, max(start[i] + 1, by_time))
            first = max(first, end)
            for e in free[i]:
                start[e.to] = max(start.get(e.to, 0.0), end)
        # From anywhere, at any time: the longest path of uncounted edges from each phase.
        longest = [0.0] * len(self.nodes)
        for i in reversed(order):
            duration, by_time = bounds[i]
            own = duration if by_time is None else min(duration, by_time)
            longest[i] = own + max((longest[e.to] for e in free[i]), default=0.0)
        failsafe = float(max(1, samples(BUILT_IN_TIMEOUT, dt)) + 1)
        counts: dict[Hashable, float] = {}
        for edges in self.edges:
            for e in edges:
                if e.counted:
                    after = longest[e.to] if e.to >= 0 else failsafe
                    counts[e.counter] = max(counts.get(e.counter, 0.0), e.times * after)
        return first + sum(counts.values()) + 1

    def reaches_end(self) -> bool:
        return _END in self.reached()

    def reached(self) -> set[int]:
        """The nodes a run can enter from the first phase, and the ends (_END, ...)
        it can come to."""
        todo, seen = [0], {0}
        while todo:
            for e in self.edges[todo.pop()]:
                if e.to not in seen:
                    seen.add(e.to)
                    if e.to >= 0:
                        todo.append(e.to)
        return seen


def _entry_samples(phase: Phase, dt: float) -> tuple[float, float | None]:
    """The most samples one entry of ``phase`` takes by its timeout or elapsed time
    (inf: neither), and the sample its mission time ends it by (None: none)."""
    until = phase.until
    bounds = [b for b in (phase.timeout, until.elapsed) if b is not None]
    duration = float(max(1, samples(min(bounds), dt)) + 1) if bounds else math.inf
    if until.mission_time is None:
        return duration, None
    return duration, float(max(1, samples(until.mission_time, dt)) + 1)


def _built(mission: Mission) -> _Graph:
    graph = _Graph(mission)
    graph.reactions()
    graph.order()
    return graph


def worst_case_samples(mission: Mission) -> float:
    """The most samples a run of ``mission`` can take: every phase to its time bound,
    every retry and contingency run as often as its count allows, along the longest
    path of the phase graph (inf when the graph proves no bound). The one sum of a
    run's worst case: ``validate``'s limit, the runner's budget, the free space."""
    return _built(mission).longest_run(float(mission.robot.dt))


def prove(mission: Mission) -> Iterator[GraphError]:
    """Every problem of the mission's phase graph (none for a mission without reactions)."""
    graph = _Graph(mission)
    for name in mission.contingencies:
        if name in BUILT_IN_CONTINGENCIES:
            yield GraphError(
                ("contingencies", name),
                f"contingency {name!r} is built in; name yours otherwise",
                at_key=True,
            )
    graph.reactions()
    graph.order()
    yield from graph.errors
    labels = {n.label: n.where for n in graph.nodes[: graph.main_count]}
    for node in graph.nodes[graph.main_count :]:
        phase = node.phase
        if node.label in labels:
            yield GraphError(
                (*node.where, "name"),
                f"phase name {node.label!r} is already used by {_dotted(labels[node.label])}; "
                "phase names must be unique",
            )
        labels.setdefault(node.label, node.where)
        until = phase.until
        if phase.timeout is None and until.elapsed is None and until.mission_time is None:
            yield GraphError(
                node.where,
                f"phase {phase.name!r} can never be guaranteed to end: give it a timeout, or "
                "until.elapsed or until.mission_time",
            )
    for name in BUILT_IN_CONTINGENCIES:
        # a built-in contingency's phase is named after it
        if name in graph.callers and name in labels and name not in mission.contingencies:
            yield GraphError(
                (*labels[name], "name"),
                f"phase name {name!r} is taken by the built-in contingency a reaction runs; "
                "name the phase otherwise",
            )
    for name in mission.contingencies:
        if name not in graph.named and name not in BUILT_IN_CONTINGENCIES:
            yield GraphError(
                ("contingencies", name),
                f"contingency {name!r} is unreachable: no reaction names it",
                at_key=True,
            )
    if graph.errors:
        return  # the cycles of a graph with a missing target mean little
    reached = graph.reached()
    for index, node in enumerate(graph.nodes[: graph.main_count]):
        if index not in reached:
            yield GraphError(
                node.where,
                f"phase {node.label!r} never runs: no phase goes on to it (each before it "
                "ends by a reaction that goes elsewhere); remove it or reach it",
                severity="warning",
            )
    cycle = graph.unbounded_cycle()
    if cycle is not None:
        names = " -> ".join(
            [*(graph.nodes[i].label for i, _ in cycle), graph.nodes[cycle[0][0]].label]
        )
        # the reaction that leads back (a goto, a `then`), else any reaction on the way
        written = [(i, e) for i, e in cycle if e.where is not None]
        back = [e for i, e in written if e.to <= i] or [e for _, e in written]
        where = back[0].where if back else graph.nodes[cycle[0][0]].where
        assert where is not None
        yield GraphError(
            where,
            f"these phases can loop for ever: {names}; bound the loop with "
            "{retry: {times: N}} or by running a contingency (its times)",
        )
    elif not graph.reaches_end():
        endless = [n for n in graph.nodes if _times_out_only(n.phase)]
        if not endless:
            yield GraphError(
                ("phases",), "no path through the phases and their reactions ends in success", True
            )
            return
        # at the first such phase: its empty `until`, else its name (it has none)
        first = endless[0]
        yield GraphError(
            (*first.where, "until" if "until" in first.phase.model_fields_set else "name"),
            "no path through the phases and their reactions ends in success (phases without "
            f"an `until`, which end only by their timeout: {', '.join(n.label for n in endless)}"
            "); give such a phase an `until` condition, or `on_timeout: next`",
            at_key=True,
        )
