"""A mission planned for the runner: plain numbers, records and path makers.

:func:`plan_mission` is where the simulation reads the validated mission; the
runner and the kernels see only the plan. (Each variant builds its own tuning
record from its settings: wmr_mission.estimators, wmr_mission.controllers,
wmr_mission.geometry.paths.)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal, NamedTuple

import numpy as np
import pydantic

from wmr_mission.basics import STATES, FloatArray, IntArray, samples
from wmr_mission.controllers import CONTROLLERS, ControllerType
from wmr_mission.estimators import ESTIMATORS, EstimatorType
from wmr_mission.geometry import paths, regions
from wmr_mission.geometry.paths import Trajectory
from wmr_mission.geometry.regions import RegionSpec
from wmr_mission.kernels.corrective import (
    ELLIPSE_ROW,
    POLYGON_ROW,
    polygon_value,
    row_value_with_margin,
)
from wmr_mission.kernels.records import RUNAWAY_DISTANCE, RUNAWAY_INPUT, Plant
from wmr_mission.sim.draws import DisturbancePlan
from wmr_mission.sim.reactions import ReactionPlan, contingency_phases, reaction_plan
from wmr_mission.spec.changes import path_pace, with_look_ahead
from wmr_mission.spec.checks import MAX_SAMPLES
from wmr_mission.spec.graph import worst_case_samples
from wmr_mission.spec.models import (
    Limits,
    Mission,
    Phase,
    RegulatePhase,
    StayInside,
    TrackPhase,
    Until,
    Update,
)
from wmr_mission.spec.repeats import run_count, run_order


def no_rows() -> tuple[IntArray, FloatArray]:
    return np.zeros(0, dtype=np.int64), np.zeros((0, 6))


@dataclass(frozen=True)
class Conditions:
    """The ``until`` of a phase, in samples and plain numbers (None = absent)."""

    elapsed_samples: int | None = None
    mission_time: float | None = None
    # Region rows for "reaches": the region's value is the largest row value.
    reaches: str | None = None
    reaches_rows: tuple[IntArray, FloatArray] = field(default_factory=no_rows)
    near: tuple[float, float, float] | None = None  # x, y, tolerance
    settled: tuple[float, float, float] | None = None  # position, heading, speed
    heading: tuple[float, float] | None = None  # target, tolerance


@dataclass(frozen=True)
class UpdatePlan:
    """One update of a phase's reference (docs/mission-format.md, "References
    that change on-line"): when it takes over, and the new path or target."""

    when: str  # its condition as written, for transitions.json ("elapsed 20 s")
    elapsed_samples: int | None = None
    mission_time: float | None = None
    reaches: RegionSpec | None = None
    travelled: float | None = None  # [m]
    # lap: whether the phase runs its lap N or a later one (it takes over at entry)
    in_lap: bool | None = None
    # track: builds the new path from the estimated pose at the update.
    make_trajectory: Callable[[tuple[float, float, float]], Trajectory] | None = None
    target: tuple[float, float, float] | None = None  # regulate: the new target
    pace: float | None = None  # a new path's written speed (or |angular_rate|); None: none
    # track: the same path at this pace from the reference point in force
    speed: float | None = None
    # the controller's tuning with the update's look-ahead; None: unchanged
    controller_tuning: Any = None
    # hold the estimated pose where it takes over (a quiet planner's on_plan_stale: hold)
    hold: bool = False

    @property
    def changes(self) -> str:
        """What it changes, in words, for transitions.json."""
        if self.hold:
            return "hold the estimated pose"
        if self.make_trajectory is not None:
            return "a new path"
        new = [f"speed {self.speed:g}"] if self.speed is not None else []
        if self.controller_tuning is not None:
            new.append("a new look-ahead")
        return " and ".join(new) if new else "a new target"

    def for_phase(self, kind: str) -> UpdatePlan | None:
        """What of it a phase of ``kind`` takes: a track phase its path, a
        regulate phase its target (a planner's goal has both); None: nothing."""
        if self.hold and kind == "regulate":
            return replace(self, make_trajectory=None)
        if kind == "track" and self.make_trajectory is not None:
            return replace(self, target=None)
        if kind == "regulate" and self.target is not None:
            return replace(self, make_trajectory=None, pace=None)
        return None

    def first(
        self, estimates: FloatArray, first_sample: int, since: int, entry_sample: int, dt: float
    ) -> int:
        """The first sample from ``since`` on at which the update takes over, or
        -1: its condition on the estimate x_{k|k} at sample k, as a phase's
        `until` is checked. ``estimates`` ((n, 2): x, y) are those of samples
        ``first_sample`` on; ``travelled`` counts from the first of them."""
        n = estimates.shape[0]
        k = first_sample + np.arange(n)
        if self.elapsed_samples is not None:
            hits = k - entry_sample >= self.elapsed_samples
        elif self.mission_time is not None:
            hits = k * dt >= self.mission_time - 0.5 * dt
        elif self.in_lap is not None:
            hits = np.full(n, self.in_lap)
        elif self.reaches is not None:
            hits = regions.region_value(self.reaches, estimates[:, 0], estimates[:, 1]) <= 0.0
        else:
            assert self.travelled is not None
            steps = np.hypot(np.diff(estimates[:, 0]), np.diff(estimates[:, 1]))
            covered = np.concatenate(([0.0], np.cumsum(steps)))
            hits = covered >= self.travelled
        found = np.flatnonzero(hits & (k >= since))
        return int(k[found[0]]) if found.size else -1


