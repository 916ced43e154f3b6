"""A mission compiled for the runner: plain numbers, arrays and callables.

``compile_mission`` is the only place that reads the pydantic models; the
runner and the kernels see only what is here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import STATE_NAMES, measurement_mask

if TYPE_CHECKING:
    from wmr_mission.kernels.disturbances import Settings
    from wmr_mission.spec.models import Mission, Until

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

FORMS = {"bearing": 0, "deviation": 1, "increment": 2}
# [m] the smallest default look-ahead distance (the tracked point ahead of the axle).
MIN_LOOK_AHEAD = 0.05

# A position farther than this from every coordinate the mission names is a
# runaway, not a robot [m]: the threshold follows the mission's own scale, so a
# mission written in map coordinates (y = 5e6) runs like one near the origin.
RUNAWAY_DISTANCE = 1e6
# An input beyond this, whatever the limits say, is a runaway [m/s, rad/s]:
# no wheeled robot drives at 1 km/s or turns 160 times a second.
RUNAWAY_INPUT = 1e3


class Trajectory(Protocol):
    def sample(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]: ...


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
class CompiledPhase:
    name: str
    kind: str  # "track" | "regulate" | "hold"
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


@dataclass(frozen=True)
class CompiledMission:
    name: str
    dt: float
    initial_state: FloatArray
    initial_estimate: FloatArray
    # Actuator limits: |v|, |omega|, and rates (inf when absent).
    limits: FloatArray
    measure_mask: FloatArray
    noise_std: FloatArray
    seed: int
    estimator: str  # "constrained-observer" | "ekf"
    poles: FloatArray
    # [m] motion per sample below which one sample of measured positions says
    # little about an unmeasured heading: the measured positions' noise.
    heading_motion_floor: float
    lower_bounds: FloatArray
    upper_bounds: FloatArray
    use_bounds: bool
    max_iterations: int
    ekf_initial_var: FloatArray
    ekf_process_var: FloatArray
    ekf_measurement_var: FloatArray
    q: FloatArray
    r: FloatArray
    w: FloatArray
    m: FloatArray
    # Tracking: the look-ahead distance [m] (0 = the axle, literal eq. (27))
    # and the fraction of the output's error left after one sample.
    look_ahead: float
    error_decay: float
    regulation_form: int
    align_radius: float
    reverse: bool
    phases: tuple[CompiledPhase, ...]
    regions: dict[str, dict[str, object]]
    # Sample budget: the sum of each phase's bound, for pre-sizing the recorder.
    max_samples: int
    # |x|, |y| [m] and |v|, |omega| [m/s, rad/s] beyond which the run has diverged.
    runaway_position: float = RUNAWAY_DISTANCE
    runaway_input: float = RUNAWAY_INPUT
    ekf_innovation_gate: float = math.inf  # inf: no gating
    # The true plant's and the sensors' imperfections (wmr_mission.kernels.disturbances).
    disturbances: Settings = field(default_factory=lambda: _no_disturbances())


def _no_disturbances() -> Settings:
    # Imported on use: the disturbance kernels load numba, which validate never needs.
    from wmr_mission.kernels.disturbances import Settings

    return Settings()


def _disturbance_settings(mission: Mission) -> Settings:
    from wmr_mission.kernels.disturbances import settings

    return settings(mission)


def _samples(seconds: float, dt: float) -> int:
    return max(1, round(seconds / dt))


def _extent(mission: Mission, regions: dict[str, dict[str, object]]) -> float:
    """The largest coordinate magnitude the mission names [m]: start, estimate,
    regions (``regions`` dumped, less their rotation), targets, points, and
    each path's first point from the start pose."""
    from wmr_mission.geometry import paths

    start = mission.robot.initial_state
    guess = mission.estimator.initial_estimate or start
    numbers = [start.x, start.y, guess.x, guess.y]
    for region in regions.values():
        numbers += _numbers({key: value for key, value in region.items() if key != "rotation"})
    pose = (float(start.x), float(start.y), float(start.theta))
    from wmr_mission.spec.models import RegulatePhase, TrackPhase
    from wmr_mission.spec.repeats import run_order

    for phase in {run.where: run.phase for run in run_order(mission)}.values():
        if isinstance(phase, RegulatePhase):
            numbers += _numbers(phase.regulate.model_dump(mode="json"))
        if phase.until is not None and phase.until.near is not None:
            numbers += list(phase.until.near.point)
        if isinstance(phase, TrackPhase):
            trajectory = paths.instantiate(phase.track.path, mission, pose)
            x, y, _, _ = trajectory.sample(np.zeros(1))
            numbers += [float(x[0]), float(y[0])]
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
    params = np.ascontiguousarray(np.vstack([p[1] for p in parts]), dtype=np.float64)
    return kinds, params


