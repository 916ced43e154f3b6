"""``wmr-mission bench``: time the step and the whole loop per sample.

The mission runs ``repeat`` times with the fast kernels and once with the
reference step (wmr_mission.sim.reference), in the same process, without files or
plots. Two figures per sample are compared:

* the step: the controller, the plant and sensors of one sample (a few
  floating-point operations) and the estimator, timed inside the loop
  (``RunResult.compute_ns``);
* the whole loop: the wall time of the simulation loop (phase conditions,
  path, plant, sensors, estimator, controller, recording) over the samples
  (``RunResult.loop_ns``).

A mission with disturbances (wmr_mission.kernels.disturbances) is also timed without
them: the whole loop per sample with and without, in the same process.

The built-in controllers (wmr_mission.controllers) are timed on the same
mission in place of its own: the whole loop per sample with each, runs
alternating, and its ratio to the paper's controller.

A first untimed run takes the one-off cost of loading or compiling the kernels.
The reference step runs with BLAS limited to one thread: its matrices are
3x3, so BLAS threads only add waiting (on a busy machine, milliseconds per
call), which would flatter the ratio.
"""

from __future__ import annotations

import math
import sys
from contextlib import AbstractContextManager
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome
from wmr_mission.sim.draws import DisturbancePlan
from wmr_mission.sim.plan import MissionPlan, plan_mission
from wmr_mission.sim.runner import run_mission

if TYPE_CHECKING:
    from wmr_mission.spec.models import Mission

# Average computation time per sample reported in the paper's section IV [us].
PAPER_US_PER_SAMPLE = {"case study 1": 120.0, "case study 2": 175.0}
# The speed-up over the reference step the fast kernels are built for.
TARGET_RATIO = 100.0


def one_blas_thread() -> AbstractContextManager[object]:
    """A context limiting BLAS to one thread."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")  # type: ignore[no-any-return]


def _stats(ns: NDArray[np.int64]) -> dict[str, float]:
    us = ns.astype(np.float64) / 1000.0
    return {
        "mean_us": float(np.mean(us)),
        "median_us": float(np.median(us)),
        "p99_us": float(np.percentile(us, 99)),
    }


def _timed_samples(result: RunResult) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(phase index, compute ns) of every timed sample of ``result``.

    The row that closes a run has no step and carries 0 ns: it is left out.
    """
    timed = result.compute_ns > 0
    return result.phase[timed], result.compute_ns[timed]


class NothingToTime(ValueError):
    """The mission ends before its first step: no sample to time."""


def _same_trajectory(a: RunResult, b: RunResult) -> bool:
    """Both runs visit the same poses within 1e-6 (m, rad) at every sample."""
    if a.samples != b.samples:
        return False
    return all(
        bool(np.allclose(getattr(a, name), getattr(b, name), rtol=0.0, atol=1e-6))
        for name in ("x", "y", "theta")
    )


def bench_mission(mission: Mission | MissionPlan, repeat: int) -> dict[str, Any]:
    """Run ``mission`` once untimed, ``repeat`` times with the fast kernels and
    once with the reference step; return per-phase and overall median and p99
    microseconds per sample of each, and their ratio (reference / ours).

    A :class:`Mission` is checked first, as a file is (raises ``MissionError``).
    """
    from wmr_mission.sim.reference import REFERENCE
    from wmr_mission.spec.loader import validate_mission

    if repeat < 1:
        raise ValueError(f"repeat must be at least 1, got {repeat}")
    plan = mission if isinstance(mission, MissionPlan) else plan_mission(validate_mission(mission))
    ours = _whole(run_mission(plan))  # warm-up: loads or compiles the kernels
    if not np.any(ours.compute_ns > 0):
        why = "" if ours.succeeded else f": {ours.outcome.value}, {ours.message}"
        raise NothingToTime(f"the mission ends at t = {ours.t[-1]:g} s, before its first step{why}")
    # Only the timed samples of each run are kept: memory grows with the samples
    # timed, not with whole results.
    timed, loops = [], []
    for _ in range(repeat):
        ours = _whole(run_mission(plan))
        timed.append(_timed_samples(ours))
        loops.append(ours.loop_ns / ours.samples / 1000.0)
    with one_blas_thread():
        reference = _whole(run_mission(plan, substitutes=REFERENCE))
    our_phase = np.concatenate([phases for phases, _ in timed])
    our_ns = np.concatenate([ns for _, ns in timed])
    ref_phase, ref_ns = _timed_samples(reference)

    def row(
        name: str, kind: str, mine: NDArray[np.int64], theirs: NDArray[np.int64]
    ) -> dict[str, Any]:
        fast, slow = _stats(mine), _stats(theirs)
        return {
            "name": name,
            "kind": kind,
            "samples": int(theirs.size),
            "ours": fast,
            "reference": slow,
            "ratio": slow["median_us"] / fast["median_us"],
        }

    phases = []
    for index, info in enumerate(reference.phases):
        mine = our_ns[our_phase == index]
        theirs = ref_ns[ref_phase == index]
        if mine.size and theirs.size:
            phases.append(row(info.name, info.kind, mine, theirs))
    return {
        "mission": plan.name,
        "dt": plan.dt,
        "samples": reference.samples,
        "outcome": ours.outcome.value,
        "repeat": repeat,
        "compiled": bool(ours.loop_compiled),  # as the timed runs ran
        "same_trajectory": _same_trajectory(ours, reference),
        "phases": phases,
        "overall": row("all", "", our_ns, ref_ns),
        "loop": _loop_row(loops, reference),
        "paper_us_per_sample": dict(PAPER_US_PER_SAMPLE),
        "disturbances": _disturbance_cost(plan, loops, repeat),
        "controllers": _controller_costs(plan, repeat),
    }


