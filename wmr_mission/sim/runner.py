"""The phase state machine around the compiled loop.

The fixed-step loop itself (plant, sensors, estimator, controller, exit
conditions, recording, divergence checks) is :func:`wmr_mission.kernels.loop.run_segment`.
This module runs it chunk by chunk: it enters phases (instantiating paths
from the estimated pose), samples each track phase's path ahead, draws the
noise and disturbances ahead, records transitions, reports progress between chunks,
and turns Ctrl-C into an ``interrupted`` result holding every sample so far.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from enum import StrEnum
from typing import Any

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.geometry.paths import Trajectory
from wmr_mission.kernels import jit, loop, scalar_math
from wmr_mission.kernels.corrective import max_row_value
from wmr_mission.kernels.loop import FLOAT_COLUMNS, EnteredPhase, PathBlock, Recording, Signals
from wmr_mission.output.metrics import judge
from wmr_mission.output.result import Outcome, PhaseRecord, RunResult, Transition
from wmr_mission.sim.draws import Draws
from wmr_mission.sim.plan import MissionPlan, PhasePlan, plan_mission
from wmr_mission.spec.loader import validate_mission
from wmr_mission.spec.models import Mission

# Samples per call of the compiled loop: between calls the runner reports
# progress and Ctrl-C gets in (a few milliseconds apart when compiled). A
# track phase whose end cannot be foreseen starts with short chunks, so a
# short phase samples little path ahead (PhaseRun.first_chunk).
CHUNK = 4096
FIRST_CHUNK = 256
# Largest recorder pre-sized from the mission's sample budget; it grows beyond.
MAX_PRESIZED = 2_000_000


class Status(StrEnum):
    pending = "pending"
    running = "running"
    done = "done"
    timed_out = "timed-out"


class Recorder:
    """Pre-sized columns (wmr_mission.kernels.loop.Recording), one row per sample; grows
    by doubling if a run outlasts its estimate. Columns are contiguous, so the
    result hands them out as views, without copying."""

    def __init__(self, capacity: int) -> None:
        self.record = self._allocate(max(16, capacity))

    @staticmethod
    def _allocate(capacity: int) -> Recording:
        # np.empty: pages a short run never writes are never touched.
        return Recording(
            np.empty((len(FLOAT_COLUMNS), capacity)).T,
            np.empty(capacity, dtype=np.int64),
            np.empty(capacity, dtype=np.int64),
            np.empty(capacity, dtype=np.int64),
            np.zeros(1, dtype=np.int64),
        )

    @property
    def count(self) -> int:
        return int(self.record.rows[0])

    def reserve(self, rows: int) -> None:
        """Room for ``rows`` more rows."""
        old = self.record
        capacity = old.phase.shape[0]
        if self.count + rows <= capacity:
            return
        grown = self._allocate(max(2 * capacity, self.count + rows))
        n = self.count
        grown.floats[:n] = old.floats[:n]
        for new, kept in zip(grown[1:4], old[1:4], strict=True):
            new[:n] = kept[:n]
        grown.rows[0] = n
        self.record = grown


class PhaseRun:
    """One phase's lifecycle in a run: ``enter`` at its first sample gives the
    record the compiled loop runs it with; ``path_ahead`` samples its path."""

    def __init__(self, phase: PhasePlan, mission: MissionPlan, index: int) -> None:
        self.phase = phase
        self.mission = mission
        self.index = index
        self.status = Status.pending
        self.entry_sample = 0
        self.target = np.zeros(3)
        self._trajectory: Trajectory | None = None
        # Samples after which the phase ends for sure (elapsed or timeout).
        bounds = [phase.until.elapsed_samples, phase.timeout_samples]
        self.bound = min((b for b in bounds if b is not None), default=2**62)
        # Its first chunk: short only for a track phase whose end cannot be
        # foreseen (a condition other than elapsed and timeout), so it samples
        # little path it never uses; any other phase runs to its bound (or
        # CHUNK) per call.
        until = phase.until
        conditions = (until.mission_time, until.reaches, until.near, until.settled, until.heading)
        unforeseen = phase.kind == "track" and any(c is not None for c in conditions)
        self.first_chunk = min(FIRST_CHUNK, CHUNK) if unforeseen else CHUNK

    def enter(self, k: int, estimate: FloatArray) -> EnteredPhase:
        self.status = Status.running
        self.entry_sample = k
        pose = (float(estimate[0]), float(estimate[1]), float(estimate[2]))
        phase = self.phase
        if phase.kind == "track":
            assert phase.make_trajectory is not None
            self._trajectory = phase.make_trajectory(pose)
        self.target[:] = phase.target if phase.target is not None else pose
        until = phase.until
        reaches_kinds, reaches_params = until.reaches_rows
        reaches_sign = 0.0
        if reaches_kinds.shape[0]:
            reaches_sign = math.copysign(
                1.0, _max_row_value(reaches_kinds, reaches_params, pose[0], pose[1])
            )
        kinds, params = phase.constraint_rows
        return EnteredPhase(
            number=self.index,
            tracking=phase.kind == "track",
            entry_sample=k,
            target=self.target,
            constraint_kinds=kinds,
            constraint_params=params,
            elapsed_samples=-1 if until.elapsed_samples is None else until.elapsed_samples,
            mission_time=math.nan if until.mission_time is None else until.mission_time,
            reaches_kinds=reaches_kinds,
            reaches_params=reaches_params,
            reaches_sign=reaches_sign,
            near=np.array(until.near if until.near is not None else (math.nan,) * 3),
            settled=np.array(until.settled if until.settled is not None else (math.nan,) * 3),
            heading=np.array(until.heading if until.heading is not None else (math.nan,) * 2),
            timeout_samples=-1 if phase.timeout_samples is None else phase.timeout_samples,
        )

    @property
    def tracks_a_path(self) -> bool:
        return self._trajectory is not None

    def path_ahead(self, local_sample: int, rows: int) -> PathBlock:
        """The path at phase-local samples ``local_sample`` onwards: point and
        unit tangent (NaN where the path rests)."""
        if self._trajectory is None or rows == 0:
            return PathBlock(local_sample, np.zeros((0, 4)))
        t = (local_sample + np.arange(rows, dtype=np.float64)) * self.mission.dt
        x, y, dx, dy = self._trajectory.sample(t)
        block = np.empty((rows, 4))
        block[:, 0] = x
        block[:, 1] = y
        speed = np.hypot(dx, dy)
        moving = speed > 1e-12
        np.divide(dx, speed, out=block[:, 2], where=moving)
        np.divide(dy, speed, out=block[:, 3], where=moving)
        block[~moving, 2:] = np.nan  # only where it rests: numpy fills two columns slowly
        return PathBlock(local_sample, block)


# Called once per phase or run: plain Python (wmr_mission.kernels.jit.plain).
_max_row_value = jit.plain(max_row_value)
_record_sample = jit.plain(loop.record_sample)

ProgressCallback = Callable[[float, float, str], None]


@functools.cache
def bound_loop(estimator_step: Callable[..., int], control_step: Callable[..., None]) -> Any:
    """The loop for one estimator and one controller: ``run_segment`` with
    their steps bound to the names it calls them by (wmr_mission.kernels.variants),
    one copy per pair, so each is compiled and cached once."""
    return jit.bind(
        loop.run_segment, {"estimator_step": estimator_step, "control_step": control_step}
    )


def run_mission(
    mission: Mission | MissionPlan,
    *,
    seed: int | None = None,
    progress: ProgressCallback | None = None,
    substitutes: Mapping[Any, Callable[..., Any]] | None = None,
) -> RunResult:
    """Simulate ``mission`` and return every sample as arrays.

    A :class:`Mission` is checked first exactly as a mission file is (raises
    ``MissionError``), and the run is judged by its ``expect`` thresholds, as
    ``wmr-mission run`` does. ``progress(t, t_budget, phase_name)`` is called
    between chunks of samples. The run stops cleanly on a timeout with
    ``on_timeout: fail``, on divergence and on Ctrl-C (outcome
    ``interrupted``); what was produced up to then is in the result.

    ``substitutes`` replaces kernels by functions of the same signature (the
    reference step, wmr_mission.sim.reference.REFERENCE): the loop then runs
    as plain Python.
    """
    if isinstance(mission, MissionPlan):
        plan = mission if seed is None else replace(mission, seed=seed)
        return _Run(plan, progress, substitutes).run()
    checked = validate_mission(mission)
    result = _Run(plan_mission(checked, seed), progress, substitutes).run()
    resolved = checked.model_dump(mode="json")
    resolved["sensors"]["seed"] = result.seed  # the mission as run
    result.mission = resolved
    judge(result, resolved)  # a success that misses an `expect` is not one
    return result


def _seconds(samples: int, dt: float) -> float:
    """``samples * dt`` without its rounding tail (53.48, not 53.480000000000004),
    for the times people read in transitions.json."""
    return round(samples * dt, 9)


class _Run:
    def __init__(
        self,
        mission: MissionPlan,
        progress: ProgressCallback | None,
        substitutes: Mapping[Any, Callable[..., Any]] | None,
    ) -> None:
        m = self.m = mission
        self.progress = progress
        self.recorder = Recorder(min(m.max_samples, MAX_PRESIZED))
        self.transitions: list[Transition] = []
        self.phases = [PhaseRun(p, m, i) for i, p in enumerate(m.phases)]
        self.actuation, self.sensing = m.disturbances.records(m.dt, m.measured)
        self.estimator_memory = m.estimator.new_memory(m.estimator_tuning, m.initial_estimate)
        self.scratch = m.controller.new_scratch()
        segment = bound_loop(m.estimator.step, m.controller.step)
        compiles = m.estimator.compiles and m.controller.compiles
        if not substitutes and compiles and jit.compiling():
            # A loop running a plug-in's kernels is compiled afresh in each
            # process: the cache's stamp covers the package's sources only.
            parts: list[Any] = [m.estimator.tuning_record, m.estimator.step]
            parts += [m.controller.tuning_record, m.controller.step]
            cached = all(part.__module__.startswith("wmr_mission.") for part in parts)
            self.segment: Callable[..., int] = jit.compiled(segment, counted=False, cached=cached)
            self.ticks_are_ns = False
        else:
            self.segment = jit.plain(segment, substitutes)
            self.ticks_are_ns = True
        self.signals = Signals(
            state=m.initial_state.copy(),
            estimate=m.initial_estimate.copy(),
            estimate_prev=m.initial_estimate.copy(),
            measurement=np.zeros(3),
            measured=np.full(3, math.nan),
            u=np.zeros(2),
            u_prev=np.zeros(2),
            aim_now=np.zeros(4),
            aim=np.zeros(4),
            memory=np.zeros(m.controller.memory_size),
            counters=np.zeros(loop.CLOCK + 1, dtype=np.int64),
            exit_value=np.zeros(1),
            commands=np.zeros((self.actuation.input_delay + 1, 2)),
            applied=np.zeros(2),
            burst=np.zeros(1, dtype=np.int64),
        )
        self.loop_ns = 0
        # The wall clock and the loop's ticks at the loop's start and at its
        # last return, to convert ticks to nanoseconds.
        self._started = (time.perf_counter_ns(), 0)
        self._returned_ns = self._started[0]

    def _call(self, phase: EnteredPhase, path: PathBlock, draws: FloatArray, stop: int) -> int:
        m = self.m
        status = int(
            self.segment(
                m.plant,
                self.actuation,
                self.sensing,
                m.estimator_tuning,
                self.estimator_memory,
                m.controller_tuning,
                self.scratch,
                phase,
                path,
                draws,
                self.signals,
                self.recorder.record,
                stop,
            )
        )
        self._returned_ns = time.perf_counter_ns()
        return status

    def run(self) -> RunResult:
        try:
            return self._loop()
        except KeyboardInterrupt:  # SIGINT, or SIGTERM mapped to it by the command
            return self._interrupted()

    def _interrupted(self) -> RunResult:
        """The samples recorded up to the stop. A row is counted only once it is
        whole, so a stop inside a sample (pure Python) leaves no half row."""
        record = self.recorder.record
        last = self.recorder.count - 1
        active = self.phases[int(record.phase[last]) if last >= 0 else 0]
        t = round(float(record.floats[last, 0]), 9) if last >= 0 else 0.0
        self.transitions.append(Transition(t, active.phase.name, None, "interrupted", math.nan))
        return self._result(
            Outcome.interrupted, f"interrupted in phase '{active.phase.name}' at t = {t:.6g} s"
        )

    def _loop(self) -> RunResult:
        m = self.m
        dt = m.dt
        signals = self.signals
        counters = signals.counters
        draws = Draws(m.noise_std, m.disturbances, m.seed)
        active = self.phases[0]
        phase = active.enter(0, signals.estimate)
        # Load (or compile) the loop and the paths' math before the clock: a
        # zero-sample call.
        if any(p.tracks_a_path for p in self.phases):
            scalar_math.load()
        self._call(phase, active.path_ahead(0, 0), draws.ahead(), 0)
        outcome = Outcome.success
        message = "all phases completed"
        budget = m.max_samples * dt
        self._started = (self._returned_ns, int(counters[loop.CLOCK]))
        index = 0
        chunk = active.first_chunk
        while True:
            k = int(counters[loop.K])
            local = k - active.entry_sample
            # At its bound (elapsed or timeout) the phase exits before it steps,
            # so a call that reaches the bound goes on to see it exit; the path
            # is sampled up to the bound, never past it. The loop also stops
            # where the draws drawn so far run out (Draws.ahead).
            stop = k + min(chunk, active.bound - local + 1)
            path = active.path_ahead(local, min(chunk, active.bound - local) + 1)
            self.recorder.reserve(2)  # the loop stops early when the recorder is full
            status = self._call(phase, path, draws.ahead(), stop)
            draws.used(int(counters[loop.DRAWS]))
            counters[loop.DRAWS] = 0
            k = int(counters[loop.K])
            if status == loop.CHUNK_END:
                if self.progress is not None:
                    self.progress(k * dt, budget, active.phase.name)
                chunk = min(4 * chunk, CHUNK)
                continue
            if status != loop.EXITED:
                cause = self._divergence_cause(status)
                outcome, message = self._diverged(int(counters[loop.K]), active, cause)
                break
            condition = loop.CONDITIONS[int(counters[loop.CONDITION])]
            value = float(signals.exit_value[0])
            if condition in ("elapsed", "timeout", "mission_time"):
                value = _seconds(int(value), dt)
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
                self._close(k, phase)
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
                    value,
                    None if to is None else to.phase.lap,
                )
            )
            if to is None:
                self._close(k, phase)
                break
            active = to
            signals.memory[:] = 0.0
            phase = active.enter(k, signals.estimate)
            chunk = active.first_chunk
        return self._result(outcome, message)

    def _close(self, k: int, phase: EnteredPhase) -> None:
        """The row of the sample the run ends at: no step is taken from it."""
        s = self.signals
        _record_sample(
            self.recorder.record, phase, k * self.m.dt, s.state[0], s.state[1], s.state[2],
            s.estimate, s.u_prev, math.nan, math.nan, int(s.counters[loop.ITERATIONS]), s.measured,
        )  # fmt: skip

    def _divergence_cause(self, status: int) -> str:
        s = self.signals
        u = s.u
        if status == loop.DIVERGED_INPUT:
            if math.isfinite(u[0]) and math.isfinite(u[1]):
                return (
                    f"the input ran away (v = {u[0]:.3g} m/s, omega = {u[1]:.3g} rad/s; "
                    f"beyond {self.m.plant.runaway_input:g} is no robot's)"
                )
            return "the input is not finite"
        return (
            f"the state ran away (x = {s.state[0]:.3g} m, y = {s.state[1]:.3g} m; "
            f"last input v = {u[0]:.3g} m/s, omega = {u[1]:.3g} rad/s)"
        )

    def _diverged(self, k: int, active: PhaseRun, cause: str) -> tuple[Outcome, str]:
        t = _seconds(k, self.m.dt)
        self.transitions.append(Transition(t, active.phase.name, None, "diverged", math.nan))
        return (
            Outcome.diverged,
            f"diverged in phase '{active.phase.name}' at t = {t:.6g} s: {cause}",
        )

    def _result(self, outcome: Outcome, message: str) -> RunResult:
        started_ns, started_ticks = self._started
        self.loop_ns = time.perf_counter_ns() - started_ns
        ticks = int(self.signals.counters[loop.CLOCK]) - started_ticks
        ns_per_tick = 1.0 if self.ticks_are_ns else (self._returned_ns - started_ns) / max(1, ticks)
        r = self.recorder
        n = r.count
        m = self.m
        record = r.record
        bounds = m.estimator.error_bounds(m.estimator_tuning)
        compute = record.compute[:n]
        if not (self.ticks_are_ns or jit.cycle_counter()):
            # Compiled where no cheap clock can be read inside the loop (not
            # x86-64): each sample gets the whole loop's mean.
            compute[:] = self.loop_ns // max(1, n)
        elif ns_per_tick != 1.0:
            compute[:] = np.rint(compute * ns_per_tick)
        columns = dict(zip(FLOAT_COLUMNS, record.floats[:n].T, strict=True))
        return RunResult(
            mission_name=m.name,
            dt=m.dt,
            seed=m.seed,
            phases=[
                PhaseRecord(
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
            t=columns["t"],
            x=columns["x"],
            y=columns["y"],
            theta=columns["theta"],
            x_est=columns["x_est"],
            y_est=columns["y_est"],
            theta_est=columns["theta_est"],
            v=columns["v"],
            omega=columns["omega"],
            phase=record.phase[:n],
            x_ref=columns["x_ref"],
            y_ref=columns["y_ref"],
            constraint=columns["constraint"],
            phase2_iterations=record.iterations[:n],
            compute_ns=compute,
            transitions=self.transitions,
            outcome=outcome,
            message=message,
            limits=(float(m.plant.limits[0]), float(m.plant.limits[1])),
            error_bounds=bounds,  # type: ignore[arg-type]
            regions=dict(m.regions),
            constraint_margin=float(m.plant.constraint_margin),
            loop_ns=self.loop_ns,
            x_meas=columns["x_meas"],
            y_meas=columns["y_meas"],
            theta_meas=columns["theta_meas"],
        )

    @staticmethod
    def _target(active: PhaseRun) -> tuple[float, float, float] | None:
        if active.phase.kind == "track" or active.status == Status.pending:
            return active.phase.target
        return (float(active.target[0]), float(active.target[1]), float(active.target[2]))
