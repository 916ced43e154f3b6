"""The floor under the compiled loop: case study 2's tracking samples, fused by hand.

    python benchmarks/floor.py            # the loop / the floor, and what the step timer costs
    python benchmarks/floor.py --pairs 21

The floor is what no loop can do without: per sample the paper's control law
(eqs. (13)-(27)), the plant (eq. (1)) and the constrained observer (eqs.
(4)-(12)), the same kernels the loop inlines. Fused by hand for case study 2,
which has no disturbances and measures every state without noise, it drops all
else the loop does per sample: the exit conditions, the divergence checks, the
disturbances (the plant is eq. (1) itself, the measurement the true pose), the
recording of 15 columns (the floor keeps the pose) and the step timer's two
reads of the processor's cycle counter.

It is run on the arguments the loop was given, call by call, in case study
2's two tracking phases (spiral-out, orbit), and reproduces their trajectory
to 1e-9 (tests/test_benchmarks.py). Printed, from alternating pairs in one
process: the loop's time over the floor's on the same samples, and the floor
with the step timer's two reads per sample over the floor without them.
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import time
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import jit, loop
from wmr_mission.kernels.loop import EnteredPhase, PathBlock, Signals, path_point
from wmr_mission.kernels.model import step
from wmr_mission.kernels.records import Plant
from wmr_mission.kernels.variants import control_step, estimator_step
from wmr_mission.sim import runner
from wmr_mission.sim.plan import plan_mission
from wmr_mission.spec.loader import load_mission

CASE2 = Path(__file__).resolve().parent.parent / "missions" / "case2.yaml"
TICKS = jit.ticks


def fused(
    plant: Plant,
    estimator: Any,
    estimator_memory: Any,
    controller: Any,
    scratch: Any,
    phase: EnteredPhase,
    path: PathBlock,
    signals: Signals,
    samples: int,
    timed: bool,
    poses: FloatArray,
    spent: FloatArray,
) -> None:
    """``samples`` samples of a tracking phase from ``signals``' sample on:
    the pose after each into ``poses``; with ``timed``, the cycles of each
    sample's step into ``spent``, read as the loop reads them."""
    dt = plant.dt
    state = signals.state
    estimate = signals.estimate
    u = signals.u
    row = signals.counters[loop.K] - phase.entry_sample - path.start
    for i in range(samples):
        path_point(path.rows, row + i, estimate[2], signals.held, signals.aim_now)
        path_point(path.rows, row + i + 1, estimate[2], signals.held, signals.aim)
        started = TICKS() if timed else 0
        control_step(
            controller, phase, signals.aim_now, signals.aim, estimate, signals.estimate_prev,
            signals.u_prev, plant, signals.memory, scratch, u,
        )  # fmt: skip
        state[0], state[1], state[2] = step(state[0], state[1], state[2], u[0], u[1], dt)
        signals.estimate_prev[0] = estimate[0]
        signals.estimate_prev[1] = estimate[1]
        signals.estimate_prev[2] = estimate[2]
        estimator_step(estimator, estimator_memory, estimate, u[0], u[1], dt, state, True)
        if timed:
            spent[i] = TICKS() - started
        signals.u_prev[0] = u[0]
        signals.u_prev[1] = u[1]
        poses[i, 0] = state[0]
        poses[i, 1] = state[1]
        poses[i, 2] = state[2]


class Call(NamedTuple):
    """One call of the loop in a tracking phase: its arguments as they were
    before the call, and the samples it ran."""

    arguments: tuple[Any, ...]
    first: int  # the sample it started at
    samples: int


def _copied(arguments: tuple[Any, ...]) -> tuple[Any, ...]:
    return copy.deepcopy(arguments)


def tracking_calls() -> tuple[list[Call], Any, Any]:
    """Case study 2 run as ``run_mission`` runs it, each call of the loop in
    a tracking phase kept; with the run's result and its loop."""
    calls: list[Call] = []
    loops: list[Any] = []  # the loop the run called
    segment = runner._Run._segment

    def kept(run: Any, phase: EnteredPhase, path: PathBlock, draws: FloatArray, stop: int) -> int:
        if not phase.tracking:
            return int(segment(run, phase, path, draws, stop))
        m = run.m
        arguments = (
            m.plant, run.actuation, run.sensing, m.estimator_tuning, run.estimator_memory,
            m.controller_tuning, run.scratch, phase, path, draws, run.signals,
            run.recorder.record, stop,
        )  # fmt: skip
        before = _copied(arguments)
        first = int(run.signals.counters[loop.K])
        status = int(segment(run, phase, path, draws, stop))
        done = int(run.signals.counters[loop.K]) - first
        if done:  # a call at a phase's last sample returns at once
            calls.append(Call(before, first, done))
        loops[:] = [run.segment]
        return status

    runner._Run._segment = kept  # type: ignore[method-assign]
    try:
        result = runner.run_mission(plan_mission(load_mission(CASE2)))
    finally:
        runner._Run._segment = segment  # type: ignore[method-assign]
    return calls, result, loops[0]


