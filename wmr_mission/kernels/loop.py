"""The fixed-step loop, compiled: one call runs a phase for a chunk of samples.

Per sample k, as in the paper's algorithm: the phase checks its exit
conditions on the estimate x_{k|k}; its controller computes u_k (Case 1 or
Case 2 of section III.C); the plant moves to x_{k+1} (eq. (1)); the sensors
measure it; the estimator produces x_{k+1|k+1} (eqs. (4)-(12), or the EKF);
the sample is recorded. All of it runs inside :func:`run_segment`, which
returns to Python (wmr_mission.sim.runner) only when

* an exit condition of the phase holds (``EXITED``; the runner enters the
  next phase and calls again at the same sample),
* the run diverged (``DIVERGED_INPUT``, ``DIVERGED_STATE``),
* or the chunk is done (``CHUNK_END``): ``stop`` reached, or a buffer the
  runner fills ran out: the path block, the pre-drawn random draws (noise and
  disturbances, wmr_mission.kernels.disturbances), the recorder.

Between chunks the runner reports progress and lets Ctrl-C in. The same
source runs as plain Python without numba, and with the reference step
(wmr_mission.sim.reference) in place of the fast kernels
(wmr_mission.kernels.jit.plain).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.kernels.corrective import max_row_value
from wmr_mission.kernels.disturbances import Actuation, Sensing, applied_input, plant_step, sense
from wmr_mission.kernels.jit import inlined, kernel, ticks
from wmr_mission.kernels.model import hypot, wrap_angle
from wmr_mission.kernels.records import Plant
from wmr_mission.kernels.variants import control_step, estimator_step

# Why run_segment returned.
CHUNK_END = 0
EXITED = 1
DIVERGED_INPUT = 2
DIVERGED_STATE = 3

# Exit conditions, in the order they are checked (Signals.counters[CONDITION]).
CONDITIONS = ("", "elapsed", "mission_time", "reaches", "near", "settled", "heading", "timeout")
ELAPSED, MISSION_TIME, REACHES, NEAR, SETTLED, HEADING, TIMEOUT = range(1, 8)

# Fields of Signals.counters.
K = 0  # the sample the loop is at
ITERATIONS = 1  # phase-II iterations of the estimator's last update
DRAWS = 2  # next unused row of the block of draws
CONDITION = 3  # the exit condition that fired
CLOCK = 4  # ticks() as the call returned: Python reads the clock without calling it


class EnteredPhase(NamedTuple):
    """A phase as the loop runs it, from the sample it was entered at; absent
    conditions are -1 or NaN."""

    number: int  # index in the mission's phases
    tracking: bool  # a path to follow (PathBlock); else a pose to reach
    entry_sample: int
    target: FloatArray  # (3,) the pose a regulate or hold phase parks at
    constraint_kinds: IntArray  # constraint rows (docs/architecture.md)
    constraint_params: FloatArray
    # per constraint row, a track phase's way round a keep-out ellipse, decided
    # at its entry (wmr_mission.controllers.constrained_tracking.ways_round)
    ways_round: FloatArray
    elapsed_samples: int
    mission_time: float  # [s]
    reaches_kinds: IntArray  # rows of the region of `reaches`
    reaches_params: FloatArray
    reaches_sign: float  # sign of the region's value at entry: the side it starts on
    near: FloatArray  # (3,) x, y, tolerance
    settled: FloatArray  # (3,) position, heading, speed tolerances
    heading: FloatArray  # (2,) target, tolerance
    timeout_samples: int


class PathBlock(NamedTuple):
    """The path of a track phase, sampled ahead by the runner."""

    start: int  # phase-local sample of row 0
    # (n, 4) x, y, unit tangent x, y (NaN where the path rests); (n, 8) under a
    # turn-rate acceleration limit: the same, then the path as previewed
    rows: FloatArray


class Signals(NamedTuple):
    """What the loop carries from one sample to the next, and across calls."""

    state: FloatArray  # (3,) the plant's true pose
    estimate: FloatArray  # (3,) x_{k|k}
    estimate_prev: FloatArray  # (3,) x_{k-1|k-1}
    measurement: FloatArray  # (3,) the newest measurement
    measured: FloatArray  # (3,) the measurement of the sample being recorded (NaN: none)
    u: FloatArray  # (2,) u_k
    u_prev: FloatArray  # (2,) u_{k-1}
    aim_now: FloatArray  # (8,) path point and unit tangent at t_k (tracking), then previewed
    aim: FloatArray  # (8,) the same at t_{k+1}, the point the controller aims at
    # The controller's memory within a phase (wmr_mission.controllers.registry);
    # zeroed at phase entry.
    memory: FloatArray
    # (4,) the tangent a resting path keeps (path_point), then the previewed
    # path's; NaN at phase entry: none yet.
    held: FloatArray
    counters: IntArray  # K, ITERATIONS, DRAWS, CONDITION, CLOCK
    exit_value: FloatArray  # (1,) the value of the condition that fired
    commands: FloatArray  # (d + 1, 2) the last commands, for the input delay
    applied: FloatArray  # (2,) the input the plant applies (delayed, lagged)
    burst: IntArray  # (1,) 1 while a burst of lost measurements goes on


class Recording(NamedTuple):
    """Pre-sized columns, one row per sample; ``rows[0]`` rows are used."""

    floats: FloatArray  # (capacity, len(FLOAT_COLUMNS))
    phase: IntArray
    iterations: IntArray
    compute: IntArray  # ticks of the step (see wmr_mission.kernels.jit.ticks)
    rows: IntArray  # (1,) rows used


# The recording's float columns, as record_sample writes them (named as the
# run's arrays, wmr_mission.record): time, state, estimate and input,
# then the path point, the constraint value and the measurement.
FLOAT_COLUMNS = (
    "t",
    "x",
    "y",
    "theta",
    "x_est",
    "y_est",
    "theta_est",
    "v",
    "omega",
    "x_ref",
    "y_ref",
    "constraint",
    "x_meas",
    "y_meas",
    "theta_meas",
)


@inlined
def exit_condition(
    phase: EnteredPhase, k: int, dt: float, estimate: FloatArray, speed: float, value: FloatArray
) -> int:
    """The first exit condition of ``phase`` that holds at sample k (0: none);
    its value goes to ``value[0]``."""
    local = k - phase.entry_sample
    x = estimate[0]
    y = estimate[1]
    theta = estimate[2]
    if phase.elapsed_samples >= 0 and local >= phase.elapsed_samples:
        value[0] = local
        return ELAPSED
    if k * dt >= phase.mission_time - 0.5 * dt:  # False for NaN: no such condition
        value[0] = k
        return MISSION_TIME
    if phase.reaches_kinds.shape[0]:
        reached = max_row_value(phase.reaches_kinds, phase.reaches_params, x, y)
        if reached == 0.0 or math.copysign(1.0, reached) != phase.reaches_sign:
            value[0] = reached
            return REACHES
    if phase.near[2] == phase.near[2]:
        distance = hypot(x - phase.near[0], y - phase.near[1])
        if distance <= phase.near[2]:
            value[0] = distance
            return NEAR
    if phase.settled[0] == phase.settled[0]:
        distance = hypot(x - phase.target[0], y - phase.target[1])
        if (
            distance <= phase.settled[0]
            and abs(wrap_angle(theta - phase.target[2])) <= phase.settled[1]
            and abs(speed) <= phase.settled[2]
        ):
            value[0] = distance
            return SETTLED
    if phase.heading[0] == phase.heading[0]:
        error = abs(wrap_angle(theta - phase.heading[0]))
        if error <= phase.heading[1]:
            value[0] = error
            return HEADING
    if phase.timeout_samples >= 0 and local >= phase.timeout_samples:
        value[0] = local
        return TIMEOUT
    return 0


@kernel
def record_sample(
    record: Recording,
    phase: EnteredPhase,
    t: float,
    x: float,
    y: float,
    theta: float,
    estimate: FloatArray,
    u: FloatArray,
    reference_x: float,
    reference_y: float,
    iterations: int,
    measured: FloatArray,
) -> int:
    """Append one row; returns its index. ``estimate``, ``u`` and ``measured``
    are read now."""
    i: int = record.rows[0]
    row = record.floats[i]
    row[0] = t
    row[1] = x
    row[2] = y
    row[3] = theta
    row[4] = estimate[0]
    row[5] = estimate[1]
    row[6] = estimate[2]
    row[7] = u[0]
    row[8] = u[1]
    row[9] = reference_x
    row[10] = reference_y
    if phase.constraint_kinds.shape[0]:
        row[11] = max_row_value(phase.constraint_kinds, phase.constraint_params, x, y)
    else:
        row[11] = math.nan
    row[12] = measured[0]
    row[13] = measured[1]
    row[14] = measured[2]
    record.phase[i] = phase.number
    record.iterations[i] = iterations
    record.compute[i] = 0
    # Counted once whole: a stop inside a sample (plain Python) leaves no half row.
    record.rows[0] = i + 1
    return i


@kernel
def path_point(
    rows: FloatArray, row: int, heading: float, held: FloatArray, out: FloatArray
) -> None:
    """Point and unit tangent of the path block's ``row`` into ``out``. A path
    at rest has no tangent: the one it last moved along stands in (``held``,
    kept there), or the robot's ``heading`` where the path has rested since
    the phase began, held from then (docs/paper-notes.md, eq. (27), "A
    resting path's tangent held")."""
    out[0] = rows[row, 0]
    out[1] = rows[row, 1]
    if rows[row, 2] != rows[row, 2]:
        if held[0] != held[0]:
            held[0] = math.cos(heading)
            held[1] = math.sin(heading)
        out[2] = held[0]
        out[3] = held[1]
    else:
        out[2] = held[0] = rows[row, 2]
        out[3] = held[1] = rows[row, 3]


@kernel
def first_tangent(aim_now: FloatArray, aim: FloatArray, most_turn: float) -> None:
    """At a track phase's first sample: where the path's tangent turns from
    t_0 to t_1 by more than ``most_turn`` (the robot's turn in a sample at its
    turn-rate limit), the tangent at t_1 stands for t_0's in ``aim_now``. The
    piece whose tangent that was is left within the sample: a route joined
    from the robot's estimate to a first point a hair away (a lap entered
    where the lap before rested) starts with a leg of micrometres along the
    estimate's error (docs/paper-notes.md, eq. (27), "at a phase's first
    sample: a tangent left within it")."""
    cross = aim_now[2] * aim[3] - aim_now[3] * aim[2]
    dot = aim_now[2] * aim[2] + aim_now[3] * aim[3]
    if abs(math.atan2(cross, dot)) > most_turn:
        aim_now[2] = aim[2]
        aim_now[3] = aim[3]


def run_segment(
    plant: Plant,
    actuation: Actuation,
    sensing: Sensing,
    estimator: Any,
    estimator_memory: Any,
    controller: Any,
    scratch: Any,
    phase: EnteredPhase,
    path: PathBlock,
    draws: FloatArray,
    signals: Signals,
    record: Recording,
    stop: int,
) -> int:
    """Run ``phase`` from sample ``signals.counters[K]`` up to ``stop``; returns
    why it stopped (CHUNK_END, EXITED, DIVERGED_INPUT, DIVERGED_STATE).

    ``estimator`` and ``controller`` are the tuning records of the mission's
    estimator and controller (their types choose the steps run,
    wmr_mission.kernels.variants), ``estimator_memory`` and ``scratch`` their
    working arrays."""
    dt = plant.dt
    state = signals.state
    estimate = signals.estimate
    estimate_prev = signals.estimate_prev
    measurement = signals.measurement
    u = signals.u
    u_prev = signals.u_prev
    counters = signals.counters
    aim_now = signals.aim_now
    aim = signals.aim
    capacity = record.floats.shape[0]
    k = counters[K]
    iterations = counters[ITERATIONS]
    cursor = counters[DRAWS]
    status = CHUNK_END
    while k < stop:
        # --- phase exit on x_{k|k}.
        condition = exit_condition(phase, k, dt, estimate, u_prev[0], signals.exit_value)
        if condition != 0:
            counters[CONDITION] = condition
            status = EXITED
            break
        # Room for this sample (and a closing row), its draws, its path.
        if record.rows[0] + 2 > capacity or cursor >= draws.shape[0]:
            break
        reference_x = math.nan
        reference_y = math.nan
        if phase.tracking:
            row = k - phase.entry_sample - path.start
            if row + 1 >= path.rows.shape[0]:
                break
            # The path point at t_k is recorded; the controller aims at t_{k+1}'s.
            reference_x = path.rows[row, 0]
            reference_y = path.rows[row, 1]
            held = signals.held
            path_point(path.rows, row, estimate[2], held, aim_now)
            path_point(path.rows, row + 1, estimate[2], held, aim)
            if path.rows.shape[1] > 4:  # the path as previewed too (sim.runner.previewed)
                path_point(path.rows[:, 4:], row, estimate[2], held[2:], aim_now[4:])
                path_point(path.rows[:, 4:], row + 1, estimate[2], held[2:], aim[4:])
            if k == phase.entry_sample:  # a tangent the path leaves within the sample
                first_tangent(aim_now, aim, plant.limits[1] * dt)
                if path.rows.shape[1] > 4:
                    first_tangent(aim_now[4:], aim[4:], plant.limits[1] * dt)
        x = state[0]
        y = state[1]
        theta = state[2]
        started = ticks()
        # --- controller: u_k from x_{k|k}.
        control_step(
            controller, phase, aim_now, aim, estimate, estimate_prev, u_prev, plant,
            signals.memory, scratch, u,
        )  # fmt: skip
        if not (abs(u[0]) <= plant.runaway_input and abs(u[1]) <= plant.runaway_input):  # NaN too
            spent = ticks() - started
            i = record_sample(
                record, phase, k * dt, x, y, theta, estimate, u, reference_x, reference_y,
                iterations, signals.measured,
            )  # fmt: skip
            record.compute[i] = spent
            status = DIVERGED_INPUT
            break
        # --- plant and sensors, disturbed (wmr_mission.kernels.disturbances).
        drawn = draws[cursor]
        cursor += 1
        applied_input(actuation, k, u, signals.commands, signals.applied)
        plant_step(state, signals.applied, dt, actuation, drawn)
        has_measurement = sense(state, k + 1, sensing, drawn, signals.burst, measurement)
        # --- estimator: x_{k+1|k+1}; the row of sample k keeps x_{k|k}.
        ex = estimate[0]
        ey = estimate[1]
        eth = estimate[2]
        estimate_prev[0] = ex
        estimate_prev[1] = ey
        estimate_prev[2] = eth
        recorded_iterations = iterations
        iterations = estimator_step(
            estimator, estimator_memory, estimate, u[0], u[1], dt, measurement, has_measurement
        )
        spent = ticks() - started
        i = record_sample(
            record, phase, k * dt, x, y, theta, estimate_prev, u, reference_x, reference_y,
            recorded_iterations, signals.measured,
        )  # fmt: skip
        record.compute[i] = spent
        for n in range(3):
            signals.measured[n] = (
                measurement[n] if has_measurement and sensing.measured[n] > 0.0 else math.nan
            )
        u_prev[0] = u[0]
        u_prev[1] = u[1]
        k += 1
        if not (
            abs(state[0]) < plant.runaway_position and abs(state[1]) < plant.runaway_position
            and math.isfinite(state[2])
            and abs(estimate[0]) < plant.runaway_position
            and abs(estimate[1]) < plant.runaway_position
            and math.isfinite(estimate[2])
        ):  # fmt: skip
            record_sample(
                record, phase, k * dt, state[0], state[1], state[2], estimate, u_prev,
                math.nan, math.nan, iterations, signals.measured,
            )  # fmt: skip
            status = DIVERGED_STATE
            break
    counters[K] = k
    counters[ITERATIONS] = iterations
    counters[DRAWS] = cursor
    counters[CLOCK] = ticks()
    return status
