"""Which loop `run` uses, and ``wmr-mission compile``.

Loading the compiled loop from the cache costs a process numba's import and
its entries (about 0.25 s of CPU and 120 MiB); compiling what case study
2's first run needs, about 35 s of CPU (:data:`jit.ONE_VARIANT` of wall
time), and every variant, 74-103 s of CPU, on every core (:data:`EVERY_VARIANT`
of wall time; docs/performance.md, "Compiling on every core"). Plain Python runs the same
source with the same bytes (wmr_mission.kernels.jit) at 40-130 us a sample,
judging included. So ``run`` runs a mission as plain Python when its sample
budget is at most :data:`PLAIN_PYTHON_SAMPLES`, or at most
:data:`PLAIN_PYTHON_SAMPLES_UNCOMPILED` while the cache is not known to hold
the compiled loop (no ready marker, see :func:`compile_command`): there
loading it would mean compiling it. A longer
mission runs compiled, loaded from the cache or compiled in the foreground
with one line of notice. Nothing compiles in the background: ``wmr-mission
compile`` fills the cache when the user asks, and the library's
``run_mission``, ``bench`` and ``sweep`` compile what they run
(docs/performance.md, Start-up).
"""

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from wmr_mission.kernels import cache, jit
from wmr_mission.kernels.cache import READY, is_ready, ready_stamp
from wmr_mission.kernels.jit import foreground_notice
from wmr_mission.stopping import stop_owed

if TYPE_CHECKING:
    from wmr_mission.output.progress import Steps
    from wmr_mission.record import RunRecord
    from wmr_mission.spec.models import Mission

# Up to this sample budget a run as plain Python costs less CPU than loading
# the compiled loop from the cache, or about the same: where the two cross on
# benchmarks/hour.yaml cut short (5 502 samples: compiled / plain 0.99; 5 002:
# 1.03; 6 002: 0.98; 10 002: 0.77), `python benchmarks/measure.py threshold`,
# docs/performance.md, Start-up. A sample's cost in plain Python varies with the
# mission (40-130 us), so missions near the bound may cost a little more either way.
PLAIN_PYTHON_SAMPLES = 5_500
# While the compiled loop is not in the cache, up to this budget plain Python
# costs less CPU than compiling it: a first run of case study 2 compiling its
# loop took 17.5 s of CPU (`python benchmarks/measure.py compile`), and the
# costliest example's samples as plain Python 0.12 ms each (replanned-patrol.yaml,
# `threshold`): 17.5 s / 0.12 ms = 146 000 samples.
PLAIN_PYTHON_SAMPLES_UNCOMPILED = 150_000
NO_JIT = jit.NO_JIT

# A short run per built-in estimator and controller compiles what any mission
# runs: the loop's argument types depend on the mission only through those
# (tests/test_start_up.py), and the only other compiled function Python
# calls, the math of paths (wmr_mission.kernels.scalar_math), has one argument
# type, whatever the function: the sine here compiles it.
WARM_UP_MISSION = b"""
version: 1
name: warm-up
robot: {dt: 0.01, limits: {v: 1, omega: 2}}
estimator: {type: constrained-observer}
regions:
  field: {type: ellipse, center: [0, 0], semi_axes: [5, 3]}
  far: {type: ellipse, center: [50, 0], semi_axes: [1, 1]}
phases:
  - name: track
    track: {path: {type: expression, x: "0.1*t", y: "0.01*sin(t)"}}
    constraints: [{stay_inside: field}]
    until: {reaches: far}
    timeout: 0.05
    on_timeout: next          # the park judged too: its stall compiled
  - name: park
    regulate: {target: {x: 0, y: 0, theta: 0}}
    constraints: [{stay_inside: field}]
    until: {elapsed: 0.05}
"""


def choose_loop(max_samples: int) -> str | None:
    """Called by ``run`` before the loop is loaded: plain Python for a budget
    of at most :data:`PLAIN_PYTHON_SAMPLES` samples, or of at most
    :data:`PLAIN_PYTHON_SAMPLES_UNCOMPILED` while the cache is not ready, else
    the compiled loop. Returns the line of notice to print (a compile in the
    foreground), or None."""
    if jit.loaded() or not jit.compiling():  # a library caller, or WMR_MISSION_NO_JIT=1
        return None
    if max_samples <= PLAIN_PYTHON_SAMPLES:
        jit.choose_plain_python()
        return None
    notice = foreground_notice()
    if notice is not None and max_samples <= PLAIN_PYTHON_SAMPLES_UNCOMPILED:
        jit.choose_plain_python()  # not compiled yet: plain Python costs less
        return None
    return notice


