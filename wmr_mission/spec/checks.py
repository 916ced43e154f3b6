"""Semantic checks of a mission, beyond what each field's type says.

Each check returns :class:`Finding` objects that name the data path of the
offending value; the loader turns the path into a line and column.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Final, Literal

import numpy as np

from wmr_mission.output.metrics import CONVERGENCE_TOLERANCE
from wmr_mission.spec.models import (
    BoxRegion,
    CircleRegion,
    CoveragePath,
    Ekf,
    EllipsePath,
    EllipseRegion,
    EllipticalSpiralPath,
    HoldPhase,
    Mission,
    Phase,
    PolygonRegion,
    RegulatePhase,
    RepeatPhase,
    StayInside,
    TrackPhase,
)
from wmr_mission.spec.repeats import MAX_RUN_PHASES, DataPath, run_count, run_order

__all__ = ["MAX_SAMPLES", "DataPath", "Finding", "Severity", "check"]

MAX_SAMPLES: Final = 50_000_000
"""Largest worst-case number of samples of a mission (sum of phase bounds / dt)."""

# Samples of a path when looking for a `reaches` crossing; finer than this only costs time.
_REACH_SAMPLES: Final = 20_001

Severity = Literal["error", "warning"]
Pose = tuple[float, float, float]


@dataclass(frozen=True)
class Finding:
    """A problem at a data path; ``position`` (line, column) overrides the path's."""

    path: DataPath
    message: str
    severity: Severity = "error"
    at_key: bool = False
    position: tuple[int, int] | None = None


def check(mission: Mission) -> list[Finding]:
    """Every semantic problem of a mission that passed its schema."""
    if run_count(mission) > MAX_RUN_PHASES:
        return [
            Finding(
                ("phases",),
                f"the mission runs {run_count(mission):,} phases with its repeats written out, "
                f"more than the limit of {MAX_RUN_PHASES:,}; repeat fewer times",
                at_key=True,
            )
        ]
    findings = [
        *_unique_phase_names(mission),
        *_observability(mission),
        *_estimator_keys(mission),
        *_regions(mission),
        *_phase_rules(mission),
        *_initial_state(mission),
        *_timing(mission),
        *_expectations(mission),
        *_disturbances(mission),
    ]
    if not any(f.severity == "error" for f in findings):
        # sampling paths needs a sound mission (regions of the right kind, bounded phases)
        findings.extend(_reaches(mission))
    # a phase of a repeat is checked once per lap: say each finding once
    return list(dict.fromkeys(findings))


def _unique_phase_names(mission: Mission) -> Iterator[Finding]:
    """Names of phases and repeats, inside repeats too, are unique."""
    named: list[tuple[DataPath, str]] = []
    for index, step in enumerate(mission.phases):
        named.append((("phases", index), step.name))
        if isinstance(step, RepeatPhase):
            for number, phase in enumerate(step.repeat.phases):
                named.append((("phases", index, "repeat", "phases", number), phase.name))
    seen: dict[str, DataPath] = {}
    for where, name in named:
        if name in seen:
            first = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in seen[name])
            yield Finding(
                (*where, "name"),
                f"phase name {name!r} is already used by {first.lstrip('.')}; "
                "phase names must be unique",
            )
        seen.setdefault(name, where)


def _moves(mission: Mission) -> bool:
    return any(isinstance(p.phase, TrackPhase | RegulatePhase) for p in run_order(mission))


