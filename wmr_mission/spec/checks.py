"""Semantic checks of a mission, beyond what each field's type says.

Each check returns :class:`Finding` objects that name the data path of the
offending value; the loader turns the path into a line and column.
"""

from __future__ import annotations

import functools
import itertools
import math
import re
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, Final, Literal, NamedTuple, TypeGuard

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import BaseModel

from wmr_mission import fields
from wmr_mission.basics import FloatArray, whole_samples
from wmr_mission.controllers import paper
from wmr_mission.controllers.constrained_tracking import THROUGH_CENTRE
from wmr_mission.controllers.paper import PaperController
from wmr_mission.controllers.plugin import PythonController
from wmr_mission.estimators import ESTIMATORS
from wmr_mission.estimators.ekf import Ekf
from wmr_mission.estimators.observer import BOUND_NOISE_RATIO, ConstrainedObserver
from wmr_mission.estimators.plugin import PythonEstimator
from wmr_mission.geometry import paths
from wmr_mission.geometry.paths import PathSettings
from wmr_mission.geometry.paths.circle import CirclePath
from wmr_mission.geometry.paths.coverage import CoveragePath
from wmr_mission.geometry.paths.ellipse import EllipsePath
from wmr_mission.geometry.paths.elliptical_spiral import EllipticalSpiralPath
from wmr_mission.geometry.paths.line import LinePath, LineTrajectory
from wmr_mission.geometry.paths.spiral import SpiralPath
from wmr_mission.geometry.regions import (
    BoxRegion,
    CircleRegion,
    EllipseRegion,
    HalfPlaneRegion,
    PolygonRegion,
    RegionSpec,
    ellipse_geometry,
    is_convex,
    region_outline,
    region_value,
    region_vertices,
)
from wmr_mission.geometry.routes import MAX_LANES, TURN_CREEP, coverage_lanes
from wmr_mission.plugins import EntryError, load_entry
from wmr_mission.spec import catalog, graph
from wmr_mission.spec.changes import path_pace, with_look_ahead, with_pace
from wmr_mission.spec.models import (
    Disturbances,
    HeadingCondition,
    HoldPhase,
    Mission,
    Phase,
    RegulatePhase,
    RepeatPhase,
    RoundFootprint,
    StayInside,
    TrackPhase,
    Update,
)
from wmr_mission.spec.numbers import MissionNumbers, mission_numbers
from wmr_mission.spec.reactions import Goto, Retry
from wmr_mission.spec.repeats import MAX_RUN_PHASES, DataPath, run_count, run_order

__all__ = ["MAX_SAMPLES", "DataPath", "Finding", "Severity", "check", "check_across_fields"]

MAX_SAMPLES: Final = 50_000_000
"""Largest worst-case number of samples of a mission (sum of phase bounds / dt)."""

# Samples of a path when looking for a `reaches` crossing; finer than this only costs time.
_REACH_SAMPLES: Final = 20_001
# Below this path speed [m/s] the direction of the path is not defined (a stop or a cusp).
_STANDSTILL: Final = 1e-6
# A path's turn rate is its turn within this time [s], divided by it.
TURN_WINDOW: Final = 1.0

# [m/s, rad/s] a limit at or beyond the runner's runaway bound limits nothing.
NO_LIMIT: Final = 1e3
# [rad] turn per sample beyond which eq. (1), second order in omega dt, is no
# longer the robot's motion: its step is 3 % longer than the arc at 0.5 rad.
LARGEST_TURN_PER_SAMPLE: Final = 0.5
# Output-error bounds below this many noise standard deviations act on noise.
BOUND_NOISE_FLOOR: Final = 3.0

# A note says what the run will do where the mission leaves it to a rule; it
# never fails validation, not even under --strict.
Severity = Literal["error", "warning", "note"]
Pose = tuple[float, float, float]


class Finding(NamedTuple):
    """A problem at a data path; ``position`` (line, column) overrides the path's."""

    path: DataPath
    message: str
    severity: Severity = "error"
    at_key: bool = False
    position: tuple[int, int] | None = None


# Whether the checks import the `type: python` entries: only for a run and
# for `validate --check-entries` (importing runs the module's code).
_IMPORTING_ENTRIES: ContextVar[bool] = ContextVar("importing_entries", default=False)


@contextmanager
def importing_entries() -> Iterator[None]:
    """Within, the checks of a mission import its ``type: python`` entries and
    report one that does not load at its ``entry`` (wmr_mission.plugins)."""
    token = _IMPORTING_ENTRIES.set(True)
    try:
        yield
    finally:
        _IMPORTING_ENTRIES.reset(token)


def _entries(mission: Mission) -> Iterator[Finding]:
    """Each ``type: python`` entry imports and names a callable."""
    for section, settings in (("controller", mission.controller), ("estimator", mission.estimator)):
        if isinstance(settings, PythonController | PythonEstimator):
            try:
                load_entry(settings.entry)
            except EntryError as error:
                yield Finding((section, "entry"), str(error))


_ASSUMING: Final = "assuming the robot starts the phase at"
_ASSUMED: Final = re.compile(rf"{_ASSUMING} \([^()]*\)")


def check(mission: Mission) -> list[Finding]:
    """Every semantic problem of a mission that passed its schema."""
    findings = check_across_fields(mission)
    if _IMPORTING_ENTRIES.get():
        findings.extend(_entries(mission))
    if run_count(mission) <= MAX_RUN_PHASES:
        findings.extend(_feasible_sets(mission))
        findings.extend(_angles(mission))
        findings.extend(_unwritten_headings(mission))
        findings.extend(_missing_limits(mission))
        if not any(f.severity == "error" for f in findings):
            # sampling paths needs a sound mission (regions of the right kind, bounded phases)
            findings.extend(_zones(mission))
            findings.extend(_body_room(mission))
            findings.extend(_reaches(mission))
            findings.extend(_catching_up_or_lagging(mission))
    # a phase of a repeat is checked once per lap: say each finding once, the
    # same finding of a later lap differing only in the pose it starts at
    once: dict[tuple[DataPath, str, str], Finding] = {}
    for finding in findings:
        said = _ASSUMED.sub("", finding.message)
        once.setdefault((finding.path, finding.severity, said), finding)
    return list(once.values())


def check_across_fields(mission: Mission) -> list[Finding]:
    """The checks of :func:`check` that sample neither paths nor regions: tens of
    microseconds where those take milliseconds (a campaign runs these per run)."""
    if run_count(mission) > MAX_RUN_PHASES:
        return [
            Finding(
                ("phases",),
                f"the mission runs {run_count(mission):,} phases with its repeats written out, "
                f"more than the limit of {MAX_RUN_PHASES:,}; repeat fewer times",
                at_key=True,
            )
        ]
    return [
        *_unique_phase_names(mission),
        *_observability(mission),
        *_estimator_keys(mission),
        *_unmeasured_errors(mission),
        *_regions(mission),
        *_phase_rules(mission),
        *_initial_state(mission),
        *_timing(mission),
        *_expectations(mission),
        *_formulas(mission),
        *_control(mission),
        *_estimator_bounds(mission),
        *_phase_colors(mission),
        *_disturbances(mission),
        *(
            Finding(e.path, e.message, at_key=e.at_key, severity=e.severity)
            for e in graph.prove(mission)
        ),
    ]


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
            yield Finding(
                (*where, "name"),
                f"phase name {name!r} is already used by {_dotted(seen[name])}; "
                "phase names must be unique",
            )
        seen.setdefault(name, where)


def _dotted(path: DataPath) -> str:
    """A data path as the user writes it: ``phases[0].until.near``."""
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")


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
    elif isinstance(estimator, ConstrainedObserver):
        field, keys = "output_error_bounds", list(estimator.output_error_bounds or {})
        why = "eq. (4) bounds the output error of measured states only"
    else:
        return
    for state in keys:
        if state not in measured:
            yield Finding(
                ("estimator", field, state),
                f"estimator.{field} has {state!r}, which is not measured "
                f"(sensors.measure is [{', '.join(measured)}]): {why}",
                at_key=True,
            )


def _unmeasured_errors(mission: Mission) -> Iterator[Finding]:
    """A noise or bias stated for a state the sensors do not measure changes
    nothing: the mission meant to measure it, or states it by mistake."""
    sensors = mission.sensors
    stated = [("noise_std", sensors.noise_std), ("bias", sensors.bias)]
    for field, values in stated:
        for state in ("x", "y", "theta"):
            value = getattr(values, state)
            if state not in sensors.measure and value != 0.0:
                yield Finding(
                    ("sensors", field, state),
                    f"sensors.{field}.{state} is {value:g}, but {state} is not measured "
                    f"(sensors.measure is [{', '.join(sensors.measure)}]): it changes nothing; "
                    f"measure {state}, or remove it",
                    severity="warning",
                    at_key=True,
                )


def _refused_polygon(region: Any) -> TypeGuard[PolygonRegion]:
    """Whether ``region`` is a polygon :func:`_regions` refuses (not convex): its
    edges bound no region, so no other check asks what is inside it."""
    return isinstance(region, PolygonRegion) and not is_convex(region.vertices)