def tracking_look_ahead(mission: Mission) -> float:
    """The tracked point's distance ahead of the axle [m]; 0 for the literal axle law.

    Unset, it is tied to the limits: ``max(0.05, limits.v * dt)``. The
    one-sample input sensitivity of the point has determinant
    ``dt^2 (l + v dt / 2)``, zero at ``v = -2 l / dt``; with ``l >= limits.v * dt``
    it stays within a factor 3 of ``l dt^2`` at every speed the limits allow
    (docs/paper-notes.md, eq. (27))."""
    tracking = mission.controller.tracking
    if tracking.output == "axle":
        return 0.0
    if tracking.look_ahead is not None:
        return float(tracking.look_ahead)
    return max(MIN_LOOK_AHEAD, float(mission.robot.limits.v) * float(mission.robot.dt))


def tracking_error_decay(mission: Mission) -> float:
    """Fraction of the tracked output's error left after one sample: 0 for the
    one-sample laws (``time_constant: 0``, and the literal axle law)."""
    tracking = mission.controller.tracking
    if tracking.output == "axle" or tracking.time_constant == 0:
        return 0.0
    return math.exp(-float(mission.robot.dt) / float(tracking.time_constant))


def sample_budget(mission: Mission) -> int:
    """The samples a run may take: each phase's bound (its timeout or elapsed
    time, 60 s without either) summed over the phases as run. Loads no kernel."""
    from wmr_mission.spec.repeats import run_order

    dt = float(mission.robot.dt)
    budget = 0
    for run in run_order(mission):
        phase = run.phase
        until = phase.until
        bounds = [
            b for b in (phase.timeout, None if until is None else until.elapsed) if b is not None
        ]
        budget += _samples(min(bounds), dt) + 1 if bounds else _samples(60.0, dt)
    return budget + 1


