"""A campaign's mission checked and planned once, each run's drawn pose written into the plan.

Checking a run's mission whole (pydantic, then the checks across fields) and
planning it cost about as much as simulating it. Most of a campaign's draws
are numbers that the plan holds as they are and that no check reads beyond
its field's own rule: the initial heading, the initial estimate
(:data:`WRITTEN`). Such a run starts from the mission checked and planned
with the same values of the other axes (its *base*, one per combination of
the discrete axes' values, made by the first run that has it), its drawn
numbers checked against their field's rule and written into the base's plan
and into the mission's record for the judge.

A run gets exactly what :func:`wmr_mission.campaign.checked.mission_of` and
``plan_mission`` would give it (tests/test_campaign_written.py compares them
on every shipped campaign); a drawn value the field's rule refuses, a
campaign that varies another continuous field, or a field that a sampling
check or a reaction reads takes that way instead, and is refused with the
same reason.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, replace
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike
from pydantic import TypeAdapter, ValidationError

from wmr_mission.campaign import checked
from wmr_mission.campaign.load import LoadedCampaign, value_text
from wmr_mission.campaign.plan import Draw
from wmr_mission.fields import Scalar
from wmr_mission.geometry.paths import PATHS
from wmr_mission.geometry.paths.expression import ExpressionPath
from wmr_mission.geometry.paths.registry import Sample, Trajectory
from wmr_mission.kernels.records import RUNAWAY_DISTANCE
from wmr_mission.sim.plan import (
    MissionPlan,
    PhasePlan,
    extent_but_start,
    plan_mission,
    start_extent,
)
from wmr_mission.sim.reactions import contingency_phases, used_contingencies
from wmr_mission.spec.checks import read_by_sampling_checks
from wmr_mission.spec.models import Mission, TrackPhase
from wmr_mission.spec.repeats import run_order

__all__ = ["MAX_BASES", "WRITTEN", "Base", "Written", "WrittenRun", "written_runs"]

# The fields a run writes into its base's plan: the plan's array and index. Each
# is a Scalar (wmr_mission.fields: finite, at most ABSURD) that no check across
# fields reads (wmr_mission.spec.checks.check_across_fields), and the plan reads
# it only there and in the runaway bound (sim.plan.start_extent). Keep in step.
WRITTEN: Final[dict[str, tuple[str, int]]] = {
    "robot.initial_state.theta": ("initial_state", 2),
    "estimator.initial_estimate.x": ("initial_estimate", 0),
    "estimator.initial_estimate.y": ("initial_estimate", 1),
    "estimator.initial_estimate.theta": ("initial_estimate", 2),
}

_CONTINUOUS: Final = ("uniform", "normal")

MAX_BASES: Final = 64
"""Bases kept per process, the last used: a grid's cells come run after run
(wmr_mission.campaign.plan), a choice's values at random; a base dropped is
made again if its values come back. Bounds the memory of a campaign over a
grid of many values."""


@dataclass(frozen=True)
class Base:
    """The mission checked and planned with one combination of the discrete
    axes' values, and its record as the judge reads it."""

    mission: Mission
    plan: MissionPlan
    record: dict[str, Any]
    fixed_extent: float  # sim.plan.extent_but_start
    estimate_is_start: bool  # no initial estimate written: it is the start pose
    # The extent the paths' first points and the start's position set
    # (sim.plan.start_extent without the estimate), the same for every run of
    # the base where no path's first point moves with the start heading; else
    # None (found run by run).
    start_extent: float | None


WrittenRun = tuple[MissionPlan | None, dict[str, Any], str]
"""A run's plan and its mission's record for the judge, or (None, {}, reason)."""