def _observability(mission: Mission) -> Iterator[Finding]:
    """Structural observability of eq. (1) from the measured states.

    x and y never influence another state, so each is observable only when it
    is measured. theta steers the motion, so it shows in a measured x or y once
    the robot moves.
    """
    measured = set(mission.sensors.measure)
    reasons: dict[str, str] = {}
    for state in ("x", "y"):
        if state not in measured:
            reasons[state] = (
                f"{state} is not measured and no measured state depends on it "
                f"(in eq. (1) {state} only accumulates the motion; it never feeds back)"
            )
    if "theta" not in measured:
        if not measured & {"x", "y"}:
            reasons["theta"] = (
                "theta is not measured, and neither x nor y is, so the direction of motion "
                "that would reveal it is not seen"
            )
        elif not _moves(mission):
            reasons["theta"] = (
                "theta is not measured and the mission never moves the robot (only hold "
                "phases), so the direction of motion that would reveal it is never seen"
            )
    shown = "[" + ", ".join(mission.sensors.measure) + "]"
    for state, reason in reasons.items():
        yield Finding(
            ("sensors", "measure"),
            f"sensors.measure {shown} leaves {state} unobservable for the "
            f"{mission.estimator.type} estimator: {reason}; measure {state} as well",
        )


def _estimator_keys(mission: Mission) -> Iterator[Finding]:
    measured = mission.sensors.measure
    estimator = mission.estimator
    if isinstance(estimator, Ekf):
        field, keys = "measurement_std", list(estimator.measurement_std or {})
        why = "the filter has no such measurement"
    else:
        field, keys = "output_error_bounds", list(estimator.output_error_bounds or {})
        why = "eq. (4) bounds the output error of measured states only"
    for state in keys:
        if state not in measured:
            yield Finding(
                ("estimator", field, state),
                f"estimator.{field} has {state!r}, which is not measured "
                f"(sensors.measure is [{', '.join(measured)}]): {why}",
                at_key=True,
            )


def _regions(mission: Mission) -> Iterator[Finding]:
    from wmr_mission.regions import is_convex

    for name, region in mission.regions.items():
        if isinstance(region, PolygonRegion) and not is_convex(region.vertices):
            yield Finding(
                ("regions", name, "vertices"),
                f"polygon {name!r} is not convex (or has no area): the constraint rows of a "
                "polygon are its edges, which bound a convex region only; split it or use a box",
            )


# The regions a path's `region` may name, and how to say so.
_PATH_REGIONS: Final = {
    "ellipse": ((EllipseRegion, CircleRegion), "an ellipse or circle"),
    "elliptical-spiral": ((EllipseRegion, CircleRegion), "an ellipse or circle"),
    "coverage": ((BoxRegion, PolygonRegion), "a box or convex polygon"),
}
_PATHS_ON_REGIONS: Final = (EllipsePath, EllipticalSpiralPath, CoveragePath)


def _phase_rules(mission: Mission) -> Iterator[Finding]:
    for run in run_order(mission):
        if run.lap is not None and run.lap > 1:
            continue
        phase, where = run.phase, run.where
        if isinstance(phase, TrackPhase):
            if phase.until.settled is not None:
                yield Finding(
                    (*where, "until", "settled"),
                    "'settled' needs a target pose, so it applies to regulate and hold phases "
                    "only; a track phase can end on near, reaches, heading or time",
                    at_key=True,
                )
            path = phase.track.path
            name = path.region if isinstance(path, _PATHS_ON_REGIONS) else None
            region = mission.regions.get(name) if name is not None else None
            if region is not None:
                kinds, wanted = _PATH_REGIONS[path.type]
                if not isinstance(region, kinds):
                    article = "an" if path.type[0] in "aeiou" else "a"
                    yield Finding(
                        (*where, "track", "path", "region"),
                        f"{article} {path.type} path needs {wanted} region, but "
                        f"{name!r} is a {region.type}",
                    )
        yield from _target_against_constraints(mission, phase, where)
        for number, constraint in enumerate(phase.constraints):
            if isinstance(constraint, StayInside):
                continue
            region = mission.regions.get(constraint.stay_outside)
            if isinstance(region, BoxRegion | PolygonRegion):
                yield Finding(
                    (*where, "constraints", number, "stay_outside"),
                    f"stay_outside needs a region whose outside is convex (ellipse, circle or "
                    f"half-plane); the outside of {region.type} {constraint.stay_outside!r} is not",
                )