@dataclass(frozen=True)
class PhasePlan:
    """One phase of the run, repeats written out."""

    name: str
    kind: str  # the phase's action: "track" | "regulate" | "hold"
    until: Conditions
    timeout_samples: int | None
    fail_on_timeout: bool
    # track: builds the path from the estimated pose at phase entry.
    make_trajectory: Callable[[tuple[float, float, float]], Trajectory] | None = None
    # regulate: the target pose; hold: None (the pose at entry).
    target: tuple[float, float, float] | None = None
    constraint_rows: tuple[IntArray, FloatArray] = field(default_factory=no_rows)
    constraints: tuple[tuple[str, str], ...] = ()
    # 1, 2, ... for a phase of a repeat (its lap); None outside repeats.
    lap: int | None = None
    # track: the points its path is drawn through ((m, 2), for figures), or None.
    points: FloatArray | None = None
    color: str | None = None  # for the figures: from the mission's plot.phase_colors
    updates: tuple[UpdatePlan, ...] = ()  # in the order they are written
    pace: float | None = None  # track: its path's written speed (or |angular_rate|)
    # regulate: why its target is out of the controller's reach (the band it
    # keeps round a zone holds the axle farther from it than `settled` allows),
    # or None (docs/paper-notes.md, eq. (28), "A target within the band kept
    # round a zone")
    out_of_reach: str | None = None


@dataclass(frozen=True)
class MissionPlan:
    name: str
    plant: Plant  # period, limits, and where the run counts as diverged
    initial_state: FloatArray
    initial_estimate: FloatArray
    measured: FloatArray  # 1.0 for each measured state
    noise_std: FloatArray  # of each measured state's measurement [m, m, rad], 0 elsewhere
    seed: int
    estimator: EstimatorType
    estimator_tuning: Any  # the estimator's tuning record
    controller: ControllerType
    controller_tuning: Any  # the controller's tuning record
    phases: tuple[PhasePlan, ...]
    regions: dict[str, dict[str, object]]
    # Sample budget: the sum of each phase's bound, for pre-sizing the recorder.
    max_samples: int
    # The true plant's and the sensors' imperfections (wmr_mission.kernels.disturbances).
    disturbances: DisturbancePlan = field(default_factory=DisturbancePlan)
    # What the run does at a timeout or a breach; None: fail at a timeout with
    # on_timeout fail, else go on (wmr_mission.sim.reactions).
    reactions: ReactionPlan | None = None
    # What a path given while the mission runs may refer to (planned).
    context: paths.Context = field(default_factory=lambda: paths.Context(regions={}))
    # The robot's body as written (robot.footprint); None: a point.
    footprint: dict[str, Any] | None = None

    @property
    def dt(self) -> float:
        return self.plant.dt


def _bound(seconds: float, dt: float) -> int:
    """A phase's duration in samples: at least one."""
    return max(1, samples(seconds, dt))