class Written:
    """The runs of one campaign in this process: their bases, made as runs need them."""

    def __init__(self, loaded: LoadedCampaign) -> None:
        self.loaded = loaded
        vary = loaded.campaign.vary
        self.written = [p for p, axis in vary.items() if axis.kind in _CONTINUOUS]
        self.discrete = [p for p, axis in vary.items() if axis.kind not in _CONTINUOUS]
        self.writes = all(path in WRITTEN for path in self.written)
        self.keys = {path: _keys(path) for path in self.written}
        self.bases: dict[tuple[str, ...], Base | None] = {}

    def run(self, draw: Draw) -> WrittenRun:
        """The run's plan and its mission's record for the judge, or (None, {},
        reason) when the mission refuses its values."""
        base = self._base(draw) if self.writes and _all_sound(draw, self.written) else None
        if base is None:  # checked and planned whole, as a replay does
            mission, reason = checked.mission_of(self.loaded, draw)
            if mission is None:
                return None, {}, reason
            return plan_mission(mission, draw.seed), mission.model_dump(mode="json"), ""
        return self._plan(base, draw), self._record(base, draw), ""

    def _base(self, draw: Draw) -> Base | None:
        """The base of the run's discrete values, made from the run's own
        mission if it is the first; None when a check or the plan reads a
        written field elsewhere (the runs of these values are then checked
        whole), or when the mission refuses this run (the next run tries again)."""
        key = tuple(value_text(draw.values[path]) for path in self.discrete)
        if key in self.bases:
            base = self.bases[key] = self.bases.pop(key)  # the last used, last
            return base
        mission, _ = checked.mission_of(self.loaded, draw)
        if mission is None:
            return None
        if len(self.bases) >= MAX_BASES:
            del self.bases[next(iter(self.bases))]  # the longest unused
        base = self.bases[key] = self._made(mission, draw)
        return base

    def _made(self, mission: Mission, draw: Draw) -> Base | None:
        if any(read_by_sampling_checks(path, mission) for path in self.written):
            return None
        if "robot.initial_state.theta" in self.written and (
            "return-home" in used_contingencies(mission)  # its target is the start pose
        ):
            return None
        plan = plan_mission(mission, draw.seed)
        plan = replace(plan, phases=_kept_paths(mission, plan.phases))
        x, y, theta = (float(value) for value in plan.initial_state)
        heading_free = "robot.initial_state.theta" not in self.written or _heading_free(mission)
        return Base(
            mission,
            plan,
            mission.model_dump(mode="json"),
            extent_but_start(mission, plan.regions),
            mission.estimator.initial_estimate is None,
            start_extent(mission, (x, y, theta), (x, y)) if heading_free else None,
        )

    def _plan(self, base: Base, draw: Draw) -> MissionPlan:
        arrays = {
            "initial_state": base.plan.initial_state.copy(),
            "initial_estimate": base.plan.initial_estimate.copy(),
        }
        for path in self.written:
            name, index = WRITTEN[path]
            arrays[name][index] = draw.values[path]
        if base.estimate_is_start:
            arrays["initial_estimate"] = arrays["initial_state"].copy()
        start, estimate = arrays["initial_state"], arrays["initial_estimate"]
        if base.start_extent is None:
            moved = start_extent(
                base.mission,
                (float(start[0]), float(start[1]), float(start[2])),
                (float(estimate[0]), float(estimate[1])),
            )
        else:  # the estimate's x and y: finite, as every written value is (_all_sound)
            moved = max(base.start_extent, abs(float(estimate[0])), abs(float(estimate[1])))
        extent = max(base.fixed_extent, moved)
        plant = base.plan.plant._replace(runaway_position=RUNAWAY_DISTANCE + extent)
        return replace(
            base.plan, plant=plant, seed=draw.seed, initial_state=start, initial_estimate=estimate
        )

    def _record(self, base: Base, draw: Draw) -> dict[str, Any]:
        """The base's record with the run's values: each mapping on a written
        path copied, the rest shared (the judge only reads it)."""
        record = dict(base.record)
        for path in self.written:
            *sections, name = self.keys[path]
            inner = record
            for key in sections:
                inner[key] = dict(inner[key])
                inner = inner[key]
            inner[name] = draw.values[path]
        return record


def _keys(path: str) -> tuple[str, ...]:
    return tuple(path.split("."))