@functools.cache
def warm_up_missions() -> tuple[Mission, ...]:
    """The warm-up mission with each built-in estimator and controller: the
    compiled loop is specialised to the types of their tuning records
    (wmr_mission.kernels.variants), every other argument type is the same for
    every mission."""
    from wmr_mission.controllers import CONTROLLERS
    from wmr_mission.estimators import ESTIMATORS
    from wmr_mission.fields import type_name
    from wmr_mission.spec.loader import Override, check_mission_bytes

    # A plug-in's loop is compiled for the user's code, never cached: none here.
    estimators = [type_name(e.settings) for e in ESTIMATORS if not e.plugin]
    controllers = [type_name(c.settings) for c in CONTROLLERS if not c.plugin]
    missions = []
    for estimator in estimators:
        for controller in controllers:
            overrides = [
                Override(("estimator", "type"), estimator, f"estimator.type={estimator}"),
                Override(("controller", "type"), controller, f"controller.type={controller}"),
            ]
            mission, diagnostics = check_mission_bytes(WARM_UP_MISSION, "warm-up.yaml", overrides)
            assert mission is not None, diagnostics
            missions.append(mission)
    return tuple(missions)


class CompileFailed(Exception):
    """A variant of the loop did not compile: its run's message."""


def side_by_side(wanted: int) -> int:
    """How many processes can compile the variants side by side: ``wanted``,
    at most one per variant after the first (:func:`compile_kernels`), and 1
    where numba's saves to the cache cannot be made to take turns
    (:func:`jit.saves_can_take_turns`)."""
    wanted = min(wanted, len(warm_up_missions()) - 1)
    directory = cache.cache_directory()
    if wanted < 2 or directory is None or not jit.saves_can_take_turns():
        return 1
    return wanted if _locks(directory / jit.SAVE_LOCK) else 1


def _locks(path: Path) -> bool:
    """Whether the file system of ``path`` takes flock (some network and FUSE
    file systems refuse it: each save would then fail)."""
    import fcntl

    try:
        with open(path, "a") as held:
            fcntl.flock(held, fcntl.LOCK_EX)
    except OSError:
        return False
    return True


def compile_kernels(processes: int = 1, steps: Steps | None = None) -> None:
    """Compile every kernel the loop runs into the cache, the EKF band's replay
    and the judge's passes. First, here, one variant with what every variant
    shares (numba set up, the kernels Python calls), and beside it the
    judge's passes, which need a run's record but not its loop; then the
    other variants on ``processes`` processes side by side
    (:func:`side_by_side`), each taking the next task as it ends one.
    ``steps``: where to show each task as it ends (on a terminal)."""
    from wmr_mission.output.progress import Steps

    missions = warm_up_missions()
    first = first_variant()
    steps = Steps(None) if steps is None else steps
    rest = [i for i in range(len(missions)) if i != first]
    tasks = len(rest) + 1  # the judge's passes too
    if processes < 2:
        steps.step("the first variant")
        result = _compiled_run(first)
        steps.say(f"compiled {_variant_name(missions[first])}, with what every variant shares")
        steps.step("the other variants and the judge", total=tasks)
        _judge(result)
        _ended(steps, 1, tasks, "the judge's passes")
        for done, variant in enumerate(rest, start=2):
            _compiled_run(variant)
            _ended(steps, done, tasks, _variant_name(missions[variant]))
        return
    from concurrent.futures import Future, as_completed
    from concurrent.futures.process import BrokenProcessPool

    from wmr_mission.campaign.engine import local_pool

    # Forked where the system can (where flock is, it can). Ctrl-C is this
    # process's, which stops them (local_pool).
    with local_pool(1) as beside:
        # The judge's passes beside the first variant, from a run made as
        # plain Python: from nothing they cost what they cost after it (11.1
        # s of CPU against 10.9 s, `python benchmarks/measure.py
        # compiletasks`), and the first variant's compile leaves a core idle.
        names: dict[Future[None], str] = {beside.submit(compile_judge, first): "the judge's passes"}
        steps.step("the first variant")
        _compiled_run(first)
        steps.say(f"compiled {_variant_name(missions[first])}, with what every variant shares")
        if stop_owed():  # came inside the first compile: no process started for the rest
            raise KeyboardInterrupt
        # Then the costliest first, so that the processes end together: the
        # paper's law's variants (15-18 s of CPU each), then the others (4-5 s).
        papers = [i for i in rest if missions[i].controller.type == "paper"]
        order = papers + [i for i in rest if i not in papers]
        steps.step("the other variants and the judge", total=tasks)
        # Forked now, each finds numba set up and what every variant shares
        # compiled, in memory (compiled in each, it took 1.2 times the CPU of
        # one process).
        with local_pool(processes) as pool:
            names |= {pool.submit(compile_variant, v): _variant_name(missions[v]) for v in order}
            # Each as it ends; the first failure as it comes (leaving local_pool
            # stops the others)
            for done, compiled in enumerate(as_completed(names), start=1):
                try:
                    compiled.result()  # a CompileFailed is raised here
                except BrokenProcessPool:  # one was killed (out of memory, kill -9)
                    raise CompileFailed("a process compiling a variant died") from None
                _ended(steps, done, tasks, names[compiled])


def _variant_name(mission: Mission) -> str:
    """A warm-up mission's variant of the loop: its estimator and control law."""
    return f"{mission.estimator.type} with {mission.controller.type}"