def _breaches(
    mission: Mission, phase: Phase, x: float, y: float
) -> Iterator[tuple[int, str, str, str]]:
    """(constraint number, region name, required side, actual side) of each
    constraint of ``phase`` that the point (x, y) breaks."""
    from wmr_mission.regions import region_value

    for number, constraint in enumerate(phase.constraints):
        inside = isinstance(constraint, StayInside)
        name = (
            constraint.stay_inside
            if isinstance(constraint, StayInside)
            else constraint.stay_outside
        )
        region = mission.regions.get(name)
        if region is None:
            continue
        value = float(region_value(region, np.array([x]), np.array([y]))[0])
        if (inside and value > 0) or (not inside and value < 0):
            side, other = ("inside", "outside") if inside else ("outside", "inside")
            yield number, name, side, other


def _target_against_constraints(
    mission: Mission, phase: Phase, where: DataPath
) -> Iterator[Finding]:
    """A phase that ends on settling at a target beyond its own constraint never
    settles. (Pushing a target beyond a fence for a fixed time is a fair use.)"""
    if not isinstance(phase, RegulatePhase) or phase.until.settled is None:
        return
    target = phase.regulate.target
    for number, name, side, other in _breaches(mission, phase, target.x, target.y):
        yield Finding(
            (*where, "constraints", number),
            f"the target ({target.x:g}, {target.y:g}) is {other} region {name!r}, but the "
            f"phase must stay {side} it: the robot stops at the boundary and until.settled "
            "can never fire",
            severity="warning",
        )


def _initial_state(mission: Mission) -> Iterator[Finding]:
    start = mission.robot.initial_state
    first = run_order(mission)[0]
    for number, name, side, other in _breaches(mission, first.phase, start.x, start.y):
        yield Finding(
            (*first.where, "constraints", number),
            f"robot.initial_state ({start.x:g}, {start.y:g}) is {other} region {name!r}, "
            f"but the first phase must stay {side} it",
        )


def _limits(phase: Phase, start_time: float) -> list[tuple[float, str]]:
    """Each time bound of a phase entered at ``start_time``: (seconds, what sets it)."""
    until = phase.until
    limits: list[tuple[float, str]] = []
    if until.elapsed is not None:
        limits.append((until.elapsed, "until.elapsed"))
    if until.mission_time is not None:
        limits.append((max(0.0, until.mission_time - start_time), "until.mission_time"))
    if phase.timeout is not None:
        limits.append((phase.timeout, f"its timeout (on_timeout: {phase.on_timeout})"))
    return limits


def _bounds(phase: Phase, start_time: float) -> float:
    """Longest the phase can last when entered at ``start_time`` [s] (inf: unbounded)."""
    return min((seconds for seconds, _ in _limits(phase, start_time)), default=math.inf)


def _limit(phase: Phase, start_time: float) -> str:
    """What ends the phase first by time, in words."""
    return min(_limits(phase, start_time), default=(math.inf, "nothing"))[1]


def _ends_on_time_only(phase: Phase) -> bool:
    """No condition on the robot's motion can end the phase early."""
    until = phase.until
    return all(c is None for c in (until.reaches, until.near, until.settled, until.heading))


def _multiple_of(duration: float, dt: float) -> bool:
    samples = duration / dt
    return abs(samples - round(samples)) <= 1e-6 * max(1.0, samples)