def _whole(result: RunResult) -> RunResult:
    """A timed run is never cut short: ``run_mission`` turns Ctrl-C into an
    ``interrupted`` result, which here stops the whole benchmark."""
    if result.outcome is Outcome.interrupted:
        raise KeyboardInterrupt
    return result


def _disturbance_cost(
    plan: MissionPlan, loops: list[float], repeat: int
) -> dict[str, float] | None:
    """Whole-loop wall time per sample [us] with the mission's disturbances
    (``loops``, one per timed run) and without them (None when it has none)."""
    if not plan.disturbances.active():
        return None
    calm = replace(plan, disturbances=DisturbancePlan())
    without = []
    for _ in range(repeat):
        result = _whole(run_mission(calm))
        without.append(result.loop_ns / result.samples / 1000.0)
    with_us = float(np.median(loops))
    without_us = float(np.median(without))
    return {"with_us": with_us, "without_us": without_us, "ratio": with_us / without_us}


def _controller_costs(plan: MissionPlan, repeat: int) -> list[dict[str, Any]]:
    """Whole-loop wall time per sample [us] of ``plan`` with each built-in
    controller at its default settings, runs alternating between them (one
    untimed run each first), and its ratio to the paper's controller's."""
    from wmr_mission.controllers import CONTROLLERS
    from wmr_mission.fields import type_name

    plans = {}
    for controller in CONTROLLERS:
        if controller.plugin or not controller.step.__module__.startswith("wmr_mission."):
            continue  # a plug-in's, or one registered from outside the package
        name = type_name(controller.settings)
        settings = controller.settings.model_validate({"type": name})  # its defaults
        tuning = controller.tuning_of(settings, plan.plant)
        plans[name] = replace(plan, controller=controller, controller_tuning=tuning)
    for each in plans.values():
        _whole(run_mission(each))  # loads or compiles its loop
    times: dict[str, list[float]] = {name: [] for name in plans}
    for _ in range(repeat):
        for name, each in plans.items():
            result = _whole(run_mission(each))
            times[name].append(result.loop_ns / result.samples / 1000.0)
    medians = {name: float(np.median(us)) for name, us in times.items()}
    paper = medians.get("paper", math.nan)
    return [
        {"controller": name, "loop_us": us, "ratio_to_paper": us / paper}
        for name, us in medians.items()
    ]


def _loop_row(ours_us: list[float], reference: RunResult) -> dict[str, float]:
    """Whole-loop wall time per sample: the median of our runs, the reference's."""
    mine = float(np.median(ours_us))
    theirs = reference.loop_ns / reference.samples / 1000.0
    return {"ours_us": mine, "reference_us": theirs, "ratio": theirs / mine}


TARGET_WORDS = (
    f"target: at least {TARGET_RATIO:.0f}x below the reference step, for the step and for "
    f"the whole loop: in 1 s the compiled code simulates what a straightforward "
    f"numpy/scipy implementation needs {TARGET_RATIO:.0f} s for"
)


# Why a timed run's loop ran as plain Python (RunRecord.loop_compiled).
PLAIN_WHY = (
    "the loop ran as plain Python: a plug-in of plain Python objects, WMR_MISSION_NO_JIT=1 "
    "or no numba; see docs/performance.md"
)


def verdict(numbers: dict[str, Any]) -> str:
    """Two plain sentences: is the step fast enough to run in real time, and how
    it compares with the plain numpy/scipy step (``wmr_mission/sim/reference.py``)."""
    overall = numbers["overall"]
    ratio = overall["ratio"]
    dt_us = numbers["dt"] * 1e6
    share = overall["ours"]["p99_us"] / dt_us
    median = overall["ours"]["median_us"]
    if share < 1.0:
        budget = (
            f"real-time: even the slowest 1 % of samples (p99) use {100.0 * share:.2g}% "
            f"of the {numbers['dt']:g} s sampling period"
        )
    else:
        budget = (
            f"NOT real-time: the slowest 1 % of samples (p99) take longer than the "
            f"{numbers['dt']:g} s sampling period"
        )
    speed = f"{ratio:.0f}x faster than the plain numpy/scipy step of the same equations"
    if ratio < TARGET_RATIO:
        why = "see docs/performance.md" if numbers["compiled"] else PLAIN_WHY
        speed += f", short of the {TARGET_RATIO:.0f}x the compiled kernels reach ({why})"
    loop = numbers["loop"]
    whole = (
        f"the whole loop {loop['ours_us']:.3g} us per sample, {loop['ratio']:.0f}x faster "
        "than the plain step's loop"
    )
    return f"verdict: {median:.3g} us per sample; {budget}; {speed}; {whole}"