def disturbance_plan(mission: Mission) -> DisturbancePlan:
    """The disturbances of a validated mission."""
    dt = float(mission.robot.dt)
    plant = mission.robot.disturbances
    sensors = mission.sensors

    def per_state(values: object) -> FloatArray:
        return np.array([getattr(values, name) for name in STATES], dtype=np.float64)

    dropout = sensors.dropout
    outliers = sensors.outliers
    return DisturbancePlan(
        process_noise_std=per_state(plant.process_noise_std),
        input_delay=samples(plant.input_delay, dt),
        time_constant=float(plant.actuator_time_constant),
        slip=float(plant.slip.longitudinal),
        skid_std=float(plant.slip.lateral_std),
        period=1 if sensors.period is None else max(1, samples(sensors.period, dt)),
        bias=per_state(sensors.bias),
        dropout_probability=0.0 if dropout is None else float(dropout.probability),
        dropout_burst=1.0 if dropout is None else float(dropout.burst),
        outlier_probability=0.0 if outliers is None else float(outliers.probability),
        outlier_std=np.zeros(3) if outliers is None else per_state(outliers.std),
        acceleration=_acceleration(mission.robot.limits),
    )


def _acceleration(limits: Limits) -> tuple[float, float]:
    """The robot's acceleration limits [m/s^2, rad/s^2], inf where none."""
    if limits.acceleration is None:
        return math.inf, math.inf
    return float(limits.acceleration.v), float(limits.acceleration.omega)


def _extent(mission: Mission, dumped_regions: dict[str, dict[str, object]]) -> float:
    """The largest coordinate magnitude the mission names [m]: start, estimate,
    regions (``dumped_regions``, less their rotation and heading), targets, points, and
    each path's first point from the start pose."""
    start = mission.robot.initial_state
    guess = mission.estimator.initial_estimate or start
    return max(
        extent_but_start(mission, dumped_regions),
        start_extent(
            mission, (float(start.x), float(start.y), float(start.theta)), (guess.x, guess.y)
        ),
    )


def extent_but_start(mission: Mission, dumped_regions: dict[str, dict[str, object]]) -> float:
    """The part of :func:`_extent` that neither the start pose nor the initial
    estimate moves: regions, targets and points."""
    numbers: list[float] = []
    for region in dumped_regions.values():
        numbers += _numbers(
            {key: value for key, value in region.items() if key not in ("rotation", "heading")}
        )
    for phase in _written_phases(mission):
        if isinstance(phase, RegulatePhase):
            numbers += _numbers(phase.regulate.model_dump(mode="json"))
        if phase.until is not None and phase.until.near is not None:
            numbers += list(phase.until.near.point)
    return _largest(numbers)


def start_extent(
    mission: Mission, start: tuple[float, float, float], guess: tuple[float, float]
) -> float:
    """The part of :func:`_extent` that the start pose and the initial estimate
    (x, y) set: themselves, and each path's first point from the start pose."""
    numbers = [start[0], start[1], guess[0], guess[1]]
    context = mission.path_context()
    for phase in _written_phases(mission):
        if isinstance(phase, TrackPhase):
            trajectory = paths.trajectory(phase.track.path, context, start)
            x, y, _, _ = trajectory.sample(np.zeros(1))
            numbers += [float(x[0]), float(y[0])]
    return _largest(numbers)


def _written_phases(mission: Mission) -> list[Phase]:
    """Each phase as written, once however many laps it runs."""
    return list({run.where: run.phase for run in run_order(mission)}.values())


def _largest(numbers: list[float]) -> float:
    finite = [abs(float(n)) for n in numbers if math.isfinite(float(n))]
    return max(finite, default=0.0)


def _numbers(value: object) -> list[float]:
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return []
    if isinstance(value, int | float):
        return [float(value)]
    if isinstance(value, dict):
        return [n for item in value.values() for n in _numbers(item)]
    if isinstance(value, list | tuple):
        return [n for item in value for n in _numbers(item)]
    return []


def _stack_rows(parts: list[tuple[IntArray, FloatArray]]) -> tuple[IntArray, FloatArray]:
    if not parts:
        return no_rows()
    kinds = np.concatenate([p[0] for p in parts]).astype(np.int64)
    # a polygon row is wider than 6 (its vertices): every row padded to the widest
    width = max(p[1].shape[1] for p in parts)
    padded = [np.pad(p[1], ((0, 0), (0, width - p[1].shape[1]))) for p in parts]
    params = np.ascontiguousarray(np.vstack(padded), dtype=np.float64)
    return kinds, params


