"""The phase state machine and the fixed-step loop.

Per sample k, as in the paper's algorithm: the active phase checks its exit
conditions on the estimate x_{k|k}; its controller computes u_k (Case 1 or
Case 2 of section III.C); the plant moves to x_{k+1} (eq. (1)); the sensors
measure it; the estimator produces x_{k+1|k+1} (eqs. (4)-(12), or the EKF).
The controller sees only estimates; the true state is for the record.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from wmr_mission import control
from wmr_mission.compiled import CompiledMission, CompiledPhase, Trajectory, compile_mission
from wmr_mission.constrained_tracking import keep_constraints, keep_reference
from wmr_mission.corrective import max_row_value
from wmr_mission.ekf import ekf_step
from wmr_mission.model import step, wrap_angle
from wmr_mission.observer import observer_step
from wmr_mission.result import (
    EXTRA_COLUMNS,
    TRAJECTORY_COLUMNS,
    Outcome,
    PhaseInfo,
    RunResult,
    Transition,
)
from wmr_mission.sensors import Sensors

if TYPE_CHECKING:
    from wmr_mission.spec.models import Mission

FloatArray = NDArray[np.float64]

# Reference samples computed per path evaluation (paths are vectorised in t).
REFERENCE_BLOCK = 1024
PROGRESS_EVERY = 2000


class Status(StrEnum):
    pending = "pending"
    running = "running"
    done = "done"
    timed_out = "timed-out"


class Recorder:
    """Pre-sized columns, one row per sample; grows by doubling if a run
    outlasts its estimate. Sees every step; the kernels never log."""

    # The float columns of trajectory.csv, in its order (phase and iterations are kept apart).
    FLOAT_COLUMNS = tuple(
        c for c in (*TRAJECTORY_COLUMNS, *EXTRA_COLUMNS) if c not in ("phase", "phase2_iterations")
    )

    def __init__(self, capacity: int) -> None:
        capacity = max(16, min(capacity, 2_000_000))
        self.floats = np.full((capacity, len(self.FLOAT_COLUMNS)), math.nan)
        self.phase = np.zeros(capacity, dtype=np.int64)
        self.iterations = np.zeros(capacity, dtype=np.int64)
        self.compute_ns = np.zeros(capacity, dtype=np.int64)
        self.count = 0

    def row(self) -> int:
        if self.count == self.floats.shape[0]:
            grow = self.floats.shape[0]
            self.floats = np.vstack([self.floats, np.full((grow, self.floats.shape[1]), math.nan)])
            self.phase = np.concatenate([self.phase, np.zeros(grow, dtype=np.int64)])
            self.iterations = np.concatenate([self.iterations, np.zeros(grow, dtype=np.int64)])
            self.compute_ns = np.concatenate([self.compute_ns, np.zeros(grow, dtype=np.int64)])
        self.count += 1
        return self.count - 1

    def column(self, name: str) -> FloatArray:
        return self.floats[: self.count, self.FLOAT_COLUMNS.index(name)].copy()


def _seconds(samples: int, dt: float) -> float:
    """``samples * dt`` without its rounding tail (53.48, not 53.480000000000004),
    for the times people read in transitions.json."""
    return round(samples * dt, 9)


class ActivePhase:
    """One phase's lifecycle: ``enter`` at its first sample, ``control`` and
    ``check`` every sample, ``status`` says where it is."""

    def __init__(self, phase: CompiledPhase, mission: CompiledMission, index: int) -> None:
        self.phase = phase
        self.mission = mission
        self.index = index
        self.status = Status.pending
        self.entry_sample = 0
        self.target = np.zeros(3)
        self.memory = np.zeros(3)
        self.reference = np.zeros(4)
        self._trajectory: Trajectory | None = None
        self._block = np.zeros((0, 4))
        self._block_start = 0
        self._reaches_sign = 0.0

    def enter(self, k: int, estimate: FloatArray) -> None:
        self.status = Status.running
        self.entry_sample = k
        self.memory[:] = 0.0
        pose = (float(estimate[0]), float(estimate[1]), float(estimate[2]))
        if self.phase.kind == "track":
            assert self.phase.make_trajectory is not None
            self._trajectory = self.phase.make_trajectory(pose)
            self._block = np.zeros((0, 4))
        target = self.phase.target if self.phase.target is not None else pose
        self.target[:] = target
        kinds, params = self.phase.until.reaches_rows
        if kinds.shape[0]:
            self._reaches_sign = math.copysign(1.0, max_row_value(kinds, params, pose[0], pose[1]))

    def reference_at(self, local_sample: int, heading: float) -> FloatArray:
        """Path point and unit tangent at phase-local sample ``local_sample``."""
        offset = local_sample - self._block_start
        if offset < 0 or offset >= self._block.shape[0]:
            assert self._trajectory is not None
            self._block_start = local_sample
            t = (local_sample + np.arange(REFERENCE_BLOCK, dtype=np.float64)) * self.mission.dt
            x, y, dx, dy = self._trajectory.sample(t)
            speed = np.hypot(dx, dy)
            moving = speed > 1e-12
            safe = np.where(moving, speed, 1.0)
            self._block = np.column_stack(
                [x, y, np.where(moving, dx / safe, np.nan), np.where(moving, dy / safe, np.nan)]
            )
            offset = 0
        row = self._block[offset]
        self.reference[0] = row[0]
        self.reference[1] = row[1]
        if math.isnan(row[2]):
            # A path at rest has no tangent: keep the robot's heading.
            self.reference[2] = math.cos(heading)
            self.reference[3] = math.sin(heading)
        else:
            self.reference[2] = row[2]
            self.reference[3] = row[3]
        return self.reference

    def check(self, k: int, estimate: FloatArray, speed: float) -> tuple[str, float] | None:
        """The first exit condition that holds at sample k, with its value."""
        until = self.phase.until
        local = k - self.entry_sample
        dt = self.mission.dt
        x, y, theta = float(estimate[0]), float(estimate[1]), float(estimate[2])
        if until.elapsed_samples is not None and local >= until.elapsed_samples:
            return "elapsed", _seconds(local, dt)
        if until.mission_time is not None and k * dt >= until.mission_time - 0.5 * dt:
            return "mission_time", _seconds(k, dt)
        kinds, params = until.reaches_rows
        if kinds.shape[0]:
            value = max_row_value(kinds, params, x, y)
            if value == 0.0 or math.copysign(1.0, value) != self._reaches_sign:
                return "reaches", value
        if until.near is not None:
            distance = math.hypot(x - until.near[0], y - until.near[1])
            if distance <= until.near[2]:
                return "near", distance
        if until.settled is not None:
            distance = math.hypot(x - self.target[0], y - self.target[1])
            heading_error = abs(wrap_angle(theta - self.target[2]))
            if (
                distance <= until.settled[0]
                and heading_error <= until.settled[1]
                and abs(speed) <= until.settled[2]
            ):
                return "settled", distance
        if until.heading is not None:
            error = abs(wrap_angle(theta - until.heading[0]))
            if error <= until.heading[1]:
                return "heading", error
        if self.phase.timeout_samples is not None and local >= self.phase.timeout_samples:
            return "timeout", _seconds(local, dt)
        return None


@dataclass
class _Estimator:
    mission: CompiledMission
    functions: StepFunctions
    covariance: FloatArray
    gain: FloatArray
    work: FloatArray

    def update(self, estimate: FloatArray, u: FloatArray, measurement: FloatArray) -> int:
        m = self.mission
        if m.estimator == "ekf":
            self.functions.ekf_step(
                estimate,
                self.covariance,
                u[0],
                u[1],
                m.dt,
                measurement,
                m.measure_mask,
                m.ekf_process_var,
                m.ekf_measurement_var,
                self.work,
            )
            return 0
        return int(
            self.functions.observer_step(
                estimate,
                u[0],
                u[1],
                m.dt,
                measurement,
                m.measure_mask,
                m.poles,
                m.heading_motion_floor,
                m.lower_bounds,
                m.upper_bounds,
                m.use_bounds,
                m.max_iterations,
                self.gain,
            )
        )


ProgressCallback = Callable[[float, float, str], None]


@dataclass(frozen=True)
class StepFunctions:
    """The per-sample estimator and controller functions the loop calls.

    ``FAST`` are the compiled kernels; ``wmr_mission.reference.REFERENCE``
    holds straightforward numpy/scipy versions with the same signatures, used
    as the oracle in tests and by ``wmr-mission bench``.
    """

    observer_step: Callable[..., int]
    ekf_step: Callable[..., None]
    track_input: Callable[..., None]
    regulate_input: Callable[..., None]


FAST = StepFunctions(observer_step, ekf_step, control.track_input, control.regulate_input)


def run_mission(
    mission: Mission | CompiledMission,
    *,
    seed: int | None = None,
    progress: ProgressCallback | None = None,
    functions: StepFunctions = FAST,
) -> RunResult:
    """Simulate ``mission`` and return every sample as arrays.

    A :class:`Mission` is checked first exactly as a mission file is (raises
    ``MissionError``), and the run is judged by its ``expect`` thresholds, as
    ``wmr-mission run`` does. ``progress(t, t_budget, phase_name)`` is called
    every few thousand samples. The run stops cleanly on a timeout with
    ``on_timeout: fail`` and on divergence; what was produced up to then is in
    the result.
    """
    if isinstance(mission, CompiledMission):
        compiled = mission if seed is None else replace(mission, seed=seed)
        return _Run(compiled, progress, functions).run()
    from wmr_mission.output.metrics import judge
    from wmr_mission.spec.loader import validate_mission

    checked = validate_mission(mission)
    result = _Run(compile_mission(checked, seed), progress, functions).run()
    resolved = checked.model_dump(mode="json")
    resolved["sensors"]["seed"] = result.seed  # the mission as run
    result.mission = resolved
    judge(result, resolved)  # a success that misses an `expect` is not one
    return result


class _Run:
    def __init__(
        self, mission: CompiledMission, progress: ProgressCallback | None, functions: StepFunctions
    ) -> None:
        self.m = mission
        self.progress = progress
        self.functions = functions
        self.recorder = Recorder(mission.max_samples)
        self.transitions: list[Transition] = []
        self.phases = [ActivePhase(p, mission, i) for i, p in enumerate(mission.phases)]

    def run(self) -> RunResult:
        try:
            return self._loop()
        except KeyboardInterrupt:  # SIGINT, or SIGTERM mapped to it by the command
            return self._interrupted()

    def _interrupted(self) -> RunResult:
        """The samples recorded up to the stop; a row the stop cut short is dropped."""
        recorder = self.recorder
        if recorder.count and not np.all(np.isfinite(recorder.floats[recorder.count - 1, :9])):
            recorder.count -= 1
        last = recorder.count - 1
        active = self.phases[int(recorder.phase[last]) if last >= 0 else 0]
        t = round(float(recorder.floats[last, 0]), 9) if last >= 0 else 0.0
        self.transitions.append(Transition(t, active.phase.name, None, "interrupted", math.nan))
        return self._result(
            Outcome.interrupted, f"interrupted in phase '{active.phase.name}' at t = {t:.6g} s"
        )

    def _loop(self) -> RunResult:
        m = self.m
        dt = m.dt
        state = m.initial_state.copy()
        estimate = m.initial_estimate.copy()
        estimate_prev = estimate.copy()
        measurement = np.zeros(3)
        u = np.zeros(2)
        u_prev = np.zeros(2)
        sensors = Sensors(m.noise_std, m.seed)
        estimator = _Estimator(
            m,
            self.functions,
            np.diag(m.ekf_initial_var).astype(np.float64),
            np.zeros((3, 3)),
            np.zeros((4, 3, 3)),
        )
        work = control.make_workspace()
        path_now = np.zeros(4)  # the path at t_k; the tracking law aims at t_{k+1}'s
        self._warm_up(estimator, estimate, measurement)
        recorder = self.recorder
        outcome = Outcome.success
        message = "all phases completed"
        index = 0
        active = self.phases[0]
        active.enter(0, estimate)
        k = 0
        iterations = 0
        budget = m.max_samples * dt
        while True:
            # --- phase transitions on x_{k|k} (several may fire at one sample).
            fired = active.check(k, estimate, u_prev[0])
            ended = False
            while fired is not None:
                condition, value = fired
                if condition == "timeout" and active.phase.fail_on_timeout:
                    active.status = Status.timed_out
                    self.transitions.append(
                        Transition(_seconds(k, dt), active.phase.name, None, condition, value)
                    )
                    outcome = Outcome.timeout
                    message = (
                        f"phase '{active.phase.name}' timed out after {value:.6g} s "
                        f"at t = {k * dt:.6g} s"
                    )
                    ended = True
                    break
                active.status = Status.done
                index += 1
                to = self.phases[index] if index < len(self.phases) else None
                self.transitions.append(
                    Transition(
                        _seconds(k, dt),
                        active.phase.name,
                        None if to is None else to.phase.name,
                        condition,
                        float(value),
                        None if to is None else to.phase.lap,
                    )
                )
                if to is None:
                    ended = True
                    break
                active = to
                active.enter(k, estimate)
                fired = active.check(k, estimate, u_prev[0])
            if ended:
                self._record(k, state, estimate, u_prev, active, iterations, 0, None, measurement)
                break
            # --- controller: u_k from x_{k|k}. The path is an input, looked up
            # before the clock starts; controller + estimator are timed.
            phase = active.phase
            reference = None
            if phase.kind == "track":
                local = k - active.entry_sample
                path_now[:] = active.reference_at(local, float(estimate[2]))
                reference_now = (float(path_now[0]), float(path_now[1]))
                reference = active.reference_at(local + 1, float(estimate[2]))
                kinds, params = phase.constraint_rows
                if kinds.shape[0]:  # aim along a zone's edge where the path crosses it
                    keep_reference(path_now, kinds, params, m.look_ahead)
                    keep_reference(reference, kinds, params, m.look_ahead)
            started = time.perf_counter_ns()
            if reference is not None:
                self.functions.track_input(
                    estimate, u_prev, path_now, reference, m.look_ahead, m.error_decay,
                    m.w, m.m, m.limits, dt, work, u,
                )  # fmt: skip
                if kinds.shape[0]:  # zones win over tracking: eq. (28) with priority
                    keep_constraints(
                        estimate, u_prev, kinds, params, m.look_ahead, m.limits, dt, work, u
                    )
            else:
                kinds, params = phase.constraint_rows
                self.functions.regulate_input(
                    estimate,
                    estimate_prev,
                    u_prev,
                    active.target,
                    m.regulation_form,
                    m.align_radius,
                    m.reverse,
                    m.q,
                    m.r,
                    m.w,
                    m.m,
                    kinds,
                    params,
                    m.limits,
                    dt,
                    active.memory,
                    work,
                    u,
                )
            control_ns = time.perf_counter_ns() - started
            self._record(
                k,
                state,
                estimate,
                u,
                active,
                iterations,
                control_ns,
                reference_now if reference is not None else None,
                measurement,
            )
            if not (abs(u[0]) <= m.runaway_input and abs(u[1]) <= m.runaway_input):  # NaN too
                if math.isfinite(u[0]) and math.isfinite(u[1]):
                    cause = (
                        f"the input ran away (v = {u[0]:.3g} m/s, omega = {u[1]:.3g} rad/s; "
                        f"beyond {m.runaway_input:g} is no robot's)"
                    )
                else:
                    cause = "the input is not finite"
                outcome, message = self._diverged(k, active, cause)
                break
            # --- plant, sensors, estimator.
            state[0], state[1], state[2] = step(state[0], state[1], state[2], u[0], u[1], dt)
            sensors.measure(state, measurement)
            estimate_prev[:] = estimate
            started = time.perf_counter_ns()
            iterations = estimator.update(estimate, u, measurement)
            recorder.compute_ns[recorder.count - 1] += time.perf_counter_ns() - started
            u_prev[:] = u
            k += 1
            if not (
                abs(state[0]) < m.runaway_position and abs(state[1]) < m.runaway_position
                and math.isfinite(state[2])
                and abs(estimate[0]) < m.runaway_position
                and abs(estimate[1]) < m.runaway_position
                and math.isfinite(estimate[2])
            ):  # fmt: skip
                self._record(k, state, estimate, u_prev, active, iterations, 0, None, measurement)
                cause = (
                    f"the state ran away (x = {state[0]:.3g} m, y = {state[1]:.3g} m; "
                    f"last input v = {u[0]:.3g} m/s, omega = {u[1]:.3g} rad/s)"
                )
                outcome, message = self._diverged(k, active, cause)
                break
            if self.progress is not None and k % PROGRESS_EVERY == 0:
                self.progress(k * dt, budget, phase.name)
        return self._result(outcome, message)

    def _warm_up(
        self, estimator: _Estimator, estimate: FloatArray, measurement: FloatArray
    ) -> None:
        """Call each kernel the mission uses once, on scratch copies, before the
        clock runs: a compiled kernel's first call loads it from numba's disk
        cache (milliseconds), a start-up cost, not a per-sample one."""
        if self.functions is not FAST:
            return
        scratch = _Estimator(
            self.m,
            self.functions,
            estimator.covariance.copy(),
            estimator.gain.copy(),
            estimator.work.copy(),
        )
        u = np.zeros(2)
        scratch.update(estimate.copy(), u, measurement.copy())
        m = self.m
        work = control.make_workspace()
        warmed: set[bool] = set()  # one call per controller: tracking, regulating
        for active in self.phases:
            phase = active.phase
            regulating = phase.kind != "track"
            if regulating in warmed:
                continue
            warmed.add(regulating)
            if not regulating:
                self.functions.track_input(
                    estimate.copy(), u.copy(), np.zeros(4), np.zeros(4), m.look_ahead,
                    m.error_decay, m.w, m.m, m.limits, m.dt, work, np.zeros(2),
                )  # fmt: skip
                kinds, params = phase.constraint_rows
                keep_constraints(
                    estimate.copy(), u.copy(), kinds, params, m.look_ahead, m.limits, m.dt, work,
                    np.zeros(2),
                )  # fmt: skip
            else:
                kinds, params = phase.constraint_rows
                self.functions.regulate_input(
                    estimate.copy(), estimate.copy(), u.copy(), estimate.copy(),
                    m.regulation_form, m.align_radius, m.reverse, m.q, m.r, m.w, m.m,
                    kinds, params, m.limits, m.dt, np.zeros(3), work, np.zeros(2),
                )  # fmt: skip

    def _diverged(self, k: int, active: ActivePhase, cause: str) -> tuple[Outcome, str]:
        t = _seconds(k, self.m.dt)
        self.transitions.append(Transition(t, active.phase.name, None, "diverged", math.nan))
        return (
            Outcome.diverged,
            f"diverged in phase '{active.phase.name}' at t = {t:.6g} s: {cause}",
        )

    def _record(
        self,
        k: int,
        state: FloatArray,
        estimate: FloatArray,
        u: FloatArray,
        active: ActivePhase,
        iterations: int,
        compute_ns: int,
        reference: tuple[float, float] | None,
        measurement: FloatArray,
    ) -> None:
        recorder = self.recorder
        i = recorder.row()
        row = recorder.floats[i]
        row[0] = k * self.m.dt
        row[1:4] = state
        row[4:7] = estimate
        row[7:9] = u
        if reference is not None:
            # The path point at t_k (the controller aims at t_{k+1}'s).
            row[9] = reference[0]
            row[10] = reference[1]
        kinds, params = active.phase.constraint_rows
        if kinds.shape[0]:
            row[11] = max_row_value(kinds, params, float(state[0]), float(state[1]))
        if k > 0:  # the measurement of x_k, which the estimator used for x_{k|k}
            measured = self.m.measure_mask
            row[12] = measurement[0] if measured[0] else math.nan
            row[13] = measurement[1] if measured[1] else math.nan
            row[14] = measurement[2] if measured[2] else math.nan
        recorder.phase[i] = active.index
        recorder.iterations[i] = iterations
        recorder.compute_ns[i] = compute_ns

    def _result(self, outcome: Outcome, message: str) -> RunResult:
        r = self.recorder
        n = r.count
        m = self.m
        bounds = tuple(
            (float(lo), float(hi)) if m.use_bounds and math.isfinite(lo) else (math.nan, math.nan)
            for lo, hi in zip(m.lower_bounds, m.upper_bounds, strict=True)
        )
        return RunResult(
            mission_name=m.name,
            dt=m.dt,
            seed=m.seed,
            phases=[
                PhaseInfo(
                    p.name,
                    p.kind,
                    self._target(a),
                    p.constraints,
                    near=p.until.near,
                    points=() if p.points is None else tuple(map(tuple, p.points.tolist())),
                    color=p.color,
                )
                for p, a in zip(m.phases, self.phases, strict=True)
            ],
            t=r.column("t"),
            x=r.column("x"),
            y=r.column("y"),
            theta=r.column("theta"),
            x_est=r.column("x_est"),
            y_est=r.column("y_est"),
            theta_est=r.column("theta_est"),
            v=r.column("v"),
            omega=r.column("omega"),
            phase=r.phase[:n].copy(),
            x_ref=r.column("x_ref"),
            y_ref=r.column("y_ref"),
            constraint=r.column("constraint"),
            phase2_iterations=r.iterations[:n].copy(),
            compute_ns=r.compute_ns[:n].copy(),
            transitions=self.transitions,
            outcome=outcome,
            message=message,
            limits=(float(m.limits[0]), float(m.limits[1])),
            error_bounds=bounds,  # type: ignore[arg-type]
            regions=dict(m.regions),
            x_meas=r.column("x_meas"),
            y_meas=r.column("y_meas"),
            theta_meas=r.column("theta_meas"),
        )

    @staticmethod
    def _target(active: ActivePhase) -> tuple[float, float, float] | None:
        if active.phase.kind == "track" or active.status == Status.pending:
            return active.phase.target
        return (float(active.target[0]), float(active.target[1]), float(active.target[2]))