def _conditions(until: Until, mission: Mission, dt: float) -> Conditions:
    from wmr_mission.geometry import regions

    reaches_rows = no_rows()
    if until.reaches is not None:
        reaches_rows = regions.constraint_rows(mission.regions[until.reaches], "inside")
    return Conditions(
        elapsed_samples=None if until.elapsed is None else _samples(until.elapsed, dt),
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


def compile_mission(mission: Mission, seed: int | None = None) -> CompiledMission:
    """Turn a validated mission into the runner's plain form."""
    from wmr_mission.geometry import paths, regions
    from wmr_mission.spec.models import RegulatePhase, StayInside, TrackPhase
    from wmr_mission.spec.repeats import run_order

    dt = float(mission.robot.dt)
    phases: list[CompiledPhase] = []
    for run in run_order(mission):  # repeats written out, one phase per lap
        phase = run.phase
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
        if isinstance(phase, TrackPhase):
            kind = "track"
            path = phase.track.path
            points = paths.drawn_points(path, mission)

            def make_trajectory(
                pose: tuple[float, float, float], _path: object = path
            ) -> Trajectory:
                return paths.instantiate(_path, mission, pose)  # type: ignore[arg-type]

        elif isinstance(phase, RegulatePhase):
            kind = "regulate"
            goal = phase.regulate.target
            target = (float(goal.x), float(goal.y), float(goal.theta))
        phases.append(
            CompiledPhase(
                name=run.label,
                lap=run.lap,
                points=points,
                kind=kind,
                until=_conditions(phase.until, mission, dt),
                timeout_samples=None if phase.timeout is None else _samples(phase.timeout, dt),
                fail_on_timeout=phase.on_timeout == "fail",
                make_trajectory=make_trajectory,
                target=target,
                constraint_rows=_stack_rows(row_parts),
                constraints=tuple(constraints),
                color=mission.plot.phase_colors.get(phase.name),  # every lap of a repeat
            )
        )
    estimator = mission.estimator
    sensors = mission.sensors
    mask = measurement_mask(sensors.measure)
    noise = np.array([sensors.noise_std.x, sensors.noise_std.y, sensors.noise_std.theta])
    lower = np.full(3, -math.inf)
    upper = np.full(3, math.inf)
    poles = np.full(3, 0.9)
    use_bounds = False
    max_iterations = 0
    initial_var = np.ones(3)
    process_var = np.zeros(3)
    measurement_var = np.maximum(noise, 1e-3) ** 2
    innovation_gate = math.inf
    if estimator.type == "constrained-observer":
        poles = np.array([estimator.poles.x, estimator.poles.y, estimator.poles.theta])
        if estimator.output_error_bounds:
            use_bounds = True
            for name, (lo, hi) in estimator.output_error_bounds.items():
                i = STATE_NAMES.index(name)
                lower[i] = lo
                upper[i] = hi
        max_iterations = estimator.max_iterations
    else:
        initial_var = (
            np.array(
                [estimator.initial_std.x, estimator.initial_std.y, estimator.initial_std.theta]
            )
            ** 2
        )
        process_var = (
            np.array(
                [estimator.process_std.x, estimator.process_std.y, estimator.process_std.theta]
            )
            ** 2
        )
        if estimator.measurement_std is not None:
            for name, std in estimator.measurement_std.items():
                measurement_var[STATE_NAMES.index(name)] = std * std  # not pow(): exact
        if estimator.innovation_gate is not None:
            innovation_gate = float(estimator.innovation_gate)
    limits = mission.robot.limits
    controller = mission.controller
    initial = mission.robot.initial_state
    guess = initial if estimator.initial_estimate is None else estimator.initial_estimate
    dumped_regions = {name: r.model_dump(mode="json") for name, r in mission.regions.items()}
    return CompiledMission(
        name=mission.name,
        dt=dt,
        initial_state=np.array([initial.x, initial.y, initial.theta], dtype=np.float64),
        initial_estimate=np.array([guess.x, guess.y, guess.theta], dtype=np.float64),
        limits=np.array(
            [
                limits.v,
                limits.omega,
                math.inf if limits.v_rate is None else limits.v_rate,
                math.inf if limits.omega_rate is None else limits.omega_rate,
            ]
        ),
        measure_mask=mask,
        noise_std=noise,
        seed=sensors.seed if seed is None else seed,
        estimator=estimator.type,
        poles=poles,
        heading_motion_floor=float((noise[:2] * mask[:2]).max()),
        lower_bounds=lower,
        upper_bounds=upper,
        use_bounds=use_bounds,
        max_iterations=max_iterations,
        ekf_initial_var=initial_var,
        ekf_process_var=process_var,
        ekf_measurement_var=measurement_var,
        ekf_innovation_gate=innovation_gate,
        disturbances=_disturbance_settings(mission),
        q=np.array(controller.Q, dtype=np.float64),
        r=np.array(controller.R, dtype=np.float64),
        w=np.array(controller.W, dtype=np.float64),
        m=np.array(controller.M, dtype=np.float64),
        look_ahead=tracking_look_ahead(mission),
        error_decay=tracking_error_decay(mission),
        regulation_form=FORMS[controller.regulation.form],
        align_radius=controller.regulation.align_radius,
        reverse=controller.regulation.reverse,
        phases=tuple(phases),
        regions=dumped_regions,
        max_samples=sample_budget(mission),
        runaway_position=RUNAWAY_DISTANCE + _extent(mission, dumped_regions),
    )