def _ended(steps: Steps, done: int, tasks: int, name: str) -> None:
    steps.say(f"compiled {name}")
    steps.update(done, f"{done} of {tasks}")


def first_variant() -> int:
    """The warm-up mission compiled first, with what every variant shares, and
    judged: the first with the law that compiles fastest (pure pursuit, 5-7 s
    of CPU; the paper's 18-24 s)."""
    missions = warm_up_missions()
    return next(i for i, m in enumerate(missions) if m.controller.type == "pure-pursuit")


def compile_variant(variant: int) -> None:
    """In a process side by side with others (:func:`compile_kernels`): the
    loop of the ``variant``-th warm-up mission compiled, and the EKF band's
    replay."""
    _compiled_run(variant)


def compile_judge(variant: int) -> None:
    """In a process of its own, beside the first variant's compile: the judge's
    passes compiled, judging a run of the ``variant``-th warm-up mission made
    as plain Python (its loop not compiled, here or there)."""
    with jit.plain_python_meanwhile():
        result = _run(variant)
    _judge(result)


def _judge(result: RunRecord) -> None:
    """A warm-up run judged, its passes compiled however short the run: the
    judge's kernels take no variant."""
    from wmr_mission.verdicts.metrics import judge

    if stop_owed():  # came inside the last compile
        raise KeyboardInterrupt
    jit.judged(jit.JUDGED_COMPILED_FROM)
    judge(result, result.mission)


def _compiled_run(variant: int) -> RunRecord:
    """The run of the ``variant``-th warm-up mission, its loop compiled, and the
    EKF band's replay."""
    from wmr_mission.output.covariance import estimate_std

    result = _run(variant)
    estimate_std(result)  # the EKF band's replay, for the estimation figure
    return result


def _run(variant: int) -> RunRecord:
    """The run of the ``variant``-th warm-up mission (compiled, unless inside
    :func:`jit.plain_python_meanwhile`)."""
    from wmr_mission.record import Outcome
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission

    # A stop that came inside numba's compiler was dropped there, owed
    # (wmr_mission.stopping): taken between two variants, each kept cached.
    if stop_owed():
        raise KeyboardInterrupt
    mission = warm_up_missions()[variant]
    result = run_mission(plan_mission(mission))
    if result.outcome is Outcome.error:
        # a loop that does not compile ends its run in an error, kept as
        # data: the cache would be marked ready with nothing in it
        raise CompileFailed(result.message)
    result.mission = mission.model_dump(mode="json")
    return result


# How long `wmr-mission compile` takes, the machine's load deciding: 39-49 s
# of wall time on two idle cores, 74-90 s of CPU ("Compiling on every core",
# "The judge's passes beside the first variant"); at 46c19a0, in one process,
# 91 s of CPU and 13 min of wall time with both cores busy five times over
# (docs/performance.md, Start-up).
EVERY_VARIANT = "every variant: 40 s to 13 minutes by the machine's load"


def compile_command() -> int:
    """``wmr-mission compile``: every variant of the loop into the cache, then
    the ready marker. 0, or 1 when there is no cache to keep it in."""
    if not jit.compiling():
        print("wmr-mission: nothing to compile: numba is missing or WMR_MISSION_NO_JIT is set")
        return 1
    directory = cache.cache_directory()
    if directory is None:  # wmr_mission.kernels.cache said why
        return 1
    if is_ready(directory):
        print(f"wmr-mission: the compiled loop is in {directory} already")
        return 0
    from wmr_mission.campaign.engine import default_workers

    processes = side_by_side(default_workers())  # on every core this process may use
    print(
        f"wmr-mission: compiling the simulation loop into {directory} ({EVERY_VARIANT}, "
        f"once; {processes} {'process' if processes == 1 else 'processes'} side by side)"
    )
    # The stamp of the sources compiled, read before: an edit meanwhile
    # leaves a stale marker, never a wrong one.
    stamp = ready_stamp()
    jit.compiles_said_elsewhere()  # the line above says them all, and the steps each
    from wmr_mission.output.progress import Steps

    steps = Steps(sys.stderr)  # on a terminal: each task as it ends
    try:
        try:
            compile_kernels(processes, steps)
        finally:
            steps.close()
        if stop_owed():  # came inside the last compile: no marker of a cache not filled
            raise KeyboardInterrupt
    except CompileFailed as failed:
        print(f"wmr-mission: the compiled loop failed to compile, nothing marked ready: {failed}")
        return 1
    except KeyboardInterrupt:
        # exit 130 as Python's; what each process had saved stays cached
        print(
            "wmr-mission: compile stopped, nothing marked ready; what compiled stays cached, "
            "and `wmr-mission compile` compiles the rest"
        )
        raise
    partial = directory / f"{READY}.{os.getpid()}"
    partial.write_text(stamp)
    os.replace(partial, directory / READY)
    print(
        "wmr-mission: compiled; runs of more than "
        f"{PLAIN_PYTHON_SAMPLES} samples, sweeps and bench load it from the cache"
    )
    return 0