def _body(mission: Mission) -> float:
    """[m] how far the robot's body reaches from the axle's centre: a round
    footprint's radius, a polygon's farthest corner (the disc that holds it;
    docs/paper-notes.md, "The robot's body"); 0 for a point robot."""
    footprint = mission.robot.footprint
    return 0.0 if footprint is None else footprint.reach()


def sample_budget(mission: Mission) -> int:
    """The samples a run may take: the proved worst case of its phase graph
    (wmr_mission.spec.graph.worst_case_samples), at most validate's limit."""
    return int(min(worst_case_samples(mission), MAX_SAMPLES))


def _conditions(until: Until, mission: Mission, dt: float) -> Conditions:
    reaches_rows = no_rows()
    if until.reaches is not None:
        reaches_rows = regions.constraint_rows(mission.regions[until.reaches], "inside")
    return Conditions(
        elapsed_samples=None if until.elapsed is None else _bound(until.elapsed, dt),
        mission_time=until.mission_time,
        reaches=until.reaches,
        reaches_rows=(
            np.ascontiguousarray(reaches_rows[0], dtype=np.int64),
            np.ascontiguousarray(reaches_rows[1], dtype=np.float64),
        ),
        near=None
        if until.near is None
        else (until.near.point[0], until.near.point[1], until.near.tolerance),
        settled=None
        if until.settled is None
        else (until.settled.position, until.settled.heading, until.settled.speed),
        heading=None if until.heading is None else (until.heading.target, until.heading.tolerance),
    )


def _phases(mission: Mission, plant: Plant) -> tuple[PhasePlan, ...]:
    written = [(run.phase, run.label, run.lap) for run in run_order(mission)]
    # then the phases of the contingencies a reaction names (none without reactions)
    written += [(phase, label, None) for label, phase in contingency_phases(mission)]
    return tuple(_phase(phase, label, lap, mission, plant) for phase, label, lap in written)


def _phase(phase: Phase, label: str, lap: int | None, mission: Mission, plant: Plant) -> PhasePlan:
    dt = plant.dt
    context = mission.path_context()
    constraints = []
    row_parts = []
    for constraint in phase.constraints:
        side: Literal["inside", "outside"]
        if isinstance(constraint, StayInside):
            name, side = constraint.stay_inside, "inside"
        else:
            name, side = constraint.stay_outside, "outside"
        constraints.append((name, side))
        row_parts.append(regions.constraint_rows(mission.regions[name], side))
    kind = "hold"
    make_trajectory = None
    target = None
    points = None
    pace = None
    if isinstance(phase, TrackPhase):
        kind = "track"
        path = phase.track.path
        points = paths.drawn_points(path, context)
        pace = path_pace(path)

        def make_trajectory(pose: tuple[float, float, float], _path: Any = path) -> Trajectory:
            return paths.trajectory(_path, context, pose)

    elif isinstance(phase, RegulatePhase):
        kind = "regulate"
        goal = phase.regulate.target
        target = (float(goal.x), float(goal.y), float(goal.theta))
    until = _conditions(phase.until, mission, dt)
    out_of_reach = None
    if target is not None and until.settled is not None:
        tolerance = until.settled[0]
        out_of_reach = _out_of_reach(target, tolerance, constraints, row_parts, plant)
    return PhasePlan(
        out_of_reach=out_of_reach,
        updates=tuple(_update(update, lap, mission, plant) for update in phase.updates),
        name=label,
        lap=lap,
        points=points,
        pace=pace,
        kind=kind,
        until=until,
        timeout_samples=None if phase.timeout is None else _bound(phase.timeout, dt),
        fail_on_timeout=phase.on_timeout in (None, "fail"),
        make_trajectory=make_trajectory,
        target=target,
        constraint_rows=_stack_rows(row_parts),
        constraints=tuple(constraints),
        color=mission.plot.phase_colors.get(phase.name),  # every lap of a repeat
    )