def _regions(mission: Mission) -> Iterator[Finding]:

    for name, region in mission.regions.items():
        if _refused_polygon(region):
            import shapely

            crossing = not shapely.LinearRing(region.vertices).is_simple
            what = "crosses itself, so it is not convex" if crossing else "is not convex"
            yield Finding(
                ("regions", name, "vertices"),
                f"polygon {name!r} {what} (or has no area): the constraint rows of a "
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
            yield from _path_on_region(mission, phase.track.path, (*where, "track", "path"))
        yield from _target_against_constraints(mission, phase, where)
        if phase.on_timeout is not None and phase.timeout is None:
            yield Finding(
                (*where, "on_timeout"),
                "the phase has no timeout, so its on_timeout never fires; give it a timeout, "
                "or remove on_timeout",
                severity="warning",
                at_key=True,
            )
        step = mission.phases[int(where[1])]
        laps = step.repeat.times if isinstance(step, RepeatPhase) else None
        yield from _update_rules(mission, phase, where, laps)


def _path_on_region(mission: Mission, path: PathSettings, at: DataPath) -> Iterator[Finding]:
    """A path laid on a region (at ``at``) names a region of its kind, and a
    coverage path lays at most MAX_LANES lanes (a field in kilometres at a
    spacing in micrometres would be built for hours, never run)."""
    name = path.region if isinstance(path, _PATHS_ON_REGIONS) else None
    region = mission.regions.get(name) if name is not None else None
    if region is None:
        return
    kinds, wanted = _PATH_REGIONS[path.type]
    if not isinstance(region, kinds):
        article = "an" if path.type[0] in "aeiou" else "a"
        yield Finding(
            (*at, "region"),
            f"{article} {path.type} path needs {wanted} region, but {name!r} is a {region.type}",
        )
        return
    if not isinstance(path, CoveragePath):
        return
    lanes = coverage_lanes(region_vertices(region), path.spacing, path.direction)
    if lanes > MAX_LANES:
        yield Finding(
            (*at, "spacing"),
            f"a coverage of region {path.region!r} at a spacing of {path.spacing:g} m lays "
            f"{lanes:,} lanes, more than {MAX_LANES:,}: widen the spacing, or cover a smaller "
            "region",
        )


def _update_rules(
    mission: Mission, phase: Phase, where: DataPath, laps: int | None
) -> Iterator[Finding]:
    """Each update names one condition and one new reference its phase can take:
    a path on a track phase, a target on a regulate phase. ``laps``: the times
    of the repeat the phase is in, None outside repeats."""
    for number, update in enumerate(phase.updates):
        at: DataPath = (*where, "updates", number)
        given = [name for name, value in update.when if value is not None]
        if len(given) != 1:
            yield Finding(
                (*at, "when"),
                "an update takes over on exactly one condition (elapsed, mission_time, "
                f"reaches, travelled or lap), but {len(given)} are given"
                + (f" ({', '.join(given)})" if given else ""),
                at_key=True,
            )
        ends = [b for b in (phase.timeout, phase.until.elapsed) if b is not None]
        if update.when.elapsed is not None and ends and update.when.elapsed >= min(ends):
            yield Finding(
                (*at, "when", "elapsed"),
                f"the update never takes over: the phase ends by {min(ends):g} s of its own "
                f"time, before {update.when.elapsed:g} s",
                severity="warning",
            )
        clock = update.when.mission_time
        if clock is not None:
            # the mission's longest run ends the phase by then at the latest
            latest = graph.worst_case_samples(mission) * mission.robot.dt
            if phase.until.mission_time is not None:
                latest = min(latest, phase.until.mission_time)
            if clock >= latest:
                yield Finding(
                    (*at, "when", "mission_time"),
                    f"the update never takes over: the phase ends by {latest:g} s of mission "
                    f"time at the latest, before {clock:g} s",
                    severity="warning",
                )
        lap = update.when.lap
        if lap is not None and laps is None:
            yield Finding(
                (*at, "when", "lap"),
                "'lap' counts the laps of a repeat, but this phase is not in a repeat; "
                "use elapsed, mission_time, reaches or travelled",
            )
        elif lap is not None and laps is not None and lap > laps:
            yield Finding(
                (*at, "when", "lap"),
                f"the repeat runs {laps} lap{'s' if laps > 1 else ''}, so lap {lap} never "
                f"comes; expected 1..{laps}",
            )
        wanted = "path" if isinstance(phase, TrackPhase) else "target"
        if isinstance(phase, HoldPhase):
            yield Finding(
                at,
                "a hold phase holds the pose it was entered at: it has no reference to "
                "update; make it a regulate phase with a target",
                at_key=True,
            )
            continue
        unwanted = "target" if wanted == "path" else "path"
        changes_path = update.speed is not None or update.look_ahead is not None
        if getattr(update, unwanted) is not None:
            yield Finding(
                (*at, unwanted),
                f"a {'track' if wanted == 'path' else 'regulate'} phase's update gives a new "
                f"{wanted}, not a {unwanted}",
                at_key=True,
            )
        elif wanted == "target" and changes_path:
            change = "speed" if update.speed is not None else "look_ahead"
            yield Finding(
                (*at, change),
                f"'{change}' changes how a track phase follows its path; a regulate phase's "
                "update gives a new target",
                at_key=True,
            )
        elif getattr(update, wanted) is None and not changes_path:
            more = " (or speed, look_ahead)" if wanted == "path" else ""
            yield Finding(at, f"the update gives no new {wanted}{more}", at_key=True)
        if isinstance(phase, TrackPhase):
            yield from _speed_and_look_ahead(mission, phase, number, update, at)
        if update.path is not None:
            yield from _path_on_region(mission, update.path, (*at, "path"))


def _speed_and_look_ahead(
    mission: Mission, phase: TrackPhase, number: int, update: Update, at: DataPath
) -> Iterator[Finding]:
    """A speed update needs a path in force that has a pace (the phase's own,
    or the last new path before it); a look-ahead update a controller with one."""
    if update.speed is not None and update.path is not None:
        yield Finding(
            (*at, "speed"),
            "an update with a new path takes that path's own speed; 'speed' changes the "
            "path in force: give one or the other",
            at_key=True,
        )
    elif update.speed is not None:
        earlier = [u.path for u in phase.updates[:number] if u.path is not None]
        path = earlier[-1] if earlier else phase.track.path
        if path_pace(path) is None:
            yield Finding(
                (*at, "speed"),
                f"the {path.type} path in force has no speed or angular_rate to change; "
                "give a new path instead",
                at_key=True,
            )
    if update.look_ahead is not None and with_look_ahead(mission.controller, 1.0) is None:
        yield Finding(
            (*at, "look_ahead"),
            f"the {mission.controller.type} controller"
            + (" (tracking.output: axle)" if mission.controller.type == "paper" else "")
            + " tracks no look-ahead point; drop look_ahead or use a controller with one",
            at_key=True,
        )


def _breaches(
    mission: Mission, phase: Phase, x: float, y: float
) -> Iterator[tuple[int, str, str, str]]:
    """(constraint number, region name, required side, actual side) of each
    constraint of ``phase`` that the point (x, y) breaks."""

    for number, constraint in enumerate(phase.constraints):
        inside = isinstance(constraint, StayInside)
        name = (
            constraint.stay_inside
            if isinstance(constraint, StayInside)
            else constraint.stay_outside
        )
        region = mission.regions.get(name)
        if region is None or _refused_polygon(region):
            continue
        value = float(region_value(region, np.array([x]), np.array([y]))[0])
        if (inside and value > 0) or (not inside and value < 0):
            side, other = ("inside", "outside") if inside else ("outside", "inside")
            yield number, name, side, other


def _target_against_constraints(
    mission: Mission, phase: Phase, where: DataPath
) -> Iterator[Finding]:
    """A phase that ends on settling at a target beyond its own constraint never
    settles. (Pushing a target beyond a fence for a fixed time is a fair use.)
    settled reads the target in force: one an update gives that the robot
    can reach lets it settle."""
    if not isinstance(phase, RegulatePhase) or phase.until.settled is None:
        return
    target = phase.regulate.target
    later = [u.target for u in phase.updates if u.target is not None]
    if any(not any(_breaches(mission, phase, t.x, t.y)) for t in later):
        return
    for number, name, side, other in _breaches(mission, phase, target.x, target.y):
        yield Finding(
            (*where, "constraints", number),
            f"the target ({target.x:g}, {target.y:g}) is {other} region {name!r}, but the "
            f"phase must stay {side} it: the robot stops at the boundary and until.settled "
            "can never fire",
            severity="warning",
        )


# Points tried per phase: a grid over the constrained area, and each region's
# boundary (a feasible set that is not empty has a boundary point on one of
# them, or a grid point inside it).
_GRID = 201
_BOUNDARY = 2048


# What the checks that sample paths and regions (_feasible_sets, _reaches) read:
# keep in step with them. The initial heading only through a line path
# without a heading (read_by_sampling_checks).
_SAMPLED_FIELDS: Final = (
    "regions",
    "phases",
    "parameters",
    "robot.dt",
    "robot.limits",
    "robot.initial_state.x",
    "robot.initial_state.y",
)


def read_by_sampling_checks(path: str, mission: Mission) -> bool:
    """Whether the field at dotted ``path`` is one the sampling checks read
    (a campaign leaves them out of runs that vary none of those)."""
    if path == "robot.initial_state.theta":
        return _first_path_heads_along_the_robot(mission)
    return _in_sampled_fields(path)


@functools.lru_cache(maxsize=256)  # a campaign asks once per run of each path it varies
def _in_sampled_fields(path: str) -> bool:
    return any(
        path == field or path.startswith(f"{field}.") or field.startswith(f"{path}.")
        for field in _SAMPLED_FIELDS
    )


def _first_path_heads_along_the_robot(mission: Mission) -> bool:
    """A line path without a heading of its own, tracked before any phase sets
    the pose: the only sampled path that starts from the initial heading."""
    for run in run_order(mission):
        if isinstance(run.phase, RegulatePhase):
            return False
        if isinstance(run.phase, TrackPhase):
            path = run.phase.track.path
            return isinstance(path, LinePath) and path.heading is None
    return False


def _feasible_sets(mission: Mission) -> Iterator[Finding]:
    """A phase whose constraints no point meets: its inside-sets do not
    overlap, or an outside-set covers their overlap. Sampled on a grid and on
    every region's boundary, so a set narrower than both is not seen."""
    written = {run.where: run.phase for run in run_order(mission)}  # each phase once
    for where, phase in written.items():
        sides = []
        for constraint in phase.constraints:
            inside = isinstance(constraint, StayInside)
            name = (
                constraint.stay_inside
                if isinstance(constraint, StayInside)
                else (constraint.stay_outside)
            )
            region = mission.regions.get(name)
            if region is None or _refused_polygon(region):
                return  # reported elsewhere
            sides.append((name, region, inside))
        if not sides:
            continue
        x, y = _candidates(mission, [region for _, region, _ in sides])
        meets = np.ones(x.shape, dtype=bool)
        for _, region, inside in sides:
            meets &= _meets(region, inside, x, y)
        if meets.any():
            continue
        insides = [name for name, _, inside in sides if inside]
        inner = np.ones(x.shape, dtype=bool)
        for _, region, inside in sides:
            if inside:
                inner &= _meets(region, True, x, y)
        if insides and not inner.any():
            cause = f"the regions it must stay inside ({', '.join(insides)}) do not overlap"
        else:
            outsides = [name for name, _, inside in sides if not inside]
            area = f"inside {', '.join(insides)}" if insides else "of the plane"
            cause = (
                f"the regions it must stay outside ({', '.join(outsides)}) cover every point {area}"
            )
        yield Finding(
            (*where, "constraints"),
            f"phase {phase.name!r} has no point that meets all its constraints: {cause}",
        )


def _meets(region: RegionSpec, inside: bool, x: FloatArray, y: FloatArray) -> NDArray[np.bool_]:

    value = region_value(region, x, y)
    return np.asarray(value <= 1e-9 if inside else value >= -1e-9)


def _candidates(mission: Mission, regions: list[RegionSpec]) -> tuple[FloatArray, FloatArray]:

    start = mission.robot.initial_state
    xs: list[float] = [start.x]
    ys: list[float] = [start.y]
    for run in run_order(mission):
        phase = run.phase
        if isinstance(phase, RegulatePhase):
            xs.append(phase.regulate.target.x)
            ys.append(phase.regulate.target.y)
    boundary_x: list[FloatArray] = []
    boundary_y: list[FloatArray] = []
    lines = []
    for region in regions:
        if isinstance(region, EllipseRegion | CircleRegion | BoxRegion | PolygonRegion):
            x, y = _boundary(region)
            boundary_x.append(x)
            boundary_y.append(y)
        else:  # half-plane: its line, sampled below over the area
            lines.append(region)
        if boundary_x:
            xs += [float(boundary_x[-1].min()), float(boundary_x[-1].max())]
            ys += [float(boundary_y[-1].min()), float(boundary_y[-1].max())]
    low_x, high_x, low_y, high_y = min(xs), max(xs), min(ys), max(ys)
    margin = 0.1 * max(high_x - low_x, high_y - low_y) + 1.0
    low_x, high_x, low_y, high_y = low_x - margin, high_x + margin, low_y - margin, high_y + margin
    grid_x, grid_y = np.meshgrid(
        np.linspace(low_x, high_x, _GRID), np.linspace(low_y, high_y, _GRID)
    )
    reach = 2.0 * max(
        high_x - low_x, high_y - low_y, abs(low_x), abs(high_x), abs(low_y), abs(high_y)
    )
    for region in lines:
        nx, ny = region.normal
        norm = math.hypot(nx, ny)
        along = np.linspace(-reach, reach, 4 * _BOUNDARY)
        foot_x, foot_y = nx * region.offset / norm**2, ny * region.offset / norm**2
        boundary_x.append(foot_x - ny / norm * along)
        boundary_y.append(foot_y + nx / norm * along)
    x = np.concatenate([grid_x.ravel(), np.array(xs), *boundary_x])
    y = np.concatenate([grid_y.ravel(), np.array(ys), *boundary_y])
    return x, y


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
        limits.append((phase.timeout, "its timeout"))
    return limits


def _reaction_text(reaction: Any) -> str:
    """A reaction as the mission writes it: ``fail``, ``goto park``, ``retry 2, then fail``."""
    if isinstance(reaction, Goto):
        return f"goto {reaction.goto}"
    if isinstance(reaction, Retry):
        return f"retry {reaction.retry.times}, then {_reaction_text(reaction.retry.then)}"
    return str(reaction)


def _on_timeout(mission: Mission, phase: Phase) -> str:
    """The reaction to the phase's timeout that the run takes: its own, else
    its on_failure, else the mission's, else fail (wmr_mission.sim.reactions)."""
    written = (phase.on_timeout, phase.on_failure, mission.on_timeout, mission.on_failure)
    return _reaction_text(next((r for r in written if r is not None), "fail"))


def _bounds(phase: Phase, start_time: float) -> float:
    """Longest the phase can last when entered at ``start_time`` [s] (inf: unbounded)."""
    return min((seconds for seconds, _ in _limits(phase, start_time)), default=math.inf)


def _limit(mission: Mission, phase: Phase, start_time: float) -> str:
    """What ends the phase first by time, in words."""
    what = min(_limits(phase, start_time), default=(math.inf, "nothing"))[1]
    if what == "its timeout":
        what += f" (on_timeout: {_on_timeout(mission, phase)})"
    return what


def _ends_on_time_only(phase: Phase) -> bool:
    """No condition on the robot's motion can end the phase early."""
    until = phase.until
    return all(c is None for c in (until.reaches, until.near, until.settled, until.heading))


def _timing(mission: Mission) -> Iterator[Finding]:
    dt = mission.robot.dt
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
            elif not whole_samples(duration, dt):
                yield Finding(
                    (*where, *field),
                    f"{'.'.join(field)} {duration:g} s is not a multiple of robot.dt = {dt:g} s; "
                    f"it takes effect at the next whole sample",
                    severity="warning",
                )
        if math.isinf(_bounds(phase, 0.0)):
            yield Finding(
                where,
                f"phase {phase.name!r} can never be guaranteed to end: give it a timeout, or "
                "until.elapsed or until.mission_time",
            )
            return
    # The one sum of a run's worst case, its reactions' repetitions counted.
    samples = graph.worst_case_samples(mission)
    if math.isfinite(samples) and samples > MAX_SAMPLES:  # inf: the graph's proof says why
        yield Finding(
            ("robot", "dt"),
            f"in the worst case the mission lasts {samples * dt:g} s = {samples:,.0f} samples at "
            f"dt = {dt:g} s, more than the limit of {MAX_SAMPLES:,} (every phase to its time "
            "bound, every retry and contingency as often as its count allows); shorten the "
            "timeouts, lower the counts or raise dt",
        )


def _reaches(mission: Mission) -> Iterator[Finding]:
    """Sample each track phase's path up to the phase's bound: it must be finite,
    and a `reaches` region should be crossed (warning).

    The robot is assumed to follow each phase perfectly: a track phase starts
    where the previous one ended (the initial state for the first phase, the
    previous path's point where it first reaches its `reaches` region or else
    its end, or the previous target). Kept this simple on
    purpose: the check only has to catch a path that plainly misses.
    """

    start = mission.robot.initial_state
    pose: Pose = (start.x, start.y, start.theta)
    mission_time = 0.0
    for run in run_order(mission):
        phase, where = run.phase, run.where
        bound = _bounds(phase, mission_time)
        if math.isinf(bound):
            return
        mission_time += bound
        assumed = f"{_ASSUMING} ({pose[0]:g}, {pose[1]:g})"
        if run.lap is None or run.lap == 1:
            yield from _in_time(mission, phase, where, pose, bound, mission_time - bound, assumed)
            yield from _reaches_kept(mission, phase, where, pose, assumed)
        if isinstance(phase, RegulatePhase):
            if run.lap is None or run.lap == 1:
                yield from _across_zones(mission, phase, where, pose, assumed)
            target = phase.regulate.target
            pose = (target.x, target.y, target.theta)
            continue
        if isinstance(phase, HoldPhase):
            continue
        if run.lap is None or run.lap == 1:
            yield from _update_paths(mission, phase, where, pose, bound, assumed)
        try:
            times, (x, y, dx, dy) = _sampled(mission, phase.track.path, pose, bound)
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
        followed = times.size  # samples up to the predicted end of the phase
        # A path replaced or re-timed by an update may meet the goal its own path misses.
        replaced = any(u.path is not None or u.speed is not None for u in phase.updates)
        if region is not None:
            entry = np.sign(region_value(region, np.array([pose[0]]), np.array([pose[1]])))[0]
            with np.errstate(all="ignore"):
                values = region_value(region, x, y)
            crossed = np.isfinite(values) & (np.sign(values) != entry)
            if np.any(crossed):
                followed = int(np.argmax(crossed)) + 1
            elif not replaced:
                yield Finding(
                    (*where, "until", "reaches"),
                    f"the path never reaches region {name!r} within the phase's bound of "
                    f"{bound:g} s ({assumed}); the phase will end by "
                    f"{_limit(mission, phase, mission_time - bound)}",
                    severity="warning",
                )
        near = phase.until.near
        close = (
            np.hypot(x - near.point[0], y - near.point[1]) <= near.tolerance
            if near is not None
            else np.zeros(0, dtype=bool)
        )
        if np.any(close):
            followed = min(followed, int(np.argmax(close)) + 1)
        elif near is not None and not replaced:
            yield Finding(
                (*where, "until", "near"),
                f"the path never comes within {near.tolerance:g} m of ({near.point[0]:g}, "
                f"{near.point[1]:g}) within the phase's bound of {bound:g} s ({assumed}); the "
                f"phase will end by {_limit(mission, phase, mission_time - bound)}",
                severity="warning",
            )
        yield from _path_within_limits(mission, where, phase, times[:followed], dx, dy, assumed)
        yield from _through_centres(mission, phase, where, x[:followed], y[:followed])
        yield from _between_zones(mission, phase, where, x[:followed], y[:followed])
        yield from _inside_keep_outs(mission, phase, where, x[:followed], y[:followed])
        last = followed - 1  # the next phase starts where this one is predicted to end
        if np.isfinite(x[last]) and np.isfinite(y[last]):
            heading = (
                math.atan2(float(dy[last]), float(dx[last])) if dx[last] or dy[last] else pose[2]
            )
            pose = (float(x[last]), float(y[last]), heading)
            if replaced and near is not None and not np.any(close):
                pose = (near.point[0], near.point[1], heading)  # where an update's path met it


def _reaches_kept(
    mission: Mission, phase: Phase, where: DataPath, pose: Pose, assumed: str
) -> Iterator[Finding]:
    """`until.reaches` of a region the phase itself keeps out of (or inside),
    entered on the side it keeps to: the condition fires where the estimate
    crosses the region's edge, and the zone filter holds the estimate off that
    edge, so it never fires. Entered on the other side, leaving crosses it.
    The geofence's zones are not counted: they are watched, not kept."""
    name = phase.until.reaches
    region = mission.regions.get(name) if name is not None else None
    if region is None:
        return
    outs = {c.stay_outside for c in phase.constraints if not isinstance(c, StayInside)}
    ins = {c.stay_inside for c in phase.constraints if isinstance(c, StayInside)}
    if name not in outs | ins:
        return
    value = float(region_value(region, np.array([pose[0]]), np.array([pose[1]]))[0])
    if (value > 0.0) != (name in outs) or distance_to(region, pose[0], pose[1]) == 0.0:
        return  # it starts on the side it leaves, or on the edge
    kept, side = ("out of", "outside") if name in outs else ("inside", "inside")
    yield Finding(
        (*where, "until", "reaches"),
        f"phase {phase.name!r} keeps the robot {kept} region {name!r} and starts {side} it "
        f"({assumed}): the estimate is held off its edge, so until.reaches, which fires where "
        "the estimate crosses that edge, can never fire; end the phase on `near` a point by "
        "the region, or drop the constraint",
        severity="warning",
    )


def _sample_times(mission: Mission, bound: float) -> FloatArray:
    """The times a phase's path is sampled at up to its bound [s]: every
    sample, at most _REACH_SAMPLES."""
    dt = mission.robot.dt
    times: FloatArray = np.linspace(0.0, bound, min(math.floor(bound / dt) + 1, _REACH_SAMPLES))
    return times


def _sampled(
    mission: Mission, path: PathSettings, pose: Pose, bound: float
) -> tuple[FloatArray, tuple[FloatArray, FloatArray, FloatArray, FloatArray]]:
    """The times of :func:`_sample_times` and ``path``'s points and directions at
    them, made from ``pose``; raises ValueError or ArithmeticError where it
    cannot be sampled. A diverging path is judged by its finite part."""
    trajectory = paths.trajectory(path, mission.path_context(), pose)
    times = _sample_times(mission, bound)
    with np.errstate(all="ignore"):
        return times, trajectory.sample(times)


def _catching_up_or_lagging(mission: Mission) -> list[Finding]:
    """The findings of :func:`_catching_up` and :func:`_lag_at_top_speed`, one a
    phase: a phase that ends before the robot can catch its path is said to
    (lengthening it helps), unless it lasts past its entry, so that its path is
    too fast to be caught by then at all."""
    caught = list(_catching_up(mission))
    warned = {finding.path[:-1] for finding in caught}
    lagging = list(_lag_at_top_speed(mission, warned))
    lagged = {finding.path[:-3] for finding in lagging}
    return [f for f in caught if f.path[:-1] not in lagged] + lagging


def _catching_up(mission: Mission) -> Iterator[Finding]:
    """A warning where the mission's first phase, a track phase that ends on
    time, ends before the robot can come near its reference point: a phase
    that ends within its entry is judged at its end (docs/mission-format.md,
    "Verdicts"), and there the robot, from rest at its initial state within
    its speed and acceleration limits, is still farther from that point than
    its cross-track and along-track bounds together allow. The distance to the
    reference point is at most the cross-track error and the lag (their chord
    at most the arc): such a run fails one of them, whatever the law.

    Only where the path is known before the run: the first phase, its start
    the initial state at rest and its estimate (the path of a `start: current`
    is made from the estimate), no updates (a path slowed or replaced may be
    caught), no zones (a detour is excused), no disturbances (slip and process
    noise move the robot beyond what its inputs do). The robot's reach counts
    the sampled plant's (its first input a whole sample's acceleration) and
    four noise std of the first estimate's position, where the path starts."""
    order = run_order(mission)
    if not order or not isinstance(order[0].phase, TrackPhase):
        return
    phase, where = order[0].phase, order[0].where
    initial, estimated = mission.robot.initial_state, mission.estimator.initial_estimate
    if (
        phase.constraints
        or phase.updates
        or mission.robot.disturbances != Disturbances.defaults()
        or (estimated is not None and estimated != initial)
        or not (_ends_on_time_only(phase) and "until" in _limit(mission, phase, 0.0))
    ):
        return  # the path, or how the robot moves, or how the phase ends, not known
    bound = _bounds(phase, 0.0)
    robot, limits = mission.robot, mission.robot.limits
    numbers = _numbers(mission)
    start = (initial.x, initial.y, initial.theta)
    try:
        times, (x, y, dx, dy) = _sampled(mission, phase.track.path, start, bound)
    except (ValueError, ArithmeticError):
        return  # said by _reaches
    if times.size < 2 or not np.isfinite([x[-1], y[-1]]).all():
        return
    speeds = np.hypot(dx, dy)
    top = float(np.max(speeds[np.isfinite(speeds)], initial=0.0))
    allowed = []
    for key, auto in (
        ("cross_track_error_max", numbers.tracking_tolerance),
        ("along_track_lag_max", numbers.lag_allowance(top)),
    ):
        own = phase.expect.threshold(key)
        threshold = own if own is not None else mission.expect.threshold(key)
        if threshold is None:
            return  # one not checked: the other alone proves nothing
        allowed.append(auto if threshold == "auto" else float(threshold.max))
    # the end's reference point, from where the robot starts, less the farthest
    # it can go by then (the phase's last sample: the end, or a sample before)
    # and what the first estimate's noise may shift the path by
    noise = 4.0 * math.hypot(numbers.noise["x"], numbers.noise["y"])
    gap = min(
        math.dist(start[:2], (float(x[k]), float(y[k])))
        - _farthest(float(times[k]), robot.dt, numbers)
        - noise
        for k in (-2, -1)
    )
    if gap > sum(allowed) * (1.0 + 1e-9):
        acceleration = (
            f" and an acceleration of {numbers.v_acceleration:g} m/s^2"
            if math.isfinite(numbers.v_acceleration)
            else ""
        )
        yield Finding(
            (*where, "until"),
            f"phase {phase.name!r} ends before the robot can catch its path: from rest at "
            f"({start[0]:g}, {start[1]:g}), at limits.v = {limits.v:g} m/s{acceleration}, it "
            f"is at least {gap:.3g} m from its reference point when the phase ends at "
            f"{bound:g} s, where its tracking is judged; its cross-track and along-track "
            f"bounds allow {allowed[0]:.3g} m and {allowed[1]:.3g} m, so the run fails one "
            "of them whatever the law; lengthen the phase, start the path slower or nearer, "
            "or raise the limits",
            severity="warning",
        )


def _farthest(seconds: float, dt: float, numbers: MissionNumbers) -> float:
    """[m] the farthest the robot goes in ``seconds`` from rest, sampled every
    ``dt``: each sample's speed a sample's acceleration above the last, up to
    its speed limit (the first input is a whole sample's acceleration)."""
    speed, rate = numbers.v_limit, numbers.v_acceleration
    samples = math.ceil(seconds / dt - 1e-9)
    if math.isinf(rate):
        return samples * speed * dt
    rising = min(samples, math.floor(speed / (rate * dt)))
    # sum over the rising samples of (i + 1) rate dt, then the rest at the limit
    return (rate * dt * rising * (rising + 1) / 2.0 + speed * (samples - rising)) * dt


def _numbers(mission: Mission) -> MissionNumbers:
    """The mission's numbers at its own sampling period and limits."""
    dt, limits = mission.robot.dt, mission.robot.limits
    return mission_numbers(mission.model_dump(mode="json"), dt, (limits.v, limits.omega))


def _lag_judged(
    numbers: MissionNumbers, speed: float, ahead: float, gap: float, ends: float
) -> tuple[float, float, bool]:
    """[m] the least lag a robot has at the first sample its lag is judged on a
    straight path whose reference runs at ``speed`` from ``ahead`` metres
    before it along the path, from rest; [s] that sample's time; whether it is
    the phase's last. That sample is the first after the entry, at its longest
    (``gap`` at most between the tracked point and the path's start), or the
    last before the phase's end ``ends`` if sooner: a sample the verdict
    judges. The lag is what the reference covers less the farthest the robot
    can go (:func:`_farthest`); the judged lag is at least this: it grows while
    the robot is slower than its reference and shrinks after, so no sample
    judged before this one has less."""
    dt = numbers.dt
    entry = numbers.recovery_time(gap, speed)
    first, last = math.ceil(entry / dt - 1e-9), math.ceil(ends / dt - 1e-9) - 1
    judged = min(first, last) * dt
    lag = ahead + speed * judged - _farthest(judged, dt, numbers)
    return lag, judged, first >= last


def _lag_at_top_speed(mission: Mission, caught: set[DataPath]) -> Iterator[Finding]:
    """A warning where a track phase's straight path runs too near the speed limit
    for the robot, entering it slower, to catch up before its lag is judged:
    the reference runs away at its speed while the robot accelerates within
    its acceleration limit and is left ``v^2 / (2 a)`` behind from rest; the
    entry (MissionNumbers.recovery_time) allows the time to close that gap at
    the speed the limit leaves over the path's, a tenth of the limit at least,
    and none at or above the limit. Where the least lag the limits leave at the
    end of the entry (or at the phase's end, if sooner) exceeds the
    along_track_lag_max the verdict applies, the run fails it whatever the law.

    Only where all of that is known before the run: a `line` path (a curve may
    be cut short), no updates (a path slowed may be caught), no zones (a detour
    is excused), no disturbances, a phase that ends on time (one that ends on
    the robot's motion within its entry is not judged), entered at rest from a
    known place: the first phase from the initial state (its estimate the
    same), or a phase after holds of it whose line starts at the robot
    (`start: current`); a line made from an estimate four noise std off. A
    phase in ``caught`` (:func:`_catching_up` warned that it ends before the
    robot can catch its path) is left to that warning where it ends within
    its entry."""
    if mission.robot.disturbances != Disturbances.defaults():
        return
    robot, limits = mission.robot, mission.robot.limits
    numbers = _numbers(mission)
    initial, estimated = robot.initial_state, mission.estimator.initial_estimate
    noise = 4.0 * math.hypot(numbers.noise["x"], numbers.noise["y"])
    order = run_order(mission)
    for number, (phase, where, _) in enumerate(order):
        # at rest: at the start, and after holds of the initial pose; after
        # anything else the robot may enter at any speed up to its limit
        at_rest = all(isinstance(step.phase, HoldPhase) for step in order[:number])
        if (
            not isinstance(phase, TrackPhase)
            or not isinstance(phase.track.path, LinePath)
            or not at_rest
            or phase.constraints
            or phase.updates
            or not _ends_on_time_only(phase)
            or (number > 0 and phase.until.mission_time is not None)  # its length not known
        ):
            continue
        path = phase.track.path
        if number == 0 and (estimated is None or estimated == initial):
            pose = (initial.x, initial.y, initial.theta)
            line = paths.trajectory(path, mission.path_context(), pose)
            assert isinstance(line, LineTrajectory)
            # how far the line's start lies ahead of the robot along the line
            along = math.cos(line.heading) * (line.x0 - pose[0]) + math.sin(line.heading) * (
                line.y0 - pose[1]
            )
            apart = math.hypot(line.x0 - pose[0], line.y0 - pose[1])
        elif number > 0 and path.start == "current":
            along, apart = 0.0, 0.0
        else:
            continue
        # a `start: current` line starts at an estimate: four noise std off
        ahead, gap = along - noise, apart + numbers.look_ahead + noise
        own = phase.expect.threshold("along_track_lag_max")
        threshold = own if own is not None else mission.expect.threshold("along_track_lag_max")
        ends = _bounds(phase, 0.0)
        if threshold is None or math.isinf(ends):
            continue  # not judged, or not on time
        speed = float(path.speed)
        if speed > limits.v:  # beyond the limit: refused as a path the robot cannot follow
            continue
        bound = numbers.lag_allowance(speed) if threshold == "auto" else float(threshold.max)
        lag, judged, at_end = _lag_judged(numbers, speed, ahead, gap, ends)
        if lag <= bound * (1.0 + 1e-9):
            continue
        # a phase that ends within its entry: would it pass, judged at the entry's end?
        longer = numbers.recovery_time(gap, speed) + 2.0 * numbers.dt
        lengthening = at_end and _lag_judged(numbers, speed, ahead, gap, longer)[0] <= bound * (
            1.0 + 1e-9
        )
        if lengthening and where in caught:
            continue  # _catching_up says to lengthen it, which is enough
        yield Finding(
            (*where, "track", "path", "speed"),
            f"phase {phase.name!r}: its path runs at {speed:g} m/s, limits.v is "
            f"{limits.v:g} m/s; the robot, from rest and accelerating at up to "
            f"{numbers.v_acceleration:g} m/s^2, is at least {lag:.3g} m behind its reference "
            f"point when its lag is first judged, {judged:.3g} s into the phase, where "
            f"along_track_lag_max allows {bound:.3g} m, so the run fails it whatever the law; "
            + ("lengthen the phase, " if lengthening else "")
            + _lag_remedies(
                numbers, speed, (ahead, gap), ends, None if threshold == "auto" else bound
            ),
            severity="warning",
        )


def _lag_remedies(
    numbers: MissionNumbers,
    speed: float,
    start: tuple[float, float],
    ends: float,
    bound: float | None,
) -> str:
    """What lets the robot catch up in time: a slower path (in hundredths of the
    limit), a larger acceleration limit (found by bisection, rounded up), or a
    larger ``bound`` (None: `auto`, which follows the path's speed); ``start``
    is :func:`_lag_judged`'s ``ahead`` and ``gap``."""

    def fails(candidate: MissionNumbers, pace: float) -> bool:
        allowed = candidate.lag_allowance(pace) if bound is None else bound
        return _lag_judged(candidate, pace, *start, ends)[0] > allowed * (1.0 + 1e-9)

    step = 0.01 * numbers.v_limit
    slower = min(speed, numbers.v_limit) - step
    while slower > step and fails(numbers, slower):
        slower -= step
    remedies = [f"slow the path to {slower:.3g} m/s"]
    low, high = numbers.v_acceleration, 1024.0 * numbers.v_acceleration
    if not fails(numbers._replace(v_acceleration=high), speed):  # else no limit will do
        for _ in range(50):
            middle = 0.5 * (low + high)
            if fails(numbers._replace(v_acceleration=middle), speed):
                low = middle
            else:
                high = middle
        # rounded up to three digits: a limit printed lower may not do
        digits = 2 - math.floor(math.log10(high))
        needed = math.ceil(high * 10.0**digits) / 10.0**digits
        remedies.append(f"raise the acceleration limit to {needed:g} m/s^2")
    return (
        ", ".join(remedies)
        + ", or relax along_track_lag_max (null, or a bound above the lag the run shows)"
    )


def _update_paths(
    mission: Mission, phase: TrackPhase, where: DataPath, pose: Pose, bound: float, assumed: str
) -> Iterator[Finding]:
    """Each update's path as the phase's own is checked: finite, and within the
    limits, over the phase's bound, from the pose the phase is assumed to start at
    (where the update will take over is not known in advance)."""
    times = _sample_times(mission, bound)
    in_force = phase.track.path
    for number, update in enumerate(phase.updates):
        in_force = in_force if update.path is None else update.path
        path = update.path
        if path is None and update.speed is not None and path_pace(in_force) is not None:
            path = with_pace(in_force, float(update.speed))  # the same curve, re-timed
        if path is None:
            continue
        at: DataPath = (*where, "updates", number, "path" if update.path else "speed")
        try:
            trajectory = paths.trajectory(path, mission.path_context(), pose)
            with np.errstate(all="ignore"):
                x, y, dx, dy = trajectory.sample(times)
        except (ValueError, ArithmeticError) as error:
            yield Finding(at, f"the path cannot be sampled ({assumed}): {error}", "warning")
            continue
        finite = np.isfinite(x) & np.isfinite(y) & np.isfinite(dx) & np.isfinite(dy)
        if not finite.all():
            first = float(times[int(np.argmin(finite))])
            yield Finding(
                at,
                f"the path (or its direction) is not finite at t = {first:g} s after the "
                f"update ({assumed}); the run would stop there as diverged",
                severity="error" if first == 0.0 else "warning",
            )
            continue
        # An update may take over late in the phase: what the path needs is a warning.
        for finding in _path_within_limits(mission, where, phase, times, dx, dy, assumed, path, at):
            # a speed update's finding is at its speed, not at a field of the path
            kept = finding.path if update.path is not None else at
            yield finding._replace(severity="warning", path=kept)


def _path_within_limits(
    mission: Mission,
    where: DataPath,
    phase: TrackPhase,
    times: FloatArray,
    dx: FloatArray,
    dy: FloatArray,
    assumed: str,
    path: Any = None,
    at_path: DataPath | None = None,
) -> Iterator[Finding]:
    """The path's own speed, and how fast it turns, against the actuator
    limits, up to the phase's predicted end: a robot on a path it cannot keep
    up with falls behind or cuts across, whatever the law.

    The turn rate is the path's turn within TURN_WINDOW seconds, divided by
    them (speed x curvature on a smooth path): a corner of a polyline or a lane
    end is a turn the robot makes up within that time, a circle too tight for
    the limit is not. The direction is taken up to a reversal, which the robot
    drives rather than turns. An error when the phase's end is known in advance
    (it ends on time, or on reaching a region the path crosses), a warning when
    a near or heading condition may end it first.
    """
    if times.size < 2:
        return
    dx, dy = dx[: times.size], dy[: times.size]
    speed = np.hypot(dx, dy)
    limits = mission.robot.limits
    path = phase.track.path if path is None else path
    field = next(
        (f for f in ("angular_rate", "speed") if f in getattr(type(path), "model_fields", {})), None
    )
    at: DataPath = (*(at_path or (*where, "track", "path")), *((field,) if field else ()))
    predictable = phase.until.near is None and phase.until.heading is None
    for need, limit, what, unit, name in (
        (speed, limits.v, "a speed", "m/s", "limits.v"),
        (_turn_rate(times, dx, dy, speed), limits.omega, "a turn rate", "rad/s", "limits.omega"),
    ):
        over = np.flatnonzero(need > limit * (1.0 + 1e-9))
        if over.size == 0:
            continue
        peak = float(np.max(need[np.isfinite(need)]))
        yield Finding(
            at,
            f"the path needs {what} of up to {peak:.3g} {unit} (from t = "
            f"{float(times[over[0]]):.3g} s of phase {phase.name!r}), above robot.{name} = "
            f"{limit:g} {unit} ({assumed}); the robot cannot follow it: slow the path down "
            f"or raise the limit",
            severity="error" if predictable else "warning",
        )


def _turn_rate(times: FloatArray, dx: FloatArray, dy: FloatArray, speed: FloatArray) -> FloatArray:
    """|turn of the path's direction over the next TURN_WINDOW s| / TURN_WINDOW,
    from each sample (over the whole phase when it is shorter)."""
    # A route turning in place creeps at TURN_CREEP along the heading it turns
    # to: its direction turns at the route's own turn rate, which the robot
    # follows; held at the last leg's, a corner turned at 0.2 rad/s read as a
    # quarter turn within TURN_WINDOW, 1.57 rad/s.
    creeping = np.abs(speed - TURN_CREEP) <= 1e-3 * TURN_CREEP
    moving = (speed > _STANDSTILL) | creeping
    if not moving.any():
        return np.zeros(0)
    # where the path stands still its direction is the last one it had
    held = np.maximum.accumulate(np.where(moving, np.arange(times.size), 0))
    held[: int(np.argmax(moving))] = int(np.argmax(moving))
    axis = np.unwrap(2.0 * np.arctan2(dy[held], dx[held])) / 2.0  # up to a reversal
    step = float(times[1] - times[0])
    span = max(1, min(round(TURN_WINDOW / step), times.size - 1))
    turn: FloatArray = np.abs(axis[span:] - axis[:-span]) / (span * step)
    return turn


def _expectations(mission: Mission) -> Iterator[Finding]:
    for run in run_order(mission):
        phase = run.phase
        if isinstance(phase, TrackPhase) or (run.lap is not None and run.lap > 1):
            continue
        kind = "regulate" if isinstance(phase, RegulatePhase) else "hold"
        for key in (m.name for m in catalog.phase_metrics() if m.kinds == catalog.TRACK):
            if phase.expect.threshold(key) is not None:
                yield Finding(
                    (*run.where, "expect", key),
                    f"expect.{key} measures the tracking of a path, but phase "
                    f"{phase.name!r} is a {kind} phase: it is never checked",
                    severity="warning",
                    at_key=True,
                )
    # A track phase's last reference point has a position but no heading.
    has_target = any(isinstance(p.phase, RegulatePhase) for p in run_order(mission))
    if mission.expect.threshold("final_heading_error") is not None and not has_target:
        yield Finding(
            ("expect", "final_heading_error"),
            "expect.final_heading_error is measured from the last regulate target, but the "
            "mission has no regulate phase",
            severity="warning",
            at_key=True,
        )


_MEASURED_WHERE: Final = {
    "track": "track phases",
    "zones": "phases with constraints",
    "target": "regulate and hold phases",
}


def _measured(phase: TrackPhase | RegulatePhase | HoldPhase) -> set[str]:
    """Where a phase stands among the signals' `measured_on`: the signals it measures."""
    kind = "track" if isinstance(phase, TrackPhase) else "target"
    return {"every", kind, *(("zones",) if phase.constraints else ())}


def _measured_on(formula: str) -> dict[str, str]:
    """Where each signal ``formula`` names is measured (wmr_mission.spec.temporal.SIGNALS),
    the grammar imported by the first mission that writes a formula."""
    from wmr_mission.spec.temporal import SIGNALS, parse_formula, signals_of

    return {signal: SIGNALS[signal].measured_on for signal in signals_of(parse_formula(formula))}


# Signals no sample takes below 0: distances, a wrapped angle, magnitudes.
_NON_NEGATIVE: Final = ("cross_track", "target_distance", "heading_error", "speed", "turn_rate")


def _impossible(formula: str, mission: Mission) -> Iterator[str]:
    """The comparisons of ``formula`` no sample meets: one of _NON_NEGATIVE
    below a negative bound, a speed or turn rate above its limit (the inputs
    are saturated to them), a heading error above a half turn."""
    from wmr_mission.spec.temporal import atoms_of, parse_formula

    limits = mission.robot.limits
    most = {
        "speed": (limits.v, "limits.v"),
        "turn_rate": (limits.omega, "limits.omega"),
        "heading_error": (math.pi, "pi"),
    }
    for atom in atoms_of(parse_formula(formula)):
        if not atom.above and atom.bound < 0.0 and atom.signal in _NON_NEGATIVE:
            yield f"{atom.signal} <= {atom.bound:g} never holds: it is 0 or more"
        elif atom.above and atom.signal in most and atom.bound > most[atom.signal][0]:
            top, name = most[atom.signal]
            yield f"{atom.signal} >= {atom.bound:g} never holds: it is at most {name} = {top:.4g}"


def _formulas(mission: Mission) -> Iterator[Finding]:
    """A phase's own temporal formula names only signals the phase measures,
    and a mission-wide one signals that some phase taking it measures together
    (each is checked only where all its signals are measured); no comparison
    of a formula is one no sample can meet."""
    written: list[tuple[DataPath, str]] = [
        (("expect", "temporal", i), t) for i, t in enumerate(mission.expect.temporal or ())
    ]
    for run in run_order(mission):
        temporal = run.phase.expect.temporal or ()
        written += [((*run.where, "expect", "temporal", i), t) for i, t in enumerate(temporal)]
    for path, text in dict(written).items():
        for said in _impossible(text, mission):
            yield Finding(path, f"{said}; write a bound it can meet", severity="warning")
    takers: list[set[str]] = []
    for run in run_order(mission):
        phase = run.phase
        if run.lap is not None and run.lap > 1:
            continue
        measured = _measured(phase)
        if phase.expect.temporal is None:
            takers.append(measured)
        for index, text in enumerate(phase.expect.temporal or ()):
            for signal, where in sorted(_measured_on(text).items()):
                if where not in measured:
                    yield Finding(
                        (*run.where, "expect", "temporal", index),
                        f"{signal} is measured on {_MEASURED_WHERE[where]}, but "
                        f"phase {phase.name!r} is not one: the formula is never checked",
                        severity="warning",
                    )
    for index, text in enumerate(mission.expect.temporal or ()):
        measured_on = _measured_on(text)
        # every phase measures speed and turn rate: the others decide
        signals = sorted(s for s, where in measured_on.items() if where != "every")
        if any({measured_on[s] for s in signals} <= measured for measured in takers):
            continue
        names = " and ".join(signals) + (" together" if len(signals) > 1 else "")
        places = "; ".join(f"{s}: {_MEASURED_WHERE[measured_on[s]]}" for s in signals)
        if len(signals) == 1:
            places = _MEASURED_WHERE[measured_on[signals[0]]]
        yield Finding(
            ("expect", "temporal", index),
            f"no phase that takes the mission's formulas measures {names} ({places}): "
            "the formula is never checked",
            severity="warning",
        )


def _phase_colors(mission: Mission) -> Iterator[Finding]:
    names = list(dict.fromkeys(run.phase.name for run in run_order(mission)))  # repeats once
    for name in mission.plot.phase_colors:
        if name not in names:
            hint = fields.did_you_mean(name, names)
            yield Finding(
                ("plot", "phase_colors", name),
                f"plot.phase_colors.{name}: no phase is named {name!r}{hint} "
                f"(phases: {', '.join(names)})",
                at_key=True,
            )


def _control(mission: Mission) -> Iterator[Finding]:
    """Traps of the tracking law and of eq. (1) at the configured limits."""

    robot = mission.robot
    limits = robot.limits
    if robot.dt * limits.omega > LARGEST_TURN_PER_SAMPLE:
        yield Finding(
            ("robot", "limits", "omega"),
            f"limits.omega * dt = {limits.omega * robot.dt:g} rad per sample: eq. (1) is second "
            f"order in omega dt and stops being the robot's motion beyond "
            f"{LARGEST_TURN_PER_SAMPLE:g} rad per sample; lower limits.omega or dt",
            severity="warning",
        )
    if not any(isinstance(p, TrackPhase) for p in mission.phases):
        return
    controller = mission.controller
    if not isinstance(controller, PaperController):
        return
    tracking = controller.tracking
    look_ahead = paper.look_ahead(controller, robot.dt, limits.v)
    if limits.v >= NO_LIMIT and tracking.output == "look-ahead" and tracking.look_ahead is None:
        yield Finding(
            ("robot", "limits", "v"),
            f"limits.v = {limits.v:g} m/s is no limit, but the tracking law ties its look-ahead "
            f"to it (max(0.05, limits.v * dt) = {look_ahead:g} m); give the robot's real speed "
            "limit or set controller.tracking.look_ahead",
        )
    elif paper.error_decay(controller, robot.dt) == 0.0 and max(limits.v, limits.omega) >= NO_LIMIT:
        law = "the literal axle law" if look_ahead == 0.0 else "a one-sample tracking law"
        yield Finding(
            ("robot", "limits"),
            f"{law} closes the whole tracking error in one sample and runs away without "
            f"actuator limits (limits.v = {limits.v:g}, limits.omega = {limits.omega:g}); "
            "give the robot's real limits, or a controller.tracking.time_constant > 0",
            severity="warning",  # a fair way to watch the paper's law diverge
        )
    if look_ahead > 0.0 and look_ahead <= 0.5 * limits.v * robot.dt:
        # det(D B) = dt^2 (look_ahead + v dt / 2): zero at v = -2 look_ahead / dt.
        yield Finding(
            ("controller", "tracking", "look_ahead"),
            f"the look-ahead law is singular at v = {-2 * look_ahead / robot.dt:g} m/s, within "
            f"limits.v = {limits.v:g} (det(D B) = dt^2 (look_ahead + v dt / 2)); use a "
            f"look_ahead of at least limits.v * dt = {limits.v * robot.dt:g} m, or leave it unset",
        )


def _estimator_bounds(mission: Mission) -> Iterator[Finding]:
    """Eq. (4) bounds narrower than the noise make phase II act on the noise."""
    estimator = mission.estimator
    if not isinstance(estimator, ConstrainedObserver) or not estimator.output_error_bounds:
        return
    noise = mission.sensors.measured_noise()
    for state, (lower, upper) in estimator.output_error_bounds.items():
        std = noise.get(state, 0.0)
        if std > 0 and min(-lower, upper) < BOUND_NOISE_FLOOR * std:
            yield Finding(
                ("estimator", "output_error_bounds", state),
                f"output_error_bounds.{state} [{lower:g}, {upper:g}] is within "
                f"{BOUND_NOISE_FLOOR:g} noise standard deviations (sensors.noise_std.{state} = "
                f"{std:g}): phase II of the estimator would act on the noise; use at least "
                f"+-{BOUND_NOISE_RATIO * std:g} or leave the bounds unset",
                severity="warning",
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
        if duration < dt or not whole_samples(duration, dt):
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
    convergence = expect.convergence_tolerance
    if expect.threshold("estimation_convergence_time") is not None:
        for name in ("x", "y", "theta"):
            offset = abs(getattr(bias, name))
            band = getattr(convergence, name)
            if name in measured and offset >= band:
                yield Finding(
                    ("sensors", "bias", name),
                    f"the measurement bias of {name} ({offset:g}) is at least its "
                    f"convergence tolerance ({band:g}) that estimation_convergence_time waits "
                    "for: the estimate follows the biased measurement and may never enter it",
                    severity="warning",
                )
    for field, threshold, offset, unit in (
        ("final_position_error", expect.threshold("final_position_error"), position_bias, "m"),
        ("final_heading_error", expect.threshold("final_heading_error"), heading_bias, "rad"),
    ):
        if threshold is not None and offset > threshold.max:
            yield Finding(
                ("expect", field, "max"),
                f"expect.{field} {threshold.max:g} {unit} is below the measurement bias "
                f"({offset:g} {unit}): the robot ends where the biased measurement says",
                severity="warning",
            )


# --- what validate proves before a run ------------------------------------------------

# [rad] an angle beyond a full turn either way was most likely written in degrees
FULL_TURN: Final = 2.0 * math.pi
# The fields that hold an angle [rad], by the model that has them (a
# `theta` elsewhere may be a gain, a pole or a standard deviation); every
# field a mission's models describe in [rad] is here or is a spread
# (tests/test_validate_proofs.py).
ANGLE_FIELDS: Final[dict[type[BaseModel], tuple[str, ...]]] = {
    fields.Pose: ("theta",),
    fields.StateOffset: ("theta",),
    LinePath: ("heading",),
    CirclePath: ("start",),
    EllipsePath: ("rotation", "start"),
    EllipticalSpiralPath: ("rotation", "start"),
    SpiralPath: ("start",),
    EllipseRegion: ("rotation",),
    BoxRegion: ("heading",),
    CoveragePath: ("direction",),
    HeadingCondition: ("target",),
}
# A path whose distance from a keep-out zone's centre is below this share of
# the zone's smaller semi-axis runs "through its centre": the side the robot
# takes round it is then the zone filter's rule's, not the mission's.
CENTRE_SHARE: Final = 0.02


def _angles(mission: Mission) -> Iterator[Finding]:
    """Angles are radians: one beyond +-2 pi was most likely written in degrees."""
    return _angles_below(mission, ())


def _angles_below(value: object, path: DataPath) -> Iterator[Finding]:
    if isinstance(value, BaseModel):
        for name in type(value).model_fields:
            item = getattr(value, name)
            angle = name in ANGLE_FIELDS.get(type(value), ())
            if angle and isinstance(item, float | int) and not isinstance(item, bool):
                if abs(item) > FULL_TURN:
                    yield Finding(
                        (*path, name),
                        f"{_dotted((*path, name))} = {item:g} rad is more than a full turn "
                        f"(2 pi = {FULL_TURN:.4g}): degrees? {item:g} degrees is "
                        f"{math.radians(item):.4g} rad; angles are in radians",
                        severity="warning",
                    )
            else:
                yield from _angles_below(item, (*path, name))
    elif isinstance(value, list | tuple):
        for number, item in enumerate(value):
            yield from _angles_below(item, (*path, number))
    elif isinstance(value, dict):
        for key, item in value.items():
            yield from _angles_below(item, (*path, str(key)))


def _unwritten_headings(mission: Mission) -> Iterator[Finding]:
    """A regulate target (or an update's) without a heading has heading 0, the
    pose's default: the robot turns to +x at its goal, and a `settled` waits
    for it. Written nowhere, that is most likely not what was meant."""
    for run in run_order(mission):
        phase = run.phase
        if not isinstance(phase, RegulatePhase) or run.lap not in (None, 1):
            continue
        targets = [((*run.where, "regulate", "target"), phase.regulate.target)]
        targets += [
            ((*run.where, "updates", number, "target"), update.target)
            for number, update in enumerate(phase.updates)
            if update.target is not None
        ]
        for where, target in targets:
            if "theta" not in target.model_fields_set:
                yield Finding(
                    where,
                    f"{_dotted(where)} has no theta: a target's heading is then 0 (+x), "
                    f"which the robot turns to at ({target.x:g}, {target.y:g}) and a "
                    f"`settled` waits for; write the heading it should end at (theta: 0 "
                    "says +x is meant)",
                    severity="warning",
                )


def _missing_limits(mission: Mission) -> Iterator[Finding]:
    """Every law that moves the robot needs its real limits: the defaults are the
    paper's (10 m/s, 20 rad/s), which no small robot has."""
    if "limits" in mission.robot.model_fields_set or not _moves(mission):
        return
    limits = mission.robot.limits
    yield Finding(
        ("robot",) if "robot" in mission.model_fields_set else (),
        f"robot.limits is not given, so the robot may drive at the paper's limits.v = "
        f"{limits.v:g} m/s and limits.omega = {limits.omega:g} rad/s: give the robot's real "
        "limits (every tracking law, and every check of what the mission can reach in time, "
        "reads them)",
        severity="warning",
    )


def _fenced_out(mission: Mission) -> dict[str, RegionSpec]:
    """The geofence's keep-out zones, kept whatever the phase."""
    names = mission.geofence.keep_out if mission.geofence is not None else ()
    return {n: mission.regions[n] for n in names if n in mission.regions}


def _keep_outs(mission: Mission, phase: Phase) -> dict[str, RegionSpec]:
    """The zones the robot keeps out of during ``phase``: its own and the geofence's."""
    names = [c.stay_outside for c in phase.constraints if not isinstance(c, StayInside)]
    return {n: mission.regions[n] for n in names if n in mission.regions} | _fenced_out(mission)


def _fenced_in(mission: Mission) -> dict[str, RegionSpec]:
    """The geofence's keep-in regions, kept whatever the phase."""
    names = mission.geofence.keep_in if mission.geofence is not None else ()
    return {n: mission.regions[n] for n in names if n in mission.regions}


def _keep_ins(mission: Mission, phase: Phase) -> dict[str, RegionSpec]:
    """The regions the robot keeps inside during ``phase``, every one of them
    at once: its own and the geofence's."""
    names = [c.stay_inside for c in phase.constraints if isinstance(c, StayInside)]
    return {n: mission.regions[n] for n in names if n in mission.regions} | _fenced_in(mission)


def _outside_by(region: RegionSpec, x: float, y: float) -> float:
    """[m] how far the point (x, y) is outside ``region`` (0 inside), sampled as
    :func:`distance_to` is."""
    inside = region_value(region, np.array([x]), np.array([y]))[0] <= 0.0
    return 0.0 if inside else distance_to(region, x, y)


def _apart(region: RegionSpec, other: RegionSpec) -> bool:
    """Whether two regions share no point: the boundary of each bounded one lies
    wholly outside the other (both convex, so neither then holds the other).
    Two half-planes are not judged."""
    bounded = [
        (r, o) for r, o in ((region, other), (other, region)) if not isinstance(r, HalfPlaneRegion)
    ]
    return bool(bounded) and all(
        bool(np.all(region_value(o, *_boundary(r)) > 0.0)) for r, o in bounded
    )


def _inside(region: RegionSpec, x: ArrayLike, y: ArrayLike) -> bool:
    """Whether every point (x, y) is inside ``region`` (its boundary counts as outside)."""
    return bool(np.all(region_value(region, x, y) < 0.0))


def _zones(mission: Mission) -> Iterator[Finding]:
    """A start inside a geofence's keep-out zone or beyond its margin outside
    its keep-in (inside a first phase's zone is an error of its own), a
    regulate target inside the geofence's keep-out or outside its keep-in, and
    an `until` region or point that lies wholly inside a zone kept out or
    wholly outside a region kept in."""
    start = mission.robot.initial_state
    fence = _fenced_out(mission)
    for name, zone in fence.items():
        if _inside(zone, start.x, start.y):
            yield Finding(
                ("robot", "initial_state"),
                f"robot.initial_state ({start.x:g}, {start.y:g}) is inside keep-out zone "
                f"{name!r} of the geofence: the run is breached at its first sample",
                severity="warning",
            )
    margin = mission.geofence.margin if mission.geofence is not None else 0.0
    for name, yard in _fenced_in(mission).items():
        outside = _outside_by(yard, start.x, start.y)
        if outside > margin:
            yield Finding(
                ("robot", "initial_state"),
                f"robot.initial_state ({start.x:g}, {start.y:g}) is {outside:.3g} m outside "
                f"keep-in region {name!r} of the geofence (margin {margin:g} m): the run is "
                "breached at its first sample",
                severity="warning",
            )
    for run in run_order(mission):
        phase, where = run.phase, run.where
        if run.lap is not None and run.lap > 1:
            continue
        zones, yards = _keep_outs(mission, phase), _keep_ins(mission, phase)
        if isinstance(phase, RegulatePhase):
            target = phase.regulate.target
            for name, zone in fence.items():
                if _inside(zone, target.x, target.y):
                    yield Finding(
                        (*where, "regulate", "target"),
                        f"the target ({target.x:g}, {target.y:g}) is inside keep-out zone "
                        f"{name!r} of the geofence: the robot cannot get there",
                        severity="warning",
                    )
            for name, yard in _fenced_in(mission).items():
                if _outside_by(yard, target.x, target.y) > 0.0:
                    yield Finding(
                        (*where, "regulate", "target"),
                        f"the target ({target.x:g}, {target.y:g}) is outside keep-in region "
                        f"{name!r} of the geofence: the robot cannot get there",
                        severity="warning",
                    )
        reaches = phase.until.reaches
        region = mission.regions.get(reaches) if reaches is not None else None
        if region is not None:
            x, y = _boundary(region)
            for name, zone in zones.items():
                if name != reaches and _inside(zone, x, y):
                    yield Finding(
                        (*where, "until", "reaches"),
                        f"region {reaches!r} lies inside keep-out zone {name!r}, which the "
                        f"robot keeps out of during phase {phase.name!r}: until.reaches can "
                        "never fire",
                        severity="warning",
                    )
            for name, yard in yards.items():
                if name != reaches and _apart(region, yard):
                    yield Finding(
                        (*where, "until", "reaches"),
                        f"region {reaches!r} lies wholly outside keep-in region {name!r}, "
                        f"which the robot keeps inside during phase {phase.name!r}: "
                        "until.reaches can never fire",
                        severity="warning",
                    )
        near = phase.until.near
        if near is not None:
            turn = np.linspace(0.0, 2.0 * math.pi, 64, endpoint=False)
            x = near.point[0] + near.tolerance * np.cos(turn)
            y = near.point[1] + near.tolerance * np.sin(turn)
            for name, zone in zones.items():
                if _inside(zone, x, y):
                    yield Finding(
                        (*where, "until", "near"),
                        f"every point within {near.tolerance:g} m of ({near.point[0]:g}, "
                        f"{near.point[1]:g}) is inside keep-out zone {name!r}, which the robot "
                        f"keeps out of during phase {phase.name!r}: until.near can never fire",
                        severity="warning",
                    )
            for name, yard in yards.items():
                off = _outside_by(yard, near.point[0], near.point[1])
                if off > near.tolerance:
                    yield Finding(
                        (*where, "until", "near"),
                        f"({near.point[0]:g}, {near.point[1]:g}) is {off:.3g} m outside keep-in "
                        f"region {name!r}, which the robot keeps inside during phase "
                        f"{phase.name!r}: no point within {near.tolerance:g} m of it is "
                        "inside, so until.near can never fire",
                        severity="warning",
                    )


def _body_room(mission: Mission) -> Iterator[Finding]:
    """With a footprint: a start, or a settled regulate target, that is outside
    a keep-out zone of its phase but nearer to it than the body reaches, or
    inside a keep-in region but nearer its edge than that. The zones are kept
    by the body (docs/mission-format.md, "The robot's body"): the robot
    starts beyond one, or cannot reach the target. A polygon body is kept by
    the disc round it: where the body itself, at the pose's heading, clears
    the zone and only that disc does not, the finding says so.

    And a settled target the body clears, but whose zone the controller keeps
    the axle farther from than the target lies by more than its `settled`
    tolerance: the band is the body's reach and the
    estimate's margin (``Plant.constraint_margin``), and the robot stops at
    its edge (docs/paper-notes.md, eq. (28), "A target within the band kept
    round a zone")."""
    footprint = mission.robot.footprint
    if footprint is None:
        return  # (a point's band, the estimate's margin alone, is a few cm: not said)
    reach = footprint.reach()
    margin = _estimate_margin(mission)
    band = reach + margin
    start = mission.robot.initial_state
    for number, run in enumerate(run_order(mission)):
        phase, where = run.phase, run.where
        if run.lap is not None and run.lap > 1:
            continue
        points: list[tuple[DataPath, str, Pose, float]] = []  # ..., its settled tolerance
        if number == 0:
            points.append(
                (
                    ("robot", "initial_state"),
                    "robot.initial_state",
                    (start.x, start.y, start.theta),
                    math.inf,
                )
            )
        # (settled reads the target in force: one an update gives may be met)
        retargeted = any(u.target is not None for u in phase.updates)
        if isinstance(phase, RegulatePhase) and phase.until.settled is not None and not retargeted:
            target = phase.regulate.target
            points.append(
                (
                    (*where, "regulate", "target"),
                    "the target",
                    (target.x, target.y, target.theta),
                    float(phase.until.settled.position),
                )
            )
        # (the region, how much room a point has, where it is, what the body
        # does there, whether a body placed there does it, what it does
        # otherwise, where the disc is kept)
        sides = [
            (name, zone, _gap, "from keep-out zone", "overlaps the zone", _overlaps,
             "clears it", "out of the zone")
            for name, zone in _keep_outs(mission, phase).items()
        ] + [
            (name, yard, _room, "inside the edge of keep-in region", "reaches out of it",
             _reaches_out, "stays inside it", "inside the region")
            for name, yard in _keep_ins(mission, phase).items()
        ]  # fmt: skip
        for name, region, room_at, edge, body, does, clear, kept in sides:
            for path, what, (x, y, theta), tolerance in points:
                room = room_at(region, float(x), float(y))
                if not 0.0 <= room < reach:
                    if 0.0 <= room < band - tolerance:
                        yield _within_the_band(path, (x, y), room, edge, name, reach, margin)
                    continue
                said = f"{what} ({x:g}, {y:g}) is {room:.3g} m {edge} {name!r}, nearer than "
                if isinstance(footprint, RoundFootprint) or does(
                    region, _body_at(footprint.polygon, x, y, theta)
                ):
                    said += (
                        f"the robot's body reaches ({reach:.3g} m, robot.footprint): the body "
                        f"{body} there"
                    )
                else:
                    stops = (
                        "the robot starts with that disc beyond it"
                        if path == ("robot", "initial_state")
                        else "the robot stops short of the target"
                    )
                    said += (
                        f"the disc round the robot's body reaches ({reach:.3g} m, "
                        f"robot.footprint's farthest corner): the body itself, at heading "
                        f"{theta:g}, {clear} there, but the controller keeps that disc "
                        f"{kept}, so {stops}"
                    )
                yield Finding(path, said, severity="warning")


def _within_the_band(
    path: DataPath,
    target: tuple[float, float],
    room: float,
    edge: str,
    name: str,
    reach: float,
    margin: float,
) -> Finding:
    """A settled target nearer a zone's edge than the band the controller keeps
    round it, by more than its tolerance (:func:`_body_room`)."""
    band = f"the estimate's margin {margin:.3g} m"
    if reach > 0.0:
        band = f"the disc round the robot's body {reach:.3g} m and {band}"
    return Finding(
        path,
        f"the target ({target[0]:g}, {target[1]:g}) is {room:.3g} m {edge} {name!r}, but the "
        f"controller keeps the axle {reach + margin:.3g} m from that edge ({band}): the robot "
        f"stops at least {reach + margin - room:.3g} m short of the target, beyond its "
        "settled tolerance, and the phase cannot settle",
        severity="warning",
    )


def _band(mission: Mission) -> tuple[float, str]:
    """[m] The band the controller keeps round every zone (the body's reach and
    the estimate's margin, ``Plant.constraint_margin``), and its words."""
    footprint = mission.robot.footprint
    if footprint is None:
        return _estimate_margin(mission), "the estimate's margin"
    return footprint.reach() + _estimate_margin(mission), (
        "the robot's body and the estimate's margin"
    )


def _estimate_margin(mission: Mission) -> float:
    """[m] the estimate's share of the band the controller keeps round every
    zone (``Plant.constraint_margin`` less the body's reach); 0 for a plug-in
    estimator, whose code `validate` does not run."""
    estimator = ESTIMATORS.of(mission.estimator)
    if estimator.plugin:
        return 0.0
    tuning = estimator.tuning_of(mission.estimator, mission.measurements())
    return float(estimator.constraint_margin(tuning))


def _outline(region: RegionSpec) -> Any:
    """The region's outline as a shapely polygon (an ellipse or circle as one
    of 720 corners inscribed in it); not for a half-plane."""
    import shapely

    if isinstance(region, BoxRegion | PolygonRegion):
        return shapely.Polygon(region_vertices(region))
    return shapely.Polygon(np.column_stack(region_outline(region, n=720)[:2])[:-1])


def _body_at(polygon: list[tuple[float, float]], x: float, y: float, theta: float) -> FloatArray:
    """The corners of a polygon footprint placed at the pose (x, y, theta)."""
    corners = np.asarray(polygon, dtype=np.float64)
    c, s = math.cos(theta), math.sin(theta)
    return np.column_stack(
        (x + c * corners[:, 0] - s * corners[:, 1], y + s * corners[:, 0] + c * corners[:, 1])
    )


def _overlaps(region: RegionSpec, body: FloatArray) -> bool:
    """Whether the body (its corners) touches or overlaps the region, by shapely."""
    import shapely

    if isinstance(region, HalfPlaneRegion):
        nx, ny = region.normal
        return bool(np.min(nx * body[:, 0] + ny * body[:, 1]) <= region.offset)
    return bool(_outline(region).intersects(shapely.Polygon(body)))


def _reaches_out(region: RegionSpec, body: FloatArray) -> bool:
    """Whether the body (its corners) reaches out of the region, by shapely."""
    import shapely

    if isinstance(region, HalfPlaneRegion):
        nx, ny = region.normal
        return bool(np.max(nx * body[:, 0] + ny * body[:, 1]) > region.offset)
    return not _outline(region).covers(shapely.Polygon(body))


def _gap(region: RegionSpec, x: float, y: float) -> float:
    """[m] how far the point (x, y) is outside ``region`` (-1 inside), by shapely."""
    import shapely

    if isinstance(region, HalfPlaneRegion):
        nx, ny = region.normal
        return (nx * x + ny * y - region.offset) / math.hypot(nx, ny)
    point = shapely.Point(x, y)
    outline = _outline(region)
    return -1.0 if outline.contains(point) else float(outline.distance(point))


def _room(region: RegionSpec, x: float, y: float) -> float:
    """[m] how far the point (x, y) inside ``region`` is from its edge (0 on
    it, -1 outside), by shapely."""
    import shapely

    if isinstance(region, HalfPlaneRegion):
        nx, ny = region.normal
        inside = (region.offset - nx * x - ny * y) / math.hypot(nx, ny)
        return inside if inside >= 0.0 else -1.0
    outline = _outline(region)
    point = shapely.Point(x, y)
    return float(outline.exterior.distance(point)) if outline.covers(point) else -1.0


def _boundary(region: RegionSpec) -> tuple[FloatArray, FloatArray]:
    """Points on the boundary of a bounded region (a half-plane: its foot point)."""
    if isinstance(region, EllipseRegion | CircleRegion):
        cx, cy, a, b, rotation = ellipse_geometry(region)
        angle = np.linspace(0.0, 2.0 * math.pi, _BOUNDARY, endpoint=False)
        u, w = a * np.cos(angle), b * np.sin(angle)
        c, s = math.cos(rotation), math.sin(rotation)
        return cx + c * u - s * w, cy + s * u + c * w
    if isinstance(region, BoxRegion | PolygonRegion):
        points = region_vertices(region)
        ends = np.roll(points, -1, axis=0)
        share = np.linspace(0.0, 1.0, _BOUNDARY // len(points))[:, None, None]
        edge = points[None] + share * (ends - points)[None]
        return edge[..., 0].ravel(), edge[..., 1].ravel()
    nx, ny = region.normal
    norm = math.hypot(nx, ny)
    return np.array([nx * region.offset / norm**2]), np.array([ny * region.offset / norm**2])


def distance_to(region: RegionSpec, x: float, y: float) -> float:
    """How far (x, y) is from the boundary of ``region`` [m] (sampled; exact for a half-plane)."""
    if isinstance(region, BoxRegion | PolygonRegion | EllipseRegion | CircleRegion):
        bx, by = _boundary(region)
        return float(np.min(np.hypot(bx - x, by - y)))
    nx, ny = region.normal
    return abs(nx * x + ny * y - region.offset) / math.hypot(nx, ny)


def _wrapped(angle: float) -> float:
    return abs(math.remainder(angle, 2.0 * math.pi))


def _in_time(
    mission: Mission,
    phase: Phase,
    where: DataPath,
    pose: Pose,
    bound: float,
    start_time: float,
    assumed: str,
) -> Iterator[Finding]:
    """A phase whose timeout comes before any of its `until` conditions can
    hold, at the speed and turn-rate limits from where it starts.

    Each condition's least time is the larger of its distance over limits.v
    and its turn over limits.omega: a robot turns while it drives (an arc), so
    their sum would not be a bound, and this check only says what it proves.
    """
    if isinstance(phase, HoldPhase):
        yield from _held(mission, phase, where, pose, assumed)
        return
    if "timeout" not in _limit(mission, phase, start_time):
        return  # a phase that ends on time ends
    until, limits = phase.until, mission.robot.limits
    least: list[tuple[float, str]] = []
    if until.near is not None:
        distance = math.dist(pose[:2], until.near.point) - until.near.tolerance
        least.append(
            (
                distance / limits.v,
                f"within {until.near.tolerance:g} m of the point "
                f"({until.near.point[0]:g}, {until.near.point[1]:g}), "
                f"{max(distance, 0.0):.3g} m away",
            )
        )
    if until.reaches is not None and until.reaches in mission.regions:
        region = mission.regions[until.reaches]
        distance = distance_to(region, pose[0], pose[1])
        least.append((distance / limits.v, f"region {until.reaches!r}, {distance:.3g} m away"))
    if until.heading is not None:
        turn = _wrapped(until.heading.target - pose[2]) - until.heading.tolerance
        least.append(
            (
                turn / limits.omega,
                f"heading {until.heading.target:g} rad, {max(turn, 0.0):.3g} rad of turn away",
            )
        )
    if until.settled is not None and isinstance(phase, RegulatePhase):
        # settled reads the target in force: an update's may be met first
        targets = [phase.regulate.target]
        targets += [u.target for u in phase.updates if u.target is not None]
        for target in targets:
            distance = math.dist(pose[:2], (target.x, target.y)) - until.settled.position
            turn = _wrapped(target.theta - pose[2]) - until.settled.heading
            least.append(
                (
                    max(distance / limits.v, turn / limits.omega),
                    f"the target ({target.x:g}, {target.y:g}, {target.theta:g}), "
                    f"{max(distance, 0.0):.3g} m and {max(turn, 0.0):.3g} rad away",
                )
            )
    if not least:
        return
    seconds, goal = min(least)
    if seconds > bound:
        yield Finding(
            (*where, "timeout"),
            f"phase {phase.name!r} cannot end before its timeout of {bound:g} s: it needs "
            f"at least {seconds:.3g} s to reach {goal} at limits.v = {limits.v:g} m/s and "
            f"limits.omega = {limits.omega:g} rad/s ({assumed}); raise the timeout or the "
            "limits",
            severity="warning",
        )


def _held(
    mission: Mission, phase: HoldPhase, where: DataPath, pose: Pose, assumed: str
) -> Iterator[Finding]:
    """A hold keeps the pose it starts at: a `heading`, `near` or `reaches`
    goal of its `until` that pose does not meet never holds (four noise std of
    the estimate aside), and with no other condition the phase ends only by
    its timeout, or never. The run says so at its timeout; this says it
    before."""
    until = phase.until
    if until.elapsed is not None or until.mission_time is not None or until.settled is not None:
        return  # it ends on time, or settles where it holds
    estimated = mission.estimator.initial_estimate
    if estimated is not None and estimated != mission.robot.initial_state:
        return  # it holds the estimate, which moves the robot as it converges
    noise = mission.sensors.noise_std
    slack = 4.0 * math.hypot(noise.x, noise.y)
    far: list[str] = []
    if until.heading is not None:
        turn = abs(_wrapped(until.heading.target - pose[2])) - until.heading.tolerance
        if turn <= 4.0 * noise.theta:
            return
        far.append(f"heading {until.heading.target:g} rad is {turn:.3g} rad of turn away")
    if until.near is not None:
        distance = math.dist(pose[:2], until.near.point) - until.near.tolerance
        if distance <= slack:
            return
        point = until.near.point
        far.append(f"({point[0]:g}, {point[1]:g}) is {distance:.3g} m beyond its tolerance")
    if until.reaches is not None and until.reaches in mission.regions:
        distance = _outside_by(mission.regions[until.reaches], pose[0], pose[1])
        if distance <= slack:
            return
        far.append(f"region {until.reaches!r} is {distance:.3g} m away")
    if not far:
        return
    yield Finding(
        (*where, "until"),
        f"phase {phase.name!r} holds the pose it starts at ({assumed}, heading "
        f"{pose[2]:g} rad), where its `until` never holds: {'; '.join(far)}; it ends "
        "only by its timeout. A hold does not move: track or regulate to the goal, or end "
        "the hold on `elapsed`",
        severity="warning",
    )


def _across_zones(
    mission: Mission, phase: RegulatePhase, where: DataPath, pose: Pose, assumed: str
) -> Iterator[Finding]:
    """A note where the straight way from where a regulate phase starts to its
    target passes nearer one of its keep-out zones than the band the
    controller keeps round it: the regulator drives for its target and plans
    no way round a zone; the filter holds it off the zone, and it may stop
    there, shake against it or overshoot: 22 of 57 generated parks whose way
    was so noted were no success, 3 of 63 whose way was clear (`python
    scripts/parks_across_zones.py`; 58 of 202 and 8 of 198 with `--parks 400
    --seed 1`). A target within the band of a zone is warned of already
    (:func:`_target_against_constraints` and the body's checks): no note."""
    target = phase.regulate.target
    zones = [
        (number, name, region)
        for number, c in enumerate(phase.constraints)
        if not isinstance(c, StayInside)
        and (name := c.stay_outside) in mission.regions
        and not isinstance(region := mission.regions[name], HalfPlaneRegion)
    ]
    if not zones or (pose[0], pose[1]) == (target.x, target.y):
        return
    import shapely  # (only where a park keeps out of a zone: validate's start-up)

    band, kept = _band(mission)
    way = shapely.LineString([(pose[0], pose[1]), (target.x, target.y)])
    end = shapely.Point(target.x, target.y)
    for number, zone, region in zones:
        outline = _outline(region)
        if outline.distance(end) <= band or outline.distance(way) > band:
            continue
        yield Finding(
            (*where, "constraints", number),
            f"the straight way to the target ({target.x:g}, {target.y:g}) passes within "
            f"{band:.3g} m ({kept}) of keep-out zone {zone!r} ({assumed}): a regulate phase "
            "drives for its target and plans no way round a zone: it may stop at it, shake "
            "against it or overshoot (two in five such parks fail, few with the way clear); "
            "go round it first with a track phase, or a regulate phase to a point beside it",
            severity="note",
        )


def _inside_keep_outs(
    mission: Mission, phase: TrackPhase, where: DataPath, x: FloatArray, y: FloatArray
) -> Iterator[Finding]:
    """A warning where the path lies wholly inside a keep-out zone of its phase:
    a path that crosses a zone is a detour the mission chose, one that never
    leaves it cannot be tracked at all (the robot waits at the zone's edge)."""
    for number, constraint in enumerate(phase.constraints):
        zone = None if isinstance(constraint, StayInside) else constraint.stay_outside
        region = mission.regions.get(zone) if zone is not None else None
        if region is None or x.size == 0:
            continue
        with np.errstate(all="ignore"):
            inside = region_value(region, x, y) < 0.0
        if inside.all():
            yield Finding(
                (*where, "constraints", number),
                f"the path lies wholly inside keep-out zone {zone!r}: the robot can only wait "
                "at its edge, and the phase's tracking fails; move the path or the zone",
                severity="warning",
            )


def _through_centres(
    mission: Mission, phase: TrackPhase, where: DataPath, x: FloatArray, y: FloatArray
) -> Iterator[Finding]:
    """A note where the path runs through a keep-out ellipse's centre, naming
    the side the robot goes round: the zone filter sends it to the side of the
    path away from the centre where the path passes nearest it, and through
    the centre itself to the left of the direction of travel by rule
    (controllers/constrained_tracking.ways_round), a side the mission
    does not choose. A path that merely crosses a zone is a detour the mission
    chose: no note. A box or polygon is gone round the shorter way across, on
    the left where both are as far: its centre, for a box and any polygon as
    long one way across as the other, is its corners' mean.

    No way round where the path runs into the zone and the zone reaches out
    of a region kept in on the side the robot takes: a warning in place of
    the note, that the path is blocked when it does so on both sides."""
    if x.size < 2:
        return
    yards = _keep_ins(mission, phase)
    band, kept = _band(mission) if yards else (0.0, "")
    room = (
        f" or leaves less than {2.0 * band:.3g} m to its edge ({kept} on each side)"
        if band > 0.0
        else ""
    )
    for number, constraint in enumerate(phase.constraints):
        if isinstance(constraint, StayInside):
            continue
        zone = mission.regions.get(constraint.stay_outside)
        if isinstance(zone, EllipseRegion | CircleRegion):
            cx, cy, a, b, _ = ellipse_geometry(zone)
            size = min(a, b)
        elif isinstance(zone, BoxRegion | PolygonRegion):
            corners = region_vertices(zone)
            cx, cy = (float(v) for v in corners.mean(axis=0))
            edges = np.roll(corners, -1, axis=0) - corners
            size = 0.5 * float(np.min(np.hypot(edges[:, 0], edges[:, 1])))
            a = float(np.max(np.hypot(corners[:, 0] - cx, corners[:, 1] - cy)))
        else:
            continue
        gap, nearest = _passing(x, y, cx, cy)
        centre_on_left = bool(_left_of(x, y, nearest, np.array([cx]), np.array([cy]))[0])
        through = gap <= THROUGH_CENTRE * max(a, 1.0)
        goes_left = through or not centre_on_left  # away from the centre
        left, right = _closed_sides(zone, yards, x, y, nearest, band) or (None, None)
        # said where the band alone closes a side: the zone does not reach out there
        narrow = (
            room
            if (left, right) != (_closed_sides(zone, yards, x, y, nearest) or (None, None))
            else ""
        )
        taken, other = (left, right) if goes_left else (right, left)
        name = constraint.stay_outside
        if taken is not None and other is not None:
            sides = (
                f"{left!r} on both sides of the path"
                if left == right
                else f"{left!r} on the left of the path and out of {right!r} on its right"
            )
            yield Finding(
                (*where, "constraints", number, "stay_outside"),
                f"the path is blocked: it runs into keep-out zone {name!r}, which reaches out "
                f"of keep-in region {sides}{narrow}, so there is no way round it during phase "
                f"{phase.name!r}; the robot stops at its edge: leave room on one side, or move "
                "the path or the zone",
                severity="warning",
            )
            continue
        if taken is not None:
            way, away = ("left", "right") if goes_left else ("right", "left")
            rule = "by the zone filter's rule" if through else "away from its centre"
            yield Finding(
                (*where, "constraints", number, "stay_outside"),
                f"the robot goes round keep-out zone {name!r} on the {way} of the path "
                f"({rule}), where the zone reaches out of keep-in region {taken!r}{narrow}: "
                f"there is no way round on that side during phase {phase.name!r}, and the robot "
                f"stops at the zone's edge; move the path to the {away} of the zone's centre, "
                "where there is room",
                severity="warning",
            )
            continue
        if gap > CENTRE_SHARE * size:
            continue
        if through:
            side = "on the left of its direction of travel, by the zone filter's rule"
        else:
            side = (
                f"on the {'right' if centre_on_left else 'left'}, the side the path passes the "
                f"centre on, only {gap:.2g} m off it: a slight change of the path or the zone "
                "changes the side"
            )
        yield Finding(
            (*where, "constraints", number, "stay_outside"),
            f"the path runs through the centre of keep-out zone {constraint.stay_outside!r}: "
            f"the robot goes round it {side}; move the path off the centre, towards the side "
            "it should take, to choose",
            severity="note",
        )


def _between_zones(
    mission: Mission, phase: TrackPhase, where: DataPath, x: FloatArray, y: FloatArray
) -> Iterator[Finding]:
    """A warning where the path runs between two keep-out zones of its phase
    that leave less than twice the band the controller keeps round each (the
    body's reach and the estimate's margin) and the distance ahead of the
    axle it holds them at (:func:`_rows_held`): the zone filter holds each
    zone at a point that far ahead, kept that much further off, and that
    point must pass between the zones too; where every point of the gap is
    nearer one of them than the band and that distance, it cannot. The filter
    goes round each zone on the side away from its centre, into the gap, and
    the robot stops at their edge (two posts 0.2 m apart, a body of 0.25 m:
    it stood 3.6 m from its goal until its timeout).

    Twice the band alone let gaps the held point cannot pass go unsaid:
    posts 0.6 to 0.69 m apart, a band of 0.3 m and the zones held 0.05 m
    ahead (a limit of 0.7 m) stalled until the timeout, with and without
    1 cm of noise and acceleration limits, and from 0.7 m the robot passed;
    held 0.1 m ahead (dt 0.05, limits.v 2), up to 0.78 m stalled and from
    0.8 m it passed (docs/mission-format.md, "What `validate` checks";
    `python scripts/posts_gap.py`).

    A proof, to the first order the filter keeps its rows to (0.79 m was
    passed without acceleration limits, 5 mm inside the held point's
    bound): the gap is measured between points of the zones' outlines, never
    nearer than the outlines themselves. The path runs between them where it
    crosses the line joining those points an odd number of times, the zones'
    centres on either side, and enters neither zone (a path into one is a
    detour the mission chose, and the robot may go round both). The phase's
    own zones only: the controller does not keep the geofence's."""
    band, kept = _band(mission)
    if band == 0.0 or x.size < 2:
        return
    held = _rows_held(mission, phase)
    needed = 2.0 * (band + held)
    zones = [
        (number, c.stay_outside, mission.regions[c.stay_outside])
        for number, c in enumerate(phase.constraints)
        if not isinstance(c, StayInside)
        and c.stay_outside in mission.regions
        and not isinstance(mission.regions[c.stay_outside], HalfPlaneRegion)
    ]
    with np.errstate(all="ignore"):
        zones = [z for z in zones if not np.any(region_value(z[2], x, y) < 0.0)]
    outlines = [_boundary(region) for _, _, region in zones]
    discs = [_disc(bx, by) for bx, by in outlines]
    for k, m in itertools.combinations(range(len(zones)), 2):
        (ca, ra), (cb, rb) = discs[k], discs[m]
        if math.dist(ca, cb) - ra - rb >= needed:
            continue  # their discs too far apart for a gap that narrow
        (ax, ay), (bx, by) = outlines[k], outlines[m]
        i, j, gap = _nearest_points(ax, ay, bx, by)
        if not 0.0 < gap < needed * (1.0 - 1e-9):
            continue
        crossings = _crossings(x, y, (ax[i], ay[i]), (bx[j], by[j]))
        if crossings.size % 2 == 0:
            continue  # not across, or across and back
        sides = _left_of(
            x, y, int(crossings[0]), np.array([ca[0], cb[0]]), np.array([ca[1], cb[1]])
        )
        if sides[0] == sides[1]:
            continue
        (_, a_name, _), (number, b_name, _) = zones[k], zones[m]
        yield Finding(
            (*where, "constraints", number),
            f"the path runs between keep-out zones {a_name!r} and {b_name!r}, {gap:.3g} m "
            f"apart, where the controller keeps {band:.3g} m from each ({kept})"
            + (
                f" at a point {held:.3g} m ahead of the axle, kept {held:.3g} m further off"
                if held > 0.0
                else ""
            )
            + f": the robot cannot pass between them during phase {phase.name!r}, goes round "
            f"neither and stops at their edge; widen the gap well past {needed:.3g} m, or "
            "move the path round them",
            severity="warning",
        )


def _rows_held(mission: Mission, phase: TrackPhase) -> float:
    """[m] How far ahead of the axle the controller holds a track phase's
    zones (``paper.rows_ahead``), the least over the phase's look-aheads
    (its updates may change it); 0 for any other controller, whose zones
    `validate` does not know to be held ahead."""
    controller = mission.controller
    if not isinstance(controller, PaperController):
        return 0.0
    dt, speed = mission.robot.dt, mission.robot.limits.v
    settings = [controller] + [
        with_look_ahead(controller, float(update.look_ahead))
        for update in phase.updates
        if update.look_ahead is not None
    ]
    return min(
        paper.rows_ahead(paper.look_ahead(s, dt, speed), dt, speed)
        for s in settings
        if isinstance(s, PaperController)
    )


def _disc(x: FloatArray, y: FloatArray) -> tuple[tuple[float, float], float]:
    """A disc holding the outline through (x, y): its points' mean, and the
    farthest of them from it."""
    cx, cy = float(x.mean()), float(y.mean())
    return (cx, cy), float(np.max(np.hypot(x - cx, y - cy)))


def _nearest_points(
    ax: FloatArray, ay: FloatArray, bx: FloatArray, by: FloatArray
) -> tuple[int, int, float]:
    """A near pair of points (a, b) of two sampled outlines, and their
    distance: every eighth of a's points against all of b's, then a's points
    round the best of them. Never nearer than the outlines' own distance, and
    within a few of a's sample spacings of it."""
    coarse = np.hypot(ax[::8, None] - bx, ay[::8, None] - by)
    i, _ = np.unravel_index(int(np.argmin(coarse)), coarse.shape)
    near = np.arange(8 * int(i) - 16, 8 * int(i) + 17) % ax.size
    fine = np.hypot(ax[near, None] - bx, ay[near, None] - by)
    k, j = np.unravel_index(int(np.argmin(fine)), fine.shape)
    return int(near[k]), int(j), float(fine[k, j])


def _crossings(
    x: FloatArray, y: FloatArray, p: tuple[float, float], q: tuple[float, float]
) -> NDArray[np.intp]:
    """The segments of the polyline through (x, y) that cross the segment
    from ``p`` to ``q``, in order."""
    ax, ay, ex, ey = x[:-1], y[:-1], np.diff(x), np.diff(y)
    fx, fy = q[0] - p[0], q[1] - p[1]
    with np.errstate(all="ignore"):
        across = ex * fy - ey * fx
        s = ((p[0] - ax) * fy - (p[1] - ay) * fx) / across
        t = ((p[0] - ax) * ey - (p[1] - ay) * ex) / across
    return np.flatnonzero((across != 0.0) & (s >= 0.0) & (s < 1.0) & (t >= 0.0) & (t <= 1.0))


def _passing(x: FloatArray, y: FloatArray, px: float, py: float) -> tuple[float, int]:
    """Distance from (px, py) to the polyline through the samples (x, y), and
    the polyline's segment nearest the point."""
    ax, ay, ex, ey = x[:-1], y[:-1], np.diff(x), np.diff(y)
    length2 = ex * ex + ey * ey
    with np.errstate(all="ignore"):
        share = np.clip(((px - ax) * ex + (py - ay) * ey) / length2, 0.0, 1.0)
    share = np.where(length2 > 0.0, share, 0.0)
    gaps = np.hypot(ax + share * ex - px, ay + share * ey - py)
    nearest = int(np.argmin(gaps))
    return float(gaps[nearest]), nearest


def _left_of(
    x: FloatArray, y: FloatArray, segment: int, px: FloatArray, py: FloatArray
) -> NDArray[np.bool_]:
    """Whether each point (px, py) lies on the left of the line through the
    polyline's ``segment``, in its direction."""
    ex, ey = x[segment + 1] - x[segment], y[segment + 1] - y[segment]
    return np.asarray(ex * (py - y[segment]) - ey * (px - x[segment]) > 0.0)


def _closed_sides(
    zone: RegionSpec,
    yards: dict[str, RegionSpec],
    x: FloatArray,
    y: FloatArray,
    nearest: int,
    band: float = 0.0,
) -> tuple[str | None, str | None] | None:
    """The keep-in region that closes the way round ``zone`` on the left of the
    path, and the one on its right (split at its segment ``nearest`` the
    zone's centre), None for a side with room; None when the path does not
    run into the zone. A side is closed where a point of the zone's outline on
    it is not inside a region kept in: the robot, going round along the
    outline, would leave it; or, for a region whose value is a distance (a
    box, a polygon, a half-plane), is less than twice ``band`` inside it:
    the axle, ``band`` from the zone and ``band`` inside the region (the
    body's reach and the estimate's margin), cannot cross the gap from that
    point to the region's edge, every point of which is nearer one of them."""
    if not yards or not np.any(region_value(zone, x, y) < 0.0):
        return None
    bx, by = _boundary(zone)
    left = _left_of(x, y, nearest, bx, by)

    def closes(region: RegionSpec, s: NDArray[np.bool_]) -> bool:
        room = 0.0 if isinstance(region, EllipseRegion | CircleRegion) else 2.0 * band
        if room == 0.0:
            return bool(np.any(region_value(region, bx[s], by[s]) >= 0.0))
        # (a gap of the band itself, to rounding, is not said: a proof, not a guess)
        return bool(np.any(region_value(region, bx[s], by[s]) > -room * (1.0 - 1e-9)))

    left_name, right_name = (
        next((n for n, r in yards.items() if closes(r, s)), None) for s in (left, ~left)
    )
    return left_name, right_name