def _timing(mission: Mission) -> Iterator[Finding]:
    dt = mission.robot.dt
    mission_time = 0.0  # latest start of the phase
    earliest = 0.0  # earliest start of the phase
    for index, run in enumerate(run_order(mission)):
        phase, where = run.phase, run.where
        until = phase.until
        if until.mission_time is not None and until.mission_time <= earliest and index > 0:
            yield Finding(
                (*where, "until", "mission_time"),
                f"until.mission_time {until.mission_time:g} s is at or before the earliest time "
                f"phase {phase.name!r} can begin ({earliest:g} s): it would end at its first "
                "sample",
                severity="warning",
            )
        if _ends_on_time_only(phase):
            earliest += _bounds(phase, earliest)
        durations = {
            ("until", "elapsed"): phase.until.elapsed,
            ("until", "mission_time"): phase.until.mission_time,
            ("timeout",): phase.timeout,
        }
        for field, duration in durations.items():
            if duration is None:
                continue
            if field != ("until", "mission_time") and duration < dt:
                yield Finding(
                    (*where, *field),
                    f"{'.'.join(field)} {duration:g} s is shorter than one sample "
                    f"(robot.dt = {dt:g} s)",
                )
            elif not _multiple_of(duration, dt):
                yield Finding(
                    (*where, *field),
                    f"{'.'.join(field)} {duration:g} s is not a multiple of robot.dt = {dt:g} s; "
                    f"it takes effect at the next whole sample",
                    severity="warning",
                )
        bound = _bounds(phase, mission_time)
        if math.isinf(bound):
            yield Finding(
                where,
                f"phase {phase.name!r} can never be guaranteed to end: give it a timeout, or "
                "until.elapsed or until.mission_time",
            )
            return
        mission_time += bound
    samples = mission_time / dt
    if samples > MAX_SAMPLES:
        yield Finding(
            ("robot", "dt"),
            f"in the worst case the mission lasts {mission_time:g} s = {samples:.3g} samples at "
            f"dt = {dt:g} s, more than the limit of {MAX_SAMPLES:,}; shorten the timeouts or "
            "raise dt",
        )


def _reaches(mission: Mission) -> Iterator[Finding]:
    """Sample each track phase's path up to the phase's bound: it must be finite,
    and a `reaches` region should be crossed (warning).

    The robot is assumed to follow each phase perfectly: a track phase starts
    where the previous one ended (the initial state for the first phase, the
    previous path's end or the previous target otherwise). Kept this simple on
    purpose: the check only has to catch a path that plainly misses.
    """
    from wmr_mission import paths
    from wmr_mission.regions import region_value

    start = mission.robot.initial_state
    pose: Pose = (start.x, start.y, start.theta)
    dt = mission.robot.dt
    mission_time = 0.0
    for run in run_order(mission):
        phase, where = run.phase, run.where
        bound = _bounds(phase, mission_time)
        if math.isinf(bound):
            return
        mission_time += bound
        if isinstance(phase, RegulatePhase):
            target = phase.regulate.target
            pose = (target.x, target.y, target.theta)
            continue
        if isinstance(phase, HoldPhase):
            continue
        assumed = f"assuming the robot starts the phase at ({pose[0]:g}, {pose[1]:g})"
        try:
            trajectory = paths.instantiate(phase.track.path, mission, pose)
            times = np.linspace(0.0, bound, min(math.floor(bound / dt) + 1, _REACH_SAMPLES))
            with np.errstate(all="ignore"):  # a diverging path is judged by its finite part
                x, y, dx, dy = trajectory.sample(times)
        except (ValueError, ArithmeticError) as error:
            yield Finding(
                (*where, "track", "path"),
                f"the path cannot be sampled ({assumed}): {error}",
                severity="warning",
            )
            return
        finite = np.isfinite(x) & np.isfinite(y) & np.isfinite(dx) & np.isfinite(dy)
        if not finite.all():
            first = float(times[int(np.argmin(finite))])
            yield Finding(
                (*where, "track", "path"),
                f"the path (or its direction) is not finite at t = {first:g} s of the phase "
                f"({assumed}); the run would stop there as diverged",
                # A phase that may end on a condition of the robot's motion may end first.
                severity="error" if first == 0.0 or _ends_on_time_only(phase) else "warning",
            )
            return
        name = phase.until.reaches
        region = mission.regions.get(name) if name is not None else None
        if region is not None:
            entry = np.sign(region_value(region, np.array([pose[0]]), np.array([pose[1]])))[0]
            with np.errstate(all="ignore"):
                values = region_value(region, x, y)
            crossed = np.isfinite(values) & (np.sign(values) != entry)
            if not np.any(crossed):
                yield Finding(
                    (*where, "until", "reaches"),
                    f"the path never reaches region {name!r} within the phase's bound of "
                    f"{bound:g} s ({assumed}); the phase will end by "
                    f"{_limit(phase, mission_time - bound)}",
                    severity="warning",
                )
        if np.isfinite(x[-1]) and np.isfinite(y[-1]):
            heading = math.atan2(float(dy[-1]), float(dx[-1])) if dx[-1] or dy[-1] else pose[2]
            pose = (float(x[-1]), float(y[-1]), heading)