def format_report(numbers: dict[str, Any], source: str) -> str:
    """The table ``wmr-mission bench`` prints."""
    built = "numba-compiled loop" if numbers["compiled"] else f"plain-Python loop ({PLAIN_WHY})"
    lines = [
        f"mission {numbers['mission']} ({source}): {numbers['samples']} samples at "
        f"dt = {numbers['dt']:g} s, outcome {numbers['outcome']}",
        f"ours: {built}, {numbers['repeat']} timed run(s) after a warm-up; "
        f"reference: numpy/scipy step, 1 run, BLAS on 1 thread",
        "the step (controller, plant, sensors, estimator), microseconds per sample",
        "",
        f"{'phase':<16} {'kind':<9} {'samples':>8} {'ours med':>9} {'ours p99':>9} "
        f"{'ref med':>9} {'ref p99':>9} {'ref/ours':>9}",
    ]
    for entry in [*numbers["phases"], numbers["overall"]]:
        lines.append(
            f"{entry['name'][:16]:<16} {entry['kind']:<9} {entry['samples']:>8} "
            f"{entry['ours']['median_us']:>9.2f} {entry['ours']['p99_us']:>9.2f} "
            f"{entry['reference']['median_us']:>9.1f} {entry['reference']['p99_us']:>9.1f} "
            f"{entry['ratio']:>8.0f}x"
        )
    paper = ", ".join(f"{us:g} us ({name})" for name, us in numbers["paper_us_per_sample"].items())
    overall = numbers["overall"]
    loop = numbers["loop"]
    lines += [
        "",
        f"step, mean per sample: ours {overall['ours']['mean_us']:.3g} us, "
        f"reference {overall['reference']['mean_us']:.3g} us; "
        f"the paper reports an average of {paper}",
        f"whole loop per sample: ours {loop['ours_us']:.3g} us, "
        f"reference {loop['reference_us']:.3g} us ({loop['ratio']:.0f}x)",
    ]
    cost = numbers["disturbances"]
    if cost is not None:
        lines.append(
            f"whole loop per sample with the mission's disturbances: {cost['with_us']:.3g} us, "
            f"without them: {cost['without_us']:.3g} us ({cost['ratio']:.2f}x)"
        )
    if numbers["controllers"]:
        lines.append(
            "whole loop per sample with each built-in controller in place of the mission's: "
            + ", ".join(
                f"{c['controller']} {c['loop_us']:.3g} us ({c['ratio_to_paper']:.2f}x paper)"
                for c in numbers["controllers"]
            )
        )
    if not numbers["same_trajectory"]:
        lines.append("warning: the reference step ran a different trajectory (beyond 1e-6 m)")
    lines += [TARGET_WORDS, verdict(numbers)]
    return "\n".join(lines)


def bench_command(mission_path: str | Path, repeat: int) -> int:
    """``wmr-mission bench``: exit 0 after printing the table, 1 for an invalid
    mission, 130 or 143 stopped by SIGINT or SIGTERM (nothing is printed)."""
    from wmr_mission.kernels import jit
    from wmr_mission.stopping import HOLD, RAISE, STOP_SIGNALS, StopSignals, stop_owed

    # A KeyboardInterrupt inside the import of a compiled module (scipy's
    # for the reference step, numba's) is turned into that module's
    # ImportError, and marks the interpreter to exit by SIGINT whatever
    # the command returns: the imports come first, the stop held meanwhile.
    with StopSignals(STOP_SIGNALS, HOLD) as stop:
        import wmr_mission.sim.reference  # noqa: F401

        jit.load()
        stop.mode = RAISE
        try:
            if stop_owed():  # held since the command started, or while loading
                raise KeyboardInterrupt
            return _bench(mission_path, repeat)
        except KeyboardInterrupt:
            print(f"{mission_path}: interrupted by {stop.name}; nothing timed", file=sys.stderr)
            return stop.exit_code


def _bench(mission_path: str | Path, repeat: int) -> int:
    from wmr_mission.spec.checks import importing_entries
    from wmr_mission.spec.loader import MissionError, load_mission

    try:
        with importing_entries():  # a plug-in that does not import: its line, as `run` says
            mission = load_mission(mission_path)
    except MissionError as error:
        for diagnostic in error.diagnostics:
            print(diagnostic, file=sys.stderr)
        return 1
    print(
        f"timing {mission_path}: {repeat} run(s) of our step, then one of the reference step "
        "(about 1 ms per sample) ...",
        file=sys.stderr,
    )
    try:
        numbers = bench_mission(mission, repeat)
    except NothingToTime as error:
        print(f"{mission_path}: nothing to time: {error}", file=sys.stderr)
        return 1
    print(format_report(numbers, str(mission_path)))
    return 0