def _out_of_reach(
    target: tuple[float, float, float],
    tolerance: float,
    constraints: Sequence[tuple[str, str]],
    row_parts: Sequence[tuple[IntArray, FloatArray]],
    plant: Plant,
) -> str | None:
    """Why a regulate phase cannot settle at ``target`` within ``tolerance``
    [m]: the first of its zones whose band the controller keeps (eq. (28),
    each row shrunk by ``Plant.constraint_margin``: the estimate's margin and
    the disc round the body) holds the axle farther than ``tolerance`` from
    it; None where no zone does. The axle's nearest point kept is at least
    ``tolerance`` away where a row shrunk by ``margin - tolerance`` is broken
    at the target: exactly for a box, a polygon, a half-plane and a circle,
    to ``O(margin^2 / radius of curvature)`` for an ellipse."""
    margin = float(plant.constraint_margin)
    if margin <= tolerance:
        return None
    x, y = target[0], target[1]
    for (name, side), (kinds, params) in zip(constraints, row_parts, strict=True):
        worst = -math.inf
        metric = True  # a box's, a polygon's or a half-plane's value is a distance
        for kind, p in zip(kinds, params, strict=True):
            row = np.ascontiguousarray(p, dtype=np.float64)
            if kind == POLYGON_ROW:
                value = polygon_value(row, margin - tolerance, x, y)[0]
            else:
                value = row_value_with_margin(int(kind), row, margin - tolerance, x, y)[0]
                metric = metric and kind != ELLIPSE_ROW
            worst = max(worst, value)
        if not worst > 0.0:
            continue
        body = float(plant.body)
        room = margin - tolerance - worst  # [m] from the edge, where the rows are distances
        outside = side == "outside"
        zone = f"keep-out zone {name!r}" if outside else f"keep-in region {name!r}"
        if not metric:
            where = f"within the band kept {'round' if outside else 'inside'} {zone}"
        elif room < 0.0:  # beyond the edge itself (validate says so)
            where = f"{'inside' if outside else 'outside'} {zone}"
        elif outside:
            where = f"{room:.3g} m from keep-out zone {name!r}"
        else:
            where = f"{room:.3g} m inside the edge of keep-in region {name!r}"
        kept = f"the estimate's margin {margin - body:.3g} m"
        if body > 0.0:
            kept = f"the disc round the robot's body {body:.3g} m and {kept}"
        return (
            f"its target ({x:g}, {y:g}) is {where}, and the controller keeps the axle "
            f"{margin:.3g} m from the zone's edge ({kept}): it stops farther than the "
            f"settled tolerance {tolerance:g} m from the target"
        )
    return None


def _update(update: Update, lap: int | None, mission: Mission, plant: Plant) -> UpdatePlan:
    dt = plant.dt
    context = mission.path_context()
    when = update.when
    make_trajectory = None
    if update.path is not None:
        path = update.path

        def make_trajectory(pose: tuple[float, float, float]) -> Trajectory:
            return paths.trajectory(path, context, pose)

    target = update.target
    tuning = None
    if update.look_ahead is not None:
        settings = with_look_ahead(mission.controller, float(update.look_ahead))
        assert settings is not None  # validate checked the controller has one
        tuning = CONTROLLERS.of(settings).tuning_of(settings, plant)
    name, value = next((name, value) for name, value in when if value is not None)
    unit = {"travelled": " m", "lap": ""}.get(name, " s")
    return UpdatePlan(
        when=f"reaches '{value}'" if name == "reaches" else f"{name} {value:g}{unit}",
        in_lap=None if when.lap is None else lap is not None and lap >= when.lap,
        elapsed_samples=None if when.elapsed is None else _bound(when.elapsed, dt),
        mission_time=when.mission_time,
        reaches=None if when.reaches is None else mission.regions[when.reaches],
        travelled=when.travelled,
        make_trajectory=make_trajectory,
        target=None if target is None else (float(target.x), float(target.y), float(target.theta)),
        pace=None if update.path is None else path_pace(update.path),
        speed=update.speed,
        controller_tuning=tuning,
    )