def _expectations(mission: Mission) -> Iterator[Finding]:
    # A track phase's last reference point has a position but no heading.
    has_target = any(isinstance(p.phase, RegulatePhase) for p in run_order(mission))
    if mission.expect.final_heading_error is not None and not has_target:
        yield Finding(
            ("expect", "final_heading_error"),
            "expect.final_heading_error is measured from the last regulate target, but the "
            "mission has no regulate phase",
            severity="warning",
            at_key=True,
        )


def _disturbances(mission: Mission) -> Iterator[Finding]:
    """Delays and periods in whole samples; a disturbance that makes a
    configured tolerance or expectation implausible (warning)."""
    dt = mission.robot.dt
    sensors = mission.sensors
    durations = {
        ("robot", "disturbances", "input_delay"): mission.robot.disturbances.input_delay,
        ("sensors", "period"): sensors.period,
    }
    for path, duration in durations.items():
        if duration is None or duration == 0.0:
            continue
        if duration < dt or not _multiple_of(duration, dt):
            yield Finding(
                path,
                f"{'.'.join(path)} {duration:g} s must be a whole multiple of robot.dt = "
                f"{dt:g} s (it counts samples)",
            )
    if sensors.dropout is not None and sensors.dropout.probability == 1.0:
        yield Finding(
            ("sensors", "dropout", "probability"),
            "every measurement is lost: the estimator only ever predicts",
            severity="warning",
        )
    measured = set(sensors.measure)
    bias = sensors.bias
    position_bias = math.hypot(
        bias.x if "x" in measured else 0.0, bias.y if "y" in measured else 0.0
    )
    heading_bias = abs(bias.theta) if "theta" in measured else 0.0
    if position_bias == 0.0 and heading_bias == 0.0:
        return
    # The estimate settles on the biased measurement: the true pose stays off by the bias.
    for run in run_order(mission):
        phase = run.phase
        settled = phase.until.settled
        if settled is None:
            continue
        for name, tolerance, offset, unit in (
            ("position", settled.position, position_bias, "m"),
            ("heading", settled.heading, heading_bias, "rad"),
        ):
            if offset > tolerance:
                yield Finding(
                    (*run.where, "until", "settled", name),
                    f"until.settled.{name} {tolerance:g} {unit} is smaller than the measurement "
                    f"bias ({offset:g} {unit}): the estimate settles on the biased measurement, "
                    f"so the true pose ends about {offset:g} {unit} away",
                    severity="warning",
                )
    expect = mission.expect
    largest = max(
        abs(b)
        for name, b in (("x", bias.x), ("y", bias.y), ("theta", bias.theta))
        if name in measured
    )
    if expect.estimation_convergence_time is not None and largest >= CONVERGENCE_TOLERANCE:
        yield Finding(
            ("expect", "estimation_convergence_time", "max"),
            f"the measurement bias ({largest:g}) is at least the {CONVERGENCE_TOLERANCE:g} band "
            "estimation_convergence_time waits for: the estimate follows the biased "
            "measurement and may never enter it",
            severity="warning",
        )
    for field, threshold, offset, unit in (
        ("final_position_error", expect.final_position_error, position_bias, "m"),
        ("final_heading_error", expect.final_heading_error, heading_bias, "rad"),
    ):
        if threshold is not None and offset > threshold.max:
            yield Finding(
                ("expect", field, "max"),
                f"expect.{field} {threshold.max:g} {unit} is below the measurement bias "
                f"({offset:g} {unit}): the robot ends where the biased measurement says",
                severity="warning",
            )