def floor_function() -> Any:
    """:func:`fused` for case study 2's estimator and controller, compiled
    when the loop is (not cached: a benchmark), else plain Python."""
    from wmr_mission.controllers import paper
    from wmr_mission.estimators import observer

    steps = {"estimator_step": observer.next_estimate, "control_step": paper.next_input}
    bound = jit.bind(fused, steps)
    if jit.compiling():
        return jit.compiled(bound, counted=False, cached=False)
    return jit.plain(bound)


def floor_run(floor: Any, call: Call, timed: bool = False) -> tuple[FloatArray, FloatArray]:
    """The floor over one call's samples, from a copy of its arguments: the
    poses after each sample and the cycles each step took (timed)."""
    (plant, _act, _sens, estimator, memory, controller, scratch, phase, path, _draws, signals,
     _record, _stop) = _copied(call.arguments)  # fmt: skip
    poses = np.zeros((call.samples, 3))
    spent = np.zeros(call.samples)
    floor(
        plant, estimator, memory, controller, scratch, phase, path, signals, call.samples,
        timed, poses, spent,
    )  # fmt: skip
    return poses, spent


def largest_difference(calls: list[Call], result: Any, floor: Any) -> float:
    """The largest difference of x, y or theta between the floor and the
    run over the tracking samples [m or rad]."""
    largest = 0.0
    for call in calls:
        poses, _ = floor_run(floor, call)
        after = slice(call.first + 1, call.first + 1 + call.samples)
        run = np.column_stack([result.x[after], result.y[after], result.theta[after]])
        largest = max(largest, float(np.max(np.abs(poses - run))))
    return largest


def _timed(function: Any, prepared: list[tuple[Any, ...]]) -> float:
    started = time.perf_counter_ns()
    for arguments in prepared:
        function(*arguments)
    return (time.perf_counter_ns() - started) / 1e9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=15)
    pairs = parser.parse_args().pairs
    if not jit.load():
        raise SystemExit("numba is needed (and WMR_MISSION_NO_JIT unset): the floor is compiled")
    calls, result, compiled_loop = tracking_calls()
    floor = floor_function()
    samples = sum(call.samples for call in calls)
    print(f"case study 2, tracking phases: {samples} samples in {len(calls)} calls of the loop")
    difference = largest_difference(calls, result, floor)
    print(f"floor against the run: largest difference of x, y, theta {difference:.2e}")

    def loop_arguments() -> list[tuple[Any, ...]]:
        return [_copied(call.arguments) for call in calls]

    def floor_arguments(timed: bool) -> list[tuple[Any, ...]]:
        prepared = []
        for call in calls:
            (plant, _a, _s, estimator, memory, controller, scratch, phase, path, _d, signals,
             _r, _st) = _copied(call.arguments)  # fmt: skip
            prepared.append((
                plant, estimator, memory, controller, scratch, phase, path, signals,
                call.samples, timed, np.zeros((call.samples, 3)), np.zeros(call.samples),
            ))  # fmt: skip
        return prepared

    loop_s: list[float] = []
    floor_s: list[float] = []
    timed_s: list[float] = []
    for _ in range(pairs):  # A, B, C, A, B, C, ... each on fresh copies
        loop_s.append(_timed(compiled_loop, loop_arguments()))
        floor_s.append(_timed(floor, floor_arguments(False)))
        timed_s.append(_timed(floor, floor_arguments(True)))
    per_sample = 1e6 / samples

    def show(name: str, seconds: list[float]) -> None:
        print(f"{name}: median {statistics.median(seconds) * per_sample:.3f} us a sample, "
              f"min {min(seconds) * per_sample:.3f} ({pairs} runs)")  # fmt: skip

    show("the compiled loop (run_segment)", loop_s)
    show("the floor", floor_s)
    show("the floor with the step timer's two reads", timed_s)
    ratio = statistics.median(a / b for a, b in zip(loop_s, floor_s, strict=True))
    timer = statistics.median(a / b for a, b in zip(timed_s, floor_s, strict=True))
    print(f"loop / floor, pair by pair: median {ratio:.2f}")
    print(f"floor with the timer / floor, pair by pair: median {timer:.3f}")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main()