def planned(path: Mapping[str, Any], context: paths.Context, when: str) -> UpdatePlan:
    """A path given while the mission runs (a session's ``set_path``, a
    planner's plan) as an update: checked as a mission's path is (ValueError
    says what is wrong), made from the estimated pose where it takes over."""
    try:
        update = Update.model_validate(
            {"when": {"elapsed": 1.0}, "path": dict(path)},
            context={"regions": list(context.regions)},
        )
    except pydantic.ValidationError as error:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors()
        )
        raise ValueError(f"not a valid path: {problems}") from None
    new = update.path
    assert new is not None

    def make_trajectory(pose: tuple[float, float, float]) -> Trajectory:
        return paths.trajectory(new, context, pose)

    return UpdatePlan(when=when, make_trajectory=make_trajectory, pace=path_pace(new))


def goal(
    pose: tuple[float, float, float],
    via: tuple[float, float],
    speed: float,
    context: paths.Context,
    when: str,
) -> UpdatePlan:
    """A planner's goal pose as an update: a regulate phase's new target, and
    for a track phase a straight route from the estimate where it takes over,
    through ``via`` (halfway from the robot's pose when the goal came), to the
    goal's position at ``speed``. ValueError says what is wrong."""
    route = {"type": "waypoints", "points": [list(via), list(pose[:2])], "speed": speed}
    update = planned(route, context, when)
    return replace(update, target=pose)


class Resting(NamedTuple):
    """A path that rests at one point: where a track phase holds."""

    x: float
    y: float

    def sample(self, t: Any) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        shape = np.shape(t)
        zeros = np.zeros(shape)
        return np.full(shape, self.x), np.full(shape, self.y), zeros, zeros.copy()


def hold_still(when: str) -> UpdatePlan:
    """An update that holds the estimated pose where it takes over: a track
    phase's path rests there, a regulate phase's target is that pose."""

    def make_trajectory(pose: tuple[float, float, float]) -> Trajectory:
        return Resting(pose[0], pose[1])

    return UpdatePlan(when=when, make_trajectory=make_trajectory, hold=True)


def plan_mission(mission: Mission, seed: int | None = None) -> MissionPlan:
    """Turn a validated mission into the runner's plain form."""
    dt = float(mission.robot.dt)
    told = mission.measurements()
    limits = mission.robot.limits
    dumped_regions = {name: r.model_dump(mode="json") for name, r in mission.regions.items()}
    estimator = ESTIMATORS.of(mission.estimator)
    estimator_tuning = estimator.tuning_of(mission.estimator, told)
    controller = CONTROLLERS.of(mission.controller)
    plant = Plant(
        dt=dt,
        limits=np.array(
            [
                limits.v,
                limits.omega,
                # the command's rate: the tighter of v_rate and the robot's acceleration
                min(math.inf if limits.v_rate is None else limits.v_rate, _acceleration(limits)[0]),
                min(
                    math.inf if limits.omega_rate is None else limits.omega_rate,
                    _acceleration(limits)[1],
                ),
            ]
        ),
        runaway_position=RUNAWAY_DISTANCE + _extent(mission, dumped_regions),
        runaway_input=RUNAWAY_INPUT,
        # the estimate's uncertainty, and the body: zones are kept by the footprint
        constraint_margin=float(estimator.constraint_margin(estimator_tuning)) + _body(mission),
        body=_body(mission),
    )
    phases = _phases(mission, plant)
    initial = mission.robot.initial_state
    written = mission.estimator.initial_estimate
    guess = initial if written is None else written
    return MissionPlan(
        name=mission.name,
        plant=plant,
        initial_state=np.array([initial.x, initial.y, initial.theta], dtype=np.float64),
        initial_estimate=np.array([guess.x, guess.y, guess.theta], dtype=np.float64),
        measured=told.mask,
        noise_std=told.noise_std,
        seed=mission.sensors.seed if seed is None else seed,
        estimator=estimator,
        estimator_tuning=estimator_tuning,
        controller=controller,
        controller_tuning=controller.tuning_of(mission.controller, plant),
        phases=phases,
        reactions=reaction_plan(mission, [p.name for p in phases[: run_count(mission)]]),
        regions=dumped_regions,
        max_samples=sample_budget(mission),
        disturbances=disturbance_plan(mission),
        context=mission.path_context(),
        footprint=None
        if mission.robot.footprint is None
        else mission.robot.footprint.model_dump(mode="json"),
    )