_SCALAR: Final[TypeAdapter[float]] = TypeAdapter(Scalar)


def _all_sound(draw: Draw, paths: list[str]) -> bool:
    """Whether each drawn value is a float that passes its field's own rule
    (every WRITTEN field is a Scalar); else the run is checked whole, and says why."""
    for path in paths:
        value = draw.values[path]
        if not isinstance(value, float):
            return False
        try:
            _SCALAR.validate_python(value)
        except ValidationError:
            return False
    return True


def _heading_free(mission: Mission) -> bool:
    """Whether no path's first point moves with the start heading: so of every
    built-in path type (a line's heading turns it about its first point; the
    others read the position only), not of a plug-in's."""
    return all(
        PATHS[run.phase.track.path.type].trajectory.__module__.startswith("wmr_mission.geometry.")
        for run in run_order(mission)
        if isinstance(run.phase, TrackPhase)
    )


KEPT_SAMPLES: Final = 8
"""Samplings kept of each path, the first asked for: a run samples its path
in the same chunks as the run before it, in the same order (wmr_mission.sim.runner),
a long run in more than these. Those past them are made each time: kept
last in, first out instead, a run that asks for more would find none of
them, each pushing out the one asked for next."""


class _KeptSamples:
    """An expression path as written, the same curve from whatever pose its
    phase starts: sampled once for the runs of a base at the times each asks
    for (the first KEPT_SAMPLES), its arrays read-only. Numpy evaluating the
    expressions costs more than the rest of a run's Python around the loop."""

    def __init__(self, trajectory: Trajectory) -> None:
        self.trajectory = trajectory
        self.kept: dict[tuple[tuple[int, ...], bytes], Sample] = {}

    def same_from(self, pose: tuple[float, float, float]) -> Trajectory:
        """The path made for a phase entered at ``pose``: this one, whatever the pose."""
        return self

    def sample(self, t: ArrayLike) -> Sample:
        time = np.asarray(t, dtype=np.float64)
        key = (time.shape, time.tobytes())
        found = self.kept.get(key)
        if found is None:
            found = self.trajectory.sample(time)
            for array in found:
                array.flags.writeable = False
            if len(self.kept) < KEPT_SAMPLES:
                self.kept[key] = found
        return found


def _kept_paths(mission: Mission, phases: tuple[PhasePlan, ...]) -> tuple[PhasePlan, ...]:
    """The plan's phases, each expression path as written made once and its
    samplings kept (_KeptSamples); the others as planned. A path that starts
    from the robot's pose is made and sampled by each run."""
    # sim.plan's phases: one per run of a written phase, then the contingencies'
    written = [run.phase for run in run_order(mission)]
    written += [phase for _, phase in contingency_phases(mission)]
    kept = []
    for source, phase in zip(written, phases, strict=True):
        path = source.track.path if isinstance(source, TrackPhase) else None
        if phase.make_trajectory is not None and (
            isinstance(path, ExpressionPath) and path.start == "as-written"
        ):
            made = _KeptSamples(phase.make_trajectory((0.0, 0.0, 0.0)))  # any pose
            phase = replace(phase, make_trajectory=made.same_from)
        kept.append(phase)
    return tuple(kept)


class _Current(threading.local):
    written: Written | None = None


# One per thread: a Dask worker runs tasks on several threads of one process,
# and a base is made and kept by the thread that runs it.
_current = _Current()


def written_runs(loaded: LoadedCampaign) -> Written:
    """This thread's :class:`Written` of ``loaded``: made once per campaign, kept
    while the tasks of one campaign come (each brings its own copy of ``loaded``)."""
    kept = _current.written
    if kept is None or _identity(kept.loaded) != _identity(loaded):
        kept = _current.written = Written(loaded)
    return kept


def _identity(loaded: LoadedCampaign) -> tuple[Any, ...]:
    return (
        str(loaded.path),
        str(loaded.mission_path),
        loaded.campaign_sha256,
        loaded.mission_sha256,
        tuple(loaded.setting_texts()),
        loaded.campaign.seed,
    )
