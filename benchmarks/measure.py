"""The figures of docs/performance.md that ``wmr-mission bench`` does not give.

    python benchmarks/measure.py loop       # loop_us_per_sample, case studies 1 and 2
    python benchmarks/measure.py session    # a session stepped 100 samples at a time / run_mission
    python benchmarks/measure.py loop MISSION.yaml ...   # the same, of these missions
    python benchmarks/measure.py loop COMMIT [MISSION.yaml ...]   # now / as at COMMIT, paired
    python benchmarks/measure.py parts [MISSION.yaml ...]   # short first chunks; the gate
    python benchmarks/measure.py startup    # CPU of `run case1 --no-plots` and `validate case2`
    python benchmarks/measure.py startup COMMIT   # the same, each also as at COMMIT, in turn
    python benchmarks/measure.py threshold  # where the compiled loop pays for its load, per mission
    python benchmarks/measure.py threshold SECONDS ...   # the same, hour.yaml cut to these alone
    python benchmarks/measure.py short [COMMIT] [MISSION.yaml ...]   # short runs: chosen, compiled
    python benchmarks/measure.py cuts       # what each start-up setting of the command line saves
    python benchmarks/measure.py cuts WORD ...   # the same, of the cases named with a word
    python benchmarks/measure.py imports    # CPU of `validate`'s imports, one by one
    python benchmarks/measure.py stages     # `run case1 --no-plots`, `validate case2`, by stage
    python benchmarks/measure.py classes COMMIT   # the package's dataclasses made, now / at COMMIT
    python benchmarks/measure.py llvm       # the calls into LLVM as a run loads its compiled loop
    python benchmarks/measure.py compile    # numba's compile time per kernel, case study 2
    python benchmarks/measure.py compiletasks   # `wmr-mission compile`'s tasks, one by one
    python benchmarks/measure.py compileorder   # when each task ends, on two processes
    python benchmarks/measure.py compilewaits   # the compiles besides the loop's, empty cache
    python benchmarks/measure.py plain      # every example mission as plain Python, per sample
    python benchmarks/measure.py memory     # peak memory of a 1-hour mission, and by stage
    python benchmarks/measure.py csv        # trajectory.csv's writer, per sample, the 1-hour run
    python benchmarks/measure.py scale      # run time against samples (100 s and 1 h)
    python benchmarks/measure.py figures    # case study 1's figures and animation; 10 000 phases
    python benchmarks/measure.py distance   # summary.json's distance to the path, 360 001 samples
    python benchmarks/measure.py dare       # scipy's solve_discrete_are, one 3x3 call
    python benchmarks/measure.py dlqr       # python-control's dlqr (pip install control)
    python benchmarks/measure.py campaign   # a case-2 run's cost by stage; sweep CPU per run
    python benchmarks/measure.py campaign COMMIT   # the same, the sweep also as at COMMIT, in turn
    python benchmarks/measure.py judge      # judging a case-2 run; the 1-hour run per sample, peak
    python benchmarks/measure.py judge COMMIT   # the same, each also as at COMMIT, in turn
    python benchmarks/measure.py judgeparts # a case-2 row's judge by part; in its compiled passes
    python benchmarks/measure.py sweep COMMIT   # case2-headings' sweep, now and as at COMMIT
    python benchmarks/measure.py runner     # the runner's Python around the compiled loop
    python benchmarks/measure.py task       # a worker's task set up first, or run by run
    python benchmarks/measure.py task COMMIT   # a worker's task, now and as at COMMIT, in turn
    python benchmarks/measure.py workers    # a task alone, two at once; the workers' CPU a run
    python benchmarks/measure.py parent     # the sweep's own process, by step
    python benchmarks/measure.py drawing    # a 2000-run campaign's figures and worst-run directory
    python benchmarks/measure.py drawing COMMIT   # the same, each figure also drawn as at COMMIT
    python benchmarks/measure.py png        # Pillow writing case study 2's PNGs, per zlib level
    python benchmarks/measure.py checks     # checking campaigns of 10 000 values, and of 1 MB
    python benchmarks/measure.py plugins    # Kanayama's law built in and as plug-ins, per sample
    python benchmarks/measure.py band       # the EKF's covariance replayed for its figure band

Medians over repeats, in one process where that is fair; each prints what it
measured. Timings depend on the machine and on what else runs on it.
"""

from __future__ import annotations

import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
MISSIONS = ROOT / "missions"
HOUR = ROOT / "benchmarks" / "hour.yaml"


def loop(*paths: str, repeat: int = 7) -> None:
    import numpy as np

    from wmr_mission.kernels.loop import PathBlock
    from wmr_mission.sim import runner
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.spec.loader import load_mission

    # Time spent sampling paths ahead (Python, between calls of the compiled loop).
    path_ns = [0]
    path_ahead = runner.PhaseRun.path_ahead

    def timed_path_ahead(
        self: runner.PhaseRun, local_sample: int, rows: int, wanted: int = 0
    ) -> PathBlock:
        started = time.perf_counter_ns()
        block = path_ahead(self, local_sample, rows, wanted)
        path_ns[0] += time.perf_counter_ns() - started
        return block

    runner.PhaseRun.path_ahead = timed_path_ahead  # type: ignore[method-assign]
    files = [Path(p) for p in paths] or [MISSIONS / f"{n}.yaml" for n in ("case1", "case2")]
    for file in files:
        name = file.stem
        mission = plan_mission(load_mission(file))
        runner.run_mission(mission)  # loads the compiled loop
        runs, cpu_us, path_us = [], [], []
        for _ in range(repeat):
            path_ns[0] = 0
            started = time.thread_time_ns()
            runs.append(runner.run_mission(mission))
            cpu_us.append((time.thread_time_ns() - started) / runs[-1].samples / 1000)
            path_us.append(path_ns[0] / runs[-1].samples / 1000)
        loop_us = [r.loop_ns / r.samples / 1000 for r in runs]
        step_us = np.concatenate([r.compute_ns[r.compute_ns > 0] for r in runs]) / 1000
        print(
            f"{name}: {runs[0].samples} samples; loop_us_per_sample median "
            f"{statistics.median(loop_us):.3f} (min {min(loop_us):.3f}) over {repeat} runs; "
            f"CPU time of run_mission per sample median {statistics.median(cpu_us):.3f} us; "
            f"step median {np.median(step_us):.3f} us, mean {np.mean(step_us):.3f} us, "
            f"p99 {np.percentile(step_us, 99):.3f} us; sampling paths ahead median "
            f"{statistics.median(path_us):.3f} us per sample"
        )
    runner.PhaseRun.path_ahead = path_ahead  # type: ignore[method-assign]
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# One side of `loop COMMIT`: its missions planned and each run once (the
# compiled loop loaded), then for each line of stdin, "MISSION RUNS", that
# mission run RUNS times: the least of its loop's time and of run_mission's
# CPU time, each per sample [us] (the runs least disturbed by the machine).
_LOOP_SIDE = """
import sys, time
from wmr_mission.sim import runner
from wmr_mission.sim.plan import plan_mission
from wmr_mission.spec.loader import load_mission
missions = [plan_mission(load_mission(path)) for path in sys.argv[1:]]
for mission in missions:
    runner.run_mission(mission)
print("ready", flush=True)
for line in sys.stdin:
    index, runs = map(int, line.split())
    loop, cpu = [], []
    for _ in range(runs):
        started = time.thread_time_ns()
        run = runner.run_mission(missions[index])
        cpu.append((time.thread_time_ns() - started) / run.samples / 1000)
        loop.append(run.loop_ns / run.samples / 1000)
    print(min(loop), min(cpu), flush=True)
"""


def _loads_at(commit: str, file: Path, package: str, directory: str) -> Path | None:
    """``file`` as the package at ``commit`` (on ``package``) loads it: as it
    is, else as it was at ``commit`` (a setting added since), else None."""
    check = (
        "import sys; from wmr_mission.spec.loader import load_mission; load_mission(sys.argv[1])"
    )
    env = {**_user_env(), "PYTHONPATH": package, "NUMBA_DISABLE_JIT": "1"}
    for candidate in (file, Path(directory) / file.name):
        if candidate != file:
            written = f"{commit}:missions/{file.name}"
            shown = subprocess.run(["git", "-C", str(ROOT), "show", written], capture_output=True)
            if shown.returncode:
                return None
            candidate.write_bytes(shown.stdout)
        done = subprocess.run([sys.executable, "-c", check, str(candidate)], env=env,
                              capture_output=True, cwd=directory)  # fmt: skip
        if not done.returncode:
            return candidate
    return None


def loop_against(commit: str, paths: list[str], pairs: int = 21, runs: int = 5) -> None:
    """`loop COMMIT [MISSION.yaml ...]`: each mission (all of missions/ unless
    named) run as now and as at COMMIT (its package unpacked on PYTHONPATH
    beside this one, compiled into a cache of its own), in two processes
    kept loaded, in turn (now, then; then, now; ...) ``pairs`` times, each
    time ``runs`` runs of which the least disturbed counts; per mission the
    medians of the pairs' ratios, now / then, of the loop's time and of
    run_mission's CPU time, each per sample. A mission COMMIT's package cannot load as
    it is now runs there as it was at COMMIT (a setting added since), and one
    it never had is left out, each said."""
    files = [Path(p).resolve() for p in paths] or sorted(MISSIONS.glob("*.yaml"))
    directory = Path(tempfile.gettempdir()) / f"wmr-mission-at-{commit}"
    if not (directory / "wmr_mission").is_dir():
        directory.mkdir(exist_ok=True)
        _checkout(commit, str(directory))
    package = str(directory)
    (directory / "missions").mkdir(exist_ok=True)
    now_files, then_files = [], []
    for file in files:
        then = _loads_at(commit, file, package, str(directory / "missions"))
        if then is None:
            print(f"{file.stem}: left out (not a mission at {commit})")
            continue
        if then != file:
            print(f"{file.stem}: at {commit} as it was written then")
        now_files.append(file)
        then_files.append(then)
    # its own cache beside its package, so that neither side's removes the other's
    then_env = {k: v for k, v in _user_env().items() if k != "NUMBA_CACHE_DIR"}
    then_env["PYTHONPATH"] = package
    sides = []
    for env, side_files in ((_user_env(), now_files), (then_env, then_files)):
        side = subprocess.Popen(
            [sys.executable, "-c", _LOOP_SIDE, *map(str, side_files)],
            env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
            cwd=directory / "missions",  # not beside a package: `python -c` imports from there
        )  # fmt: skip
        sides.append(side)
    for side in sides:
        assert side.stdout is not None
        assert side.stdout.readline().strip() == "ready"

    def measured(side: subprocess.Popen[str], i: int) -> tuple[float, float]:
        assert side.stdin is not None
        assert side.stdout is not None
        side.stdin.write(f"{i} {runs}\n")
        side.stdin.flush()
        loop_us, cpu_us = map(float, side.stdout.readline().split())
        return loop_us, cpu_us

    found: list[list[list[tuple[float, float]]]] = [[[], []] for _ in now_files]
    for round_ in range(pairs):
        for i in range(len(now_files)):
            order = (0, 1) if round_ % 2 == 0 else (1, 0)
            for s in order:
                found[i][s].append(measured(sides[s], i))
    for side in sides:
        assert side.stdin is not None
        side.stdin.close()
        side.wait()
    print(f"now / {commit}, medians of {pairs} pairs, each the least of {runs} runs (the loop's "
          f"time and run_mission's CPU time, us per sample):")  # fmt: skip
    for file, (now, then) in zip(now_files, found, strict=True):
        loop_ratio = _ratio([t[0] for t in then], [n[0] for n in now])
        cpu_ratio = _ratio([t[1] for t in then], [n[1] for n in now])
        print(
            f"  {file.stem}: loop {statistics.median(n[0] for n in now):.3f} / "
            f"{statistics.median(t[0] for t in then):.3f} = {loop_ratio:.3f}; run CPU "
            f"{statistics.median(n[1] for n in now):.3f} / "
            f"{statistics.median(t[1] for t in then):.3f} = {cpu_ratio:.3f}; the fastest of "
            f"each: loop {min(n[0] for n in now) / min(t[0] for t in then):.3f}, run CPU "
            f"{min(n[1] for n in now) / min(t[1] for t in then):.3f}"
        )
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def parts(*paths: str, pairs: int = 21, runs: int = 5) -> None:
    """What two parts of a run cost, each mission (all of missions/ unless
    named) in one process, in alternating pairs, each the least of ``runs``
    runs: the short first chunks (the runner's FIRST_CHUNK against CHUNK: the
    calls of the compiled loop a run makes, and run_mission's CPU time per
    sample, ratio), and, with noisy sensors, the estimator's innovation gate
    (the mission as written against ``estimator.innovation_gate: null``)."""
    from wmr_mission.sim import runner
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.spec.loader import load_mission, parse_override

    calls = [0]
    call = runner._Run._call

    def counted(self: Any, *args: Any) -> int:
        calls[0] += 1
        return call(self, *args)

    runner._Run._call = counted  # type: ignore[method-assign]
    first = runner.FIRST_CHUNK

    def cpu(mission: Any, first_chunk: int) -> float:
        runner.FIRST_CHUNK = first_chunk
        least = math.inf
        for _ in range(runs):
            started = time.thread_time_ns()
            # with a progress callback, as `run` has one: short first chunks
            # are taken only where someone waits for the first samples
            run = runner.run_mission(mission, progress=lambda *_: None)
            least = min(least, (time.thread_time_ns() - started) / run.samples)
        return least

    def paired(a: tuple[Any, int], b: tuple[Any, int]) -> float:
        ratios = []
        for i in range(pairs + 1):  # the first pair untimed
            x, y = (cpu(*a), cpu(*b)) if i % 2 else tuple(reversed((cpu(*b), cpu(*a))))
            if i:
                ratios.append(x / y)
        return statistics.median(ratios)

    for file in [Path(p) for p in paths] or sorted(MISSIONS.glob("*.yaml")):
        mission = plan_mission(load_mission(file))
        counts = []
        for chunk in (first, runner.CHUNK):
            calls[0] = 0
            cpu(mission, chunk)
            counts.append(calls[0] // runs)
        line = (
            f"{file.stem}: {counts[0]} calls a run ({counts[1]} without short first chunks), "
            f"run CPU {paired((mission, first), (mission, runner.CHUNK)):.3f} of it"
        )
        if getattr(mission.estimator_tuning, "innovation_gate", math.inf) != math.inf:
            ungated = load_mission(file, [parse_override("estimator.innovation_gate=null")])
            line += f"; the gate {paired((mission, first), (plan_mission(ungated), first)):.3f}"
        print(line)
    runner.FIRST_CHUNK = first
    runner._Run._call = call  # type: ignore[method-assign]
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def session(pairs: int = 31, chunk: int = 100) -> None:
    """The loop's time of a session stepped in chunks of ``chunk`` samples
    against run_mission's, in alternating pairs, case studies 1 and 2 (and a
    10-minute patrol, 60 001 samples): the median of the pairs' ratios, and the
    ratio of the fastest of each (the least disturbed on a loaded machine)."""
    from wmr_mission import load_mission, run_mission, start_mission

    for name, overrides in (
        ("case1", {}),
        ("case2", {}),
        ("patrol", {"phases.patrol.until.elapsed": 600}),
    ):
        mission = load_mission(MISSIONS / f"{name}.yaml", overrides)
        run_mission(mission)  # loads the compiled loop
        ratios, whole, stepped = [], [], []
        for _ in range(pairs):
            whole.append(run_mission(mission).loop_ns)
            stepping = start_mission(mission)
            while stepping.step(chunk):
                pass
            stepped.append(stepping.result().loop_ns)
            ratios.append(stepped[-1] / whole[-1])
        print(
            f"{name}: session in chunks of {chunk} / run_mission, loop time: median ratio "
            f"{statistics.median(ratios):.2f} (from {min(ratios):.2f} to {max(ratios):.2f}) "
            f"over {pairs} pairs; fastest of each: run_mission {min(whole) / 1e6:.2f} ms, "
            f"session {min(stepped) / 1e6:.2f} ms, ratio {min(stepped) / min(whole):.2f}"
        )
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def _wall(
    command: list[str], env: dict[str, str] | None = None, *, check: bool = True
) -> tuple[float, float]:
    """Wall time and CPU time (user + system) of a command [s]."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, check=check, capture_output=True, env=env)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime


# Where loading the cached compiled loop goes, in a process of its own.
_LOADING = """
import sys, time
import numpy
from wmr_mission.sim.plan import plan_mission
from wmr_mission.spec.loader import load_mission
mission = load_mission(sys.argv[1])
from wmr_mission.kernels import jit, model
t0 = time.process_time()
jit.load()  # numba, scipy refused; taught the kernels (its target is set up to compile only)
t1 = time.process_time()
from wmr_mission.sim import runner
runner.run_mission(plan_mission(mission))
t2 = time.process_time()
runner.run_mission(plan_mission(mission))
t3 = time.process_time()
jit._set_up_for_compiling()  # what a compile sets up first (scipy refused)
t4 = time.process_time()
print(f"loading numba {t1 - t0:.3f} s, first run_mission (loads run_segment and the "
      f"paths' math) {t2 - t1:.3f} s, second {t3 - t2:.3f} s; setting numba's target up, "
      f"which only compiling needs, {t4 - t3:.3f} s (CPU)")
"""

# `wmr-mission run` with the compiled loop loaded first, whatever the mission's
# budget (`run` chooses plain Python for a short one).
_RUN_COMPILED = (
    "import sys; from wmr_mission.kernels import jit; jit.load(); "
    "sys.argv[0] = 'wmr-mission'; from wmr_mission.cli import program; program()"
)


def _user_env(**more: str) -> dict[str, str]:
    """A user's environment: bytecode written (as after `pip install`), no
    setting of the test suite."""
    drop = ("PYTHONDONTWRITEBYTECODE", "WMR_MISSION_NO_JIT")
    return {**{k: v for k, v in os.environ.items() if k not in drop}, **more}


def _pairs(commands: list[list[str]], envs: list[dict[str, str]], pairs: int) -> list[list[float]]:
    """CPU seconds of each command, run in turn (A, B, A, B, ...) ``pairs`` times,
    after one untimed run of each (bytecode, cache). A command's ``--out DIR``
    is removed before each run."""
    import shutil

    def timed(command: list[str], env: dict[str, str]) -> float:
        if "--out" in command:
            shutil.rmtree(command[command.index("--out") + 1], ignore_errors=True)
        return _wall(command, env, check=False)[1]  # a mission that fails its expect exits 1

    for command, env in zip(commands, envs, strict=True):
        timed(command, env)
    times: list[list[float]] = [[] for _ in commands]
    for _ in range(pairs):
        for i, (command, env) in enumerate(zip(commands, envs, strict=True)):
            times[i].append(timed(command, env))
    return times


def _ratio(a: list[float], b: list[float]) -> float:
    return statistics.median(y / x for x, y in zip(a, b, strict=True))


def _checkout(commit: str, directory: str) -> str:
    """The package as it was at ``commit``, unpacked into ``directory``: run
    with ``PYTHONPATH`` set to it, beside the installed one."""
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", commit, "wmr_mission"], check=True, capture_output=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", directory], input=archive, check=True)
    return directory


def _compiled_at(commit: str) -> dict[str, str]:
    """A user's environment running the package as it was at ``commit``, its
    kernel cache warm: the package unpacked once into a directory of its own
    (kept between measurements: numba's cache is keyed by each source file's
    path and time), compiled there by its own `wmr-mission compile`. Its
    cache is its package's ``__pycache__``, as an installed package's, not
    ``NUMBA_CACHE_DIR``: without its own ready marker, `run` at the commit
    would choose plain Python (compiled and plain then cost the same)."""
    sha = subprocess.run(["git", "-C", str(ROOT), "rev-parse", f"{commit}^{{commit}}"],
                         check=True, capture_output=True, text=True).stdout.strip()  # fmt: skip
    directory = Path(tempfile.gettempdir()) / f"wmr-mission-at-{sha[:12]}"
    if not (directory / "wmr_mission").is_dir():
        partial = Path(tempfile.mkdtemp(prefix=directory.name + "."))
        _checkout(sha, str(partial))
        os.replace(partial, directory)
    env = {k: v for k, v in _user_env().items() if k != "NUMBA_CACHE_DIR"}
    # Read by commits that compiled in a background process (3bfbb58 to c7fae42).
    env |= {"PYTHONPATH": str(directory), "WMR_MISSION_FOREGROUND_COMPILE": "1"}
    done = subprocess.run([sys.executable, "-m", "wmr_mission", "compile"], cwd=directory.parent,
                          env=env, capture_output=True, text=True)  # fmt: skip
    said = (done.stdout + done.stderr).strip().splitlines()
    print(f"at {commit}: {said[-1] if said else ''} (exit {done.returncode})")
    return env


def startup(pairs: int = 8) -> None:
    """CPU time of the commands users start with, the kernel cache warm (made
    ready by `wmr-mission compile`): `run missions/case1.yaml --no-plots` as it
    runs (the compiled loop: its budget is over the bound of a ready cache),
    the same as plain Python (WMR_MISSION_NO_JIT=1), and `validate
    missions/case2.yaml`; each a process, in turn. With a commit's name
    (`startup COMMIT`), `run` and `validate` as at that commit too, in turn
    with these."""
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    env = _user_env()
    against = sys.argv[2] if len(sys.argv) > 2 else None
    subprocess.run([sys.executable, "-m", "wmr_mission", "compile"], check=True, env=env)
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # `python -m` puts the working directory before PYTHONPATH
        case1 = ["run", str(MISSIONS / "case1.yaml"), "--no-plots", "--out"]
        commands = [
            [sys.executable, "-m", "wmr_mission", *case1, f"{tmp}/compiled"],
            [sys.executable, "-m", "wmr_mission", *case1, f"{tmp}/plain"],
            [sys.executable, "-m", "wmr_mission", "validate", str(MISSIONS / "case2.yaml")],
        ]
        envs = [env, _user_env(WMR_MISSION_NO_JIT="1"), env]
        names = ["run case1 --no-plots (as run chooses: compiled)",
                 "the same as plain Python", "validate case2"]  # fmt: skip
        if against is not None:
            then = _compiled_at(against)
            commands += [
                [*commands[0][:-1], f"{tmp}/then-run"],
                commands[2],
                [*commands[1][:-1], f"{tmp}/then-plain"],
            ]
            envs += [then, then, {**then, "WMR_MISSION_NO_JIT": "1"}]
            names += [
                f"run case1 --no-plots at {against}",
                f"validate case2 at {against}",
                f"the same as plain Python at {against}",
            ]
        times = _pairs(commands, envs, pairs)
        loading = subprocess.run(
            [sys.executable, "-c", _LOADING, str(MISSIONS / "case2.yaml")],
            env=env,
            check=True,
            capture_output=True,
            text=True,
        ).stdout
    for name, cpu in zip(names, times, strict=True):
        print(f"{name}: CPU median {statistics.median(cpu):.3f} s, min {min(cpu):.3f} s "
              f"({pairs} runs)")  # fmt: skip
    print(f"compiled / plain, pair by pair: median {_ratio(times[1], times[0]):.2f}")
    if against is not None:
        print(f"run, now / {against}, pair by pair: median {_ratio(times[3], times[0]):.2f}")
        print(f"validate, now / {against}, pair by pair: median {_ratio(times[4], times[2]):.2f}")
        print(f"run as plain Python, now / {against}, pair by pair: median "
              f"{_ratio(times[5], times[1]):.2f}")  # fmt: skip
        print(f"compiled / plain at {against}, pair by pair: median "
              f"{_ratio(times[5], times[3]):.2f}")  # fmt: skip
    print(f"loading the compiled loop, step by step: {loading.strip()}")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# The command itself (wmr_mission.cli.main), its stages marked by wrapping the
# functions it calls: CPU seconds of this process from its start to each mark.
_STAGES = """
import atexit, sys, time
marks = []
def mark(stage):
    marks.append((stage, time.process_time()))
def timed(module, name, stage):
    function = getattr(module, name)
    def wrapper(*args, **kwargs):
        mark("before " + stage)
        try:
            return function(*args, **kwargs)
        finally:
            mark(stage)
    setattr(module, name, wrapper)
def report():
    mark("the rest")
    print(";".join(f"{stage}={seconds}" for stage, seconds in marks), file=sys.__stderr__)
atexit.register(report)
mark("the interpreter")
sys.argv[0] = "wmr-mission"
from wmr_mission import cli
if sys.argv[1] == "run":
    from wmr_mission.commands import run
    from wmr_mission.output import report, rundir
    from wmr_mission.sim import runner
    from wmr_mission.spec import loader
    from wmr_mission.verdicts import metrics
    timed(loader, "check_mission_bytes", "reading and checking the mission")
    timed(runner, "run_mission", "simulating")
    timed(metrics, "judge_mission", "judging")
    timed(rundir, "write_run", "writing the run directory")
    timed(report, "format_table", "the phase table")
else:
    from wmr_mission.campaign import load
    from wmr_mission.commands import validate
    timed(load, "check_file", "reading and checking the mission")
mark("importing the command line and the command")
cli.main()
"""


def stages(repeat: int = 5) -> None:
    """Where `run missions/case1.yaml --no-plots` (as `run` chooses its loop:
    plain Python) and `validate missions/case2.yaml` spend their CPU time,
    stage by stage in the command's process; medians of ``repeat`` runs after
    one untimed run (bytecode)."""
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    commands = {
        "run case1 --no-plots": ["run", str(MISSIONS / "case1.yaml"), "--no-plots", "--out"],
        "validate case2": ["validate", str(MISSIONS / "case2.yaml")],
    }
    import shutil

    with tempfile.TemporaryDirectory() as tmp:
        for name, command in commands.items():
            if command[-1] == "--out":
                command = [*command, f"{tmp}/run"]
            spent: dict[str, list[float]] = {}
            for attempt in range(repeat + 1):
                shutil.rmtree(f"{tmp}/run", ignore_errors=True)
                done = subprocess.run(
                    [sys.executable, "-c", _STAGES, *command],
                    env=_user_env(),
                    capture_output=True,
                    text=True,
                )
                marks = [m.split("=") for m in done.stderr.strip().splitlines()[-1].split(";")]
                before = 0.0
                between = 0.0  # before a stage's mark: the command's own work between them
                for stage, seconds in marks:
                    if stage.startswith("before "):
                        between += float(seconds) - before
                    elif attempt:
                        spent.setdefault(stage, []).append(float(seconds) - before)
                    before = float(seconds)
                if attempt:
                    spent.setdefault("the command between them", []).append(between)
            shown = [f"{stage} {statistics.median(s):.3f} s" for stage, s in spent.items()]
            total = statistics.median(sum(s[i] for s in spent.values()) for i in range(repeat))
            shown.append(f"all {total:.3f} s (CPU, medians of {repeat})")
            print(f"{name}: " + "; ".join(shown))
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# `wmr-mission` as a process of its own, and the same with Python's collections
# at shutdown left as they were (gc.freeze a no-op, wmr_mission.cli.main).
_COMMAND = "import sys; sys.argv[0] = 'wmr-mission'; from wmr_mission.cli import program; program()"
_UNFROZEN = "import gc; gc.freeze = lambda: None; " + _COMMAND
# The same with the cyclic collector left on as the command starts (gc.disable a
# no-op, wmr_mission.cli.main; wmr_mission.commands.start_up_done).
_COLLECTING = "import gc; gc.disable = lambda: None; " + _COMMAND
# The same with scipy's linear algebra alone refused as numba loads, as it was,
# not all of scipy (wmr_mission.kernels.jit._WithoutScipy).
_WITH_SCIPY = (
    "from wmr_mission.kernels import jit\n"
    "def refuse(finder, name, *rest):\n"
    "    if name == 'scipy.linalg':\n"
    "        raise ImportError(name)\n"
    "jit._WithoutScipy.find_spec = refuse\n" + _COMMAND
)

# The same with numba's target set up as numba loads (scipy refused), as before
# a cached loop loaded without it (wmr_mission.kernels.jit._set_up_for_compiling).
_SET_UP = (
    "from wmr_mission.kernels import jit\n"
    "load = jit._load\n"
    "def load_and_set_up():\n"
    "    loaded = load()\n"
    "    if loaded:\n"
    "        jit._set_up_for_compiling()\n"
    "    return loaded\n"
    "jit._load = load_and_set_up\n" + _COMMAND
)
# The same with typer building every command, not the one named alone
# (wmr_mission.cli._command_line).
_WHOLE_COMMAND_LINE = (
    "import wmr_mission.cli as cli; cli._command_line = lambda arguments: cli.app; " + _COMMAND
)

# The same ending as Python ends, its modules unloaded object by object, not at
# once after its exit functions (wmr_mission.cli._ends_at_once).
_UNLOADING = (
    "import wmr_mission.cli as cli; cli._ends_at_once = lambda *arguments: False; " + _COMMAND
)

# The same with pydantic's plug-in loader imported as pydantic imports it
# (wmr_mission.cli._no_pydantic_plugin_loader).
_PLUGIN_LOADER = (
    "import wmr_mission.cli as cli; cli._no_pydantic_plugin_loader = lambda: None; " + _COMMAND
)

# The same with the phase table laid out by rich, as every table was
# (wmr_mission.output.report._fitting_table).
_RICH_TABLE = (
    "import wmr_mission.output.report as report; report._fitting_table = lambda *a: None; "
    + _COMMAND
)

# The same with numba's extensions looked for before each cached function's
# first call, as numba does (wmr_mission.kernels.jit._extensions_when_compiling).
_EXTENSIONS_LOOKED_FOR = (
    "from wmr_mission.kernels import jit\n"
    "def looked_for():\n"
    "    from numba.core import entrypoints\n"
    "    entrypoints.init_all()\n"
    "jit._extensions_when_compiling = looked_for\n" + _COMMAND
)

# The same with numba's array module imported as numba loads, as loading the
# judge's distances did when the kernel made its scratch arrays itself
# (wmr_mission.verdicts.path_distance.compiled_distances).
_ARRAYS_IMPORTED = (
    "from wmr_mission.kernels import jit\n"
    "load = jit._load\n"
    "def load_and_import():\n"
    "    loaded = load()\n"
    "    if loaded:\n"
    "        import numba.np.arrayobj\n"
    "    return loaded\n"
    "jit._load = load_and_import\n" + _COMMAND
)

# The same with the formulas' grammar imported as the command starts (its
# settings made, numpy imported), as every check and run did
# (wmr_mission.spec.models.Formula imports it where a mission writes a formula).
_GRAMMAR = (
    "import wmr_mission.cli as cli; line = cli._command_line\n"
    "def with_grammar(arguments):\n"
    "    import wmr_mission.spec.temporal\n"
    "    return line(arguments)\n"
    "cli._command_line = with_grammar\n" + _COMMAND
)

# The same with the validators and serializers built, as the command starts, of
# the sections a mission leaves out that were made by validating them, and of the
# built-in contingencies' tolerances (wmr_mission.fields.Model.defaults).
_SECTIONS_VALIDATED = (
    "import wmr_mission.cli as cli; line = cli._command_line\n"
    "def with_validators(arguments):\n"
    "    from wmr_mission.controllers.paper import Regulation, Tracking\n"
    "    from wmr_mission.estimators.observer import StatePoles\n"
    "    from wmr_mission.spec.backend import Backend\n"
    "    from wmr_mission.spec.models import Settled\n"
    "    for model in (Tracking, Regulation, StatePoles, Backend, Settled):\n"
    "        model.model_rebuild(force=True)\n"
    "    return line(arguments)\n"
    "cli._command_line = with_validators\n" + _COMMAND
)


def cuts(pairs: int = 9) -> None:
    """What each setting the command line makes for its own process saves
    (wmr_mission/cli.py): a command with it and without, in turn, CPU
    seconds, medians and the ratio pair by pair; the kernel cache warm."""
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    py = sys.executable
    threads = str(os.cpu_count())
    with tempfile.TemporaryDirectory() as tmp:
        validate = [py, "-c", _COMMAND, "validate", str(MISSIONS / "case2.yaml")]
        case1 = ["run", str(MISSIONS / "case1.yaml"), "--no-plots", "--out", f"{tmp}/run"]
        plain = _user_env(WMR_MISSION_NO_JIT="1")
        cases = [
            (f"import numpy, BLAS threads 1 / {threads}", [py, "-c", "import numpy"],
             [py, "-c", "import numpy"], _user_env(OPENBLAS_NUM_THREADS="1"),
             _user_env(OPENBLAS_NUM_THREADS=threads)),
            ("validate case2, pydantic plug-ins not looked for / looked for", validate,
             validate, _user_env(), _user_env(PYDANTIC_DISABLE_PLUGINS="")),
            ("validate case2, no collection as it starts / collecting", validate,
             [py, "-c", _COLLECTING, *validate[3:]], _user_env(), _user_env()),
            ("run case1 --no-plots as plain Python, no collection as it starts / collecting",
             [py, "-c", _COMMAND, *case1], [py, "-c", _COLLECTING, *case1], plain, plain),
            ("run case1 --no-plots compiled, no collection as it starts / collecting",
             [py, "-c", _COMMAND, *case1], [py, "-c", _COLLECTING, *case1], _user_env(),
             _user_env()),
            ("run case1 --no-plots compiled, scipy refused as numba loads / its linear algebra",
             [py, "-c", _COMMAND, *case1], [py, "-c", _WITH_SCIPY, *case1], _user_env(),
             _user_env()),
            ("run case1 --no-plots compiled, numba's target not set up / set up as it loads",
             [py, "-c", _COMMAND, *case1], [py, "-c", _SET_UP, *case1], _user_env(),
             _user_env()),
            ("validate case2, the command built alone / every command", validate,
             [py, "-c", _WHOLE_COMMAND_LINE, *validate[3:]], _user_env(), _user_env()),
            ("run case1 --no-plots compiled, the command built alone / every command",
             [py, "-c", _COMMAND, *case1], [py, "-c", _WHOLE_COMMAND_LINE, *case1], _user_env(),
             _user_env()),
            ("validate case2, frozen at exit / not", validate,
             [py, "-c", _UNFROZEN, *validate[3:]], _user_env(), _user_env()),
            ("run case1 --no-plots as plain Python, frozen at exit / not",
             [py, "-c", _COMMAND, *case1], [py, "-c", _UNFROZEN, *case1], plain, plain),
            ("run case1 --no-plots compiled, frozen at exit / not",
             [py, "-c", _COMMAND, *case1], [py, "-c", _UNFROZEN, *case1], _user_env(),
             _user_env()),
            ("validate case2, pydantic's plug-in loader stood in for / imported", validate,
             [py, "-c", _PLUGIN_LOADER, *validate[3:]], _user_env(), _user_env()),
            ("run case1 --no-plots as plain Python, pydantic's plug-in loader stood in for / "
             "imported", [py, "-c", _COMMAND, *case1], [py, "-c", _PLUGIN_LOADER, *case1], plain,
             plain),
            ("run case1 --no-plots compiled, its table laid out here / by rich",
             [py, "-c", _COMMAND, *case1], [py, "-c", _RICH_TABLE, *case1], _user_env(),
             _user_env()),
            ("validate case2, ended at once / modules unloaded", validate,
             [py, "-c", _UNLOADING, *validate[3:]], _user_env(), _user_env()),
            ("run case1 --no-plots compiled, ended at once / modules unloaded",
             [py, "-c", _COMMAND, *case1], [py, "-c", _UNLOADING, *case1], _user_env(),
             _user_env()),
            ("run case1 --no-plots compiled, numba's extensions not looked for / looked for",
             [py, "-c", _COMMAND, *case1], [py, "-c", _EXTENSIONS_LOOKED_FOR, *case1],
             _user_env(), _user_env()),
            ("run case1 --no-plots compiled, the judge's scratch made in Python / numba's "
             "arrays imported", [py, "-c", _COMMAND, *case1], [py, "-c", _ARRAYS_IMPORTED, *case1],
             _user_env(), _user_env()),
            ("run case1 --no-plots compiled, the formulas' grammar not imported / imported",
             [py, "-c", _COMMAND, *case1], [py, "-c", _GRAMMAR, *case1], _user_env(),
             _user_env()),
            ("validate case1, the formulas' grammar not imported / imported",
             [py, "-c", _COMMAND, "validate", str(MISSIONS / "case1.yaml")],
             [py, "-c", _GRAMMAR, "validate", str(MISSIONS / "case1.yaml")], _user_env(),
             _user_env()),
            ("validate case2, sections left out unvalidated / validated", validate,
             [py, "-c", _SECTIONS_VALIDATED, *validate[3:]], _user_env(), _user_env()),
            ("run case1 --no-plots compiled, sections left out unvalidated / validated",
             [py, "-c", _COMMAND, *case1], [py, "-c", _SECTIONS_VALIDATED, *case1], _user_env(),
             _user_env()),
        ]  # fmt: skip
        wanted = sys.argv[2:]  # `cuts WORD ...`: the cases named with one of the words
        for name, with_it, without, env_with, env_without in cases:
            if wanted and not any(word in name for word in wanted):
                continue
            done, undone = _pairs([with_it, without], [env_with, env_without], pairs)
            print(f"{name}: {statistics.median(done):.3f} / {statistics.median(undone):.3f} s, "
                  f"pair by pair {_ratio(undone, done):.2f} ({pairs} pairs)")  # fmt: skip
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def imports(repeat: int = 9) -> None:
    """CPU seconds of `validate`'s imports, each imported in turn in a fresh
    process, as the command line sets it up (one BLAS thread, no pydantic
    plug-ins), then the campaign's models, which only a campaign's check
    imports; then checking case2.yaml twice (the first builds the models'
    validators) and, of the imports, the time pydantic took to make the model
    classes; medians of ``repeat`` processes."""
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    names = ["yaml", "pydantic", "pydantic.main", "pydantic.types", "typer", "numpy"]
    names += ["wmr_mission.cli", "wmr_mission.commands.validate", "wmr_mission.campaign.load"]
    names += ["wmr_mission.campaign.models"]  # a campaign's check only
    code = (
        "import importlib, sys, time\n"
        "spent = [time.process_time()]\n"
        "classes, depth, hooked = [0.0], [0], []\n"
        "def timed(new):\n"  # the outermost class statement's time
        "    def timed_new(*args, **kwargs):\n"
        "        depth[0] += 1; started = time.process_time()\n"
        "        try:\n"
        "            return new(*args, **kwargs)\n"
        "        finally:\n"
        "            depth[0] -= 1\n"
        "            if not depth[0]: classes[0] += time.process_time() - started\n"
        "    return timed_new\n"
        "for name in sys.argv[2:]:\n"
        "    if name.startswith('wmr_mission') and not hooked:\n"  # pydantic loaded by now
        "        from pydantic._internal import _model_construction as made\n"
        "        made.ModelMetaclass.__new__ = timed(made.ModelMetaclass.__new__)\n"
        "        hooked.append(True)\n"
        "    started = time.process_time(); importlib.import_module(name)\n"
        "    spent.append(time.process_time() - started)\n"
        "from pathlib import Path\n"
        "from wmr_mission.campaign.load import check_file\n"
        "for _ in range(2):\n"
        "    started = time.process_time(); check_file(Path(sys.argv[1]))\n"
        "    spent.append(time.process_time() - started)\n"
        "print(*spent, classes[0])"
    )
    env = _user_env(OPENBLAS_NUM_THREADS="1", PYDANTIC_DISABLE_PLUGINS="__all__")
    case2 = str(MISSIONS / "case2.yaml")
    runs = [
        [float(x) for x in subprocess.run([sys.executable, "-c", code, case2, *names], env=env,
         check=True, capture_output=True, text=True).stdout.split()]
        for _ in range(repeat + 1)
    ][1:]  # fmt: skip
    shown = ["(the interpreter, before the first)", *names]
    shown += ["checking case2.yaml, first (its models' validators built)", "checking it again"]
    shown += ["(of the imports above: pydantic making the model classes)"]
    for i, name in enumerate(shown):
        print(f"{statistics.median(r[i] for r in runs) * 1000:6.1f} ms  {name}")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# The command line, with the CPU of making each of the package's dataclasses
# and NamedTuples (their class statements' decorators and metaclass) summed as
# it exits: kind, classes, milliseconds.
_CLASSES_MADE = """
import atexit, dataclasses, sys, time, typing
spent = {"dataclass": [0, 0.0], "NamedTuple": [0, 0.0]}
def timed(kind, make):
    def made(*args, **kwargs):
        started = time.process_time()
        try:
            return make(*args, **kwargs)
        finally:
            name = args[0].__module__ if kind == "dataclass" else args[3].get("__module__", "")
            if name.startswith("wmr_mission"):
                spent[kind][0] += 1
                spent[kind][1] += time.process_time() - started
    return made
dataclasses._process_class = timed("dataclass", dataclasses._process_class)
typing.NamedTupleMeta.__new__ = timed("NamedTuple", typing.NamedTupleMeta.__new__)
atexit.register(lambda: print(";".join(f"{k}={n}={s}" for k, (n, s) in spent.items()),
                              file=sys.__stderr__))
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import program
program()
"""


def classes(repeat: int = 7) -> None:
    """CPU of making the package's dataclasses and NamedTuples as `validate
    missions/case2.yaml` and `run missions/case1.yaml --no-plots` import their
    modules (as plain Python: the same modules either way), now and as at
    COMMIT (`classes COMMIT`), in turn; medians of ``repeat`` processes. Then a
    frozen dataclass of five fields against a NamedTuple of the same, made 200
    times in this process."""
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    against = sys.argv[2] if len(sys.argv) > 2 else None
    sides = {"now": _user_env(WMR_MISSION_NO_JIT="1")}
    with tempfile.TemporaryDirectory() as tmp:
        if against is not None:
            os.mkdir(f"{tmp}/then")
            sides[against] = {**sides["now"], "PYTHONPATH": _checkout(against, f"{tmp}/then")}
        os.chdir(tmp)  # `python -c` puts the working directory first on the path
        case1 = ["run", str(MISSIONS / "case1.yaml"), "--no-plots", "--out", f"{tmp}/run"]
        commands = {"validate case2": ["validate", str(MISSIONS / "case2.yaml")],
                    "run case1 --no-plots": case1}  # fmt: skip
        for name, args in commands.items():
            for side, env in sides.items():
                found: dict[str, list[tuple[int, float]]] = {}
                for _ in range(repeat):
                    subprocess.run(["rm", "-rf", f"{tmp}/run"], check=True)
                    done = subprocess.run([sys.executable, "-c", _CLASSES_MADE, *args], env=env,
                                          capture_output=True, text=True)  # fmt: skip
                    for part in done.stderr.strip().splitlines()[-1].split(";"):
                        kind, count, seconds = part.split("=")
                        found.setdefault(kind, []).append((int(count), float(seconds)))
                shown = []
                for kind, runs in found.items():
                    spent = statistics.median(t for _, t in runs) * 1e3
                    shown.append(f"{kind} {runs[0][0]} classes {spent:.1f} ms")
                print(f"{name}, {side}: " + ", ".join(shown) + f" (CPU, medians of {repeat})")
    code = (
        "import dataclasses, textwrap, time, typing\n"
        "fields = 'a: int\\nb: float\\nc: str = \"x\"\\nd: int = 0\\ne: float = 1.0\\n'\n"
        "def made(head):\n"
        "    statement = compile(head + textwrap.indent(fields, '    '), 'A', 'exec')\n"
        "    started = time.process_time()\n"
        "    for _ in range(200):\n"
        "        exec(statement, {'dataclasses': dataclasses, 'typing': typing})\n"
        "    return (time.process_time() - started) / 200 * 1e3\n"
        "frozen = made('@dataclasses.dataclass(frozen=True)\\nclass A:\\n')\n"
        "named = made('class A(typing.NamedTuple):\\n')\n"
        "print(f'a frozen dataclass of five fields {frozen:.2f} ms, '\n"
        "      f'a NamedTuple of the same {named:.2f} ms (CPU, each of 200)')"
    )
    print(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True).stdout.strip())  # fmt: skip
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# The first and second run_mission of a mission with the compiled loop loaded
# from the cache, the CPU of the first's calls into LLVM counted by function
# (llvmlite's wrapper of each, timed), and the modules the first imported.
_LLVM_CALLS = """
import sys, time
import numpy
from wmr_mission.kernels import jit
from wmr_mission.sim import runner
from wmr_mission.sim.plan import plan_mission
from wmr_mission.spec.loader import load_mission
plan = plan_mission(load_mission(sys.argv[1]))
jit.load()
from llvmlite.binding import ffi
calls = {}
call = ffi._lib_fn_wrapper.__call__
def timed(self, *args, **kwargs):
    started = time.process_time()
    try:
        return call(self, *args, **kwargs)
    finally:
        n, spent = calls.get(self._cfn.__name__, (0, 0.0))
        calls[self._cfn.__name__] = (n + 1, spent + time.process_time() - started)
ffi._lib_fn_wrapper.__call__ = timed
before = set(sys.modules)
started = time.process_time()
runner.run_mission(plan)
first = time.process_time() - started
ffi._lib_fn_wrapper.__call__ = call
started = time.process_time()
runner.run_mission(plan)
second = time.process_time() - started
print(f"first run_mission {first * 1e3:.1f} ms, second {second * 1e3:.1f} ms (CPU)")
print(f"calls into LLVM: {sum(n for n, _ in calls.values())}, "
      f"{sum(s for _, s in calls.values()) * 1e3:.1f} ms")
for name, (n, spent) in sorted(calls.items(), key=lambda item: -item[1][1])[:8]:
    print(f"  {name}: {n} calls, {spent * 1e3:.2f} ms")
print("imported by the first:", " ".join(sorted(set(sys.modules) - before)))
"""


def llvm() -> None:
    """Where loading case study 1's compiled loop from the cache goes: the
    first run_mission against the second, its calls into LLVM by function
    (CPU), the modules it imports; the kernel cache warm."""
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    env = _user_env()
    subprocess.run([sys.executable, "-m", "wmr_mission", "compile"], check=True, env=env)
    done = subprocess.run([sys.executable, "-c", _LLVM_CALLS, str(MISSIONS / "case1.yaml")],
                          env=env, check=True, capture_output=True, text=True)  # fmt: skip
    print(done.stdout.strip())
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def threshold(pairs: int = 3) -> None:
    """Where the compiled loop pays for its load: each example mission and
    benchmarks/hour.yaml cut to 50-400 s, `run --no-plots` as plain Python and
    with the compiled loop loaded from the cache, in turn; CPU seconds and the
    ratio compiled / plain beside each mission's sample budget."""
    from wmr_mission.commands.compile import PLAIN_PYTHON_SAMPLES
    from wmr_mission.sim.plan import sample_budget
    from wmr_mission.spec.loader import check_mission_bytes, overrides_of_texts

    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    subprocess.run([sys.executable, "-m", "wmr_mission", "compile"], check=True, env=_user_env())
    chosen = sys.argv[2:]  # `threshold SECONDS ...`: hour.yaml cut to these alone
    cases = [] if chosen else [(path, []) for path in sorted(MISSIONS.glob("*.yaml"))]
    cuts = chosen or ["50", "100", "150", "200", "250", "300", "400"]
    cases += [(HOUR, [f"phases.0.until.elapsed={s}"]) for s in cuts]
    plain_env = _user_env(WMR_MISSION_NO_JIT="1")
    print(f"run: plain Python up to a budget of {PLAIN_PYTHON_SAMPLES} samples")
    with tempfile.TemporaryDirectory() as tmp:
        for path, settings in cases:
            sets = [f"--set={s}" for s in settings]
            overrides, _, _ = overrides_of_texts(settings)
            mission, _ = check_mission_bytes(path.read_bytes(), str(path), overrides)
            assert mission is not None
            budget = sample_budget(mission)
            run = ["run", str(path), "--no-plots", *sets, "--out"]
            plain_cpu, compiled_cpu = _pairs(
                [[sys.executable, "-m", "wmr_mission", *run, f"{tmp}/p"],
                 [sys.executable, "-c", _RUN_COMPILED, *run, f"{tmp}/c"]],
                [plain_env, _user_env()],
                pairs,
            )  # fmt: skip
            name = path.name + (f" {settings[0]}" if settings else "")
            print(f"  {name:45s} budget {budget:6d}: plain {statistics.median(plain_cpu):.2f} s, "
                  f"compiled {statistics.median(compiled_cpu):.2f} s, compiled / plain "
                  f"{_ratio(plain_cpu, compiled_cpu):.2f}")  # fmt: skip
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def _short_missions() -> list[Path]:
    """Every tenth mission of tests/data/generated whose sample budget is at
    most the bound under which `run` starts it as plain Python."""
    from wmr_mission.commands.compile import PLAIN_PYTHON_SAMPLES
    from wmr_mission.sim.plan import sample_budget
    from wmr_mission.spec.loader import load_mission

    generated = sorted((ROOT / "tests" / "data" / "generated").glob("*.yaml"))
    short = [p for p in generated if sample_budget(load_mission(p)) <= PLAIN_PYTHON_SAMPLES]
    return short[::10]


def short(pairs: int = 5) -> None:
    """`run --no-plots` of short missions (_short_missions, or the files named
    after the commit), the kernel cache warm: as `run` chooses, and with the
    compiled loop loaded from the start, in turn; with a commit's name (`short
    COMMIT`), as `run` chose at that commit too. CPU seconds, medians, and the
    ratios pair by pair."""
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    env = _user_env()
    against = sys.argv[2] if len(sys.argv) > 2 and not sys.argv[2].endswith(".yaml") else None
    named = [Path(p).resolve() for p in sys.argv[2 + (against is not None) :]]
    paths = named or _short_missions()
    subprocess.run([sys.executable, "-m", "wmr_mission", "compile"], check=True, env=env)
    then = _compiled_at(against) if against is not None else None
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # `python -m` puts the working directory before PYTHONPATH
        for path in paths:
            run = ["run", str(path), "--no-plots", "--out"]
            commands = [[sys.executable, "-m", "wmr_mission", *run, f"{tmp}/now"],
                        [sys.executable, "-c", _RUN_COMPILED, *run, f"{tmp}/compiled"]]  # fmt: skip
            envs = [env, env]
            if then is not None:
                commands.append([sys.executable, "-m", "wmr_mission", *run, f"{tmp}/then"])
                envs.append(then)
            times = _pairs(commands, envs, pairs)
            line = (f"{path.stem:20s} now {statistics.median(times[0]):.2f} s, compiled from the "
                    f"start {statistics.median(times[1]):.2f} s (now / that "
                    f"{_ratio(times[1], times[0]):.2f})")  # fmt: skip
            if then is not None:
                line += (f", at {against} {statistics.median(times[2]):.2f} s (now / then "
                         f"{_ratio(times[2], times[0]):.2f})")  # fmt: skip
            print(line, flush=True)
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def plain() -> None:
    """Every example mission as plain Python: its sample budget (what `run`
    compares with PLAIN_PYTHON_SAMPLES) and the simulation's time per sample,
    in all and in the phases that track a path and those that regulate to a pose (CPU time
    of the loop's calls)."""
    os.environ["WMR_MISSION_NO_JIT"] = "1"  # before the loop is loaded
    from wmr_mission.commands.compile import PLAIN_PYTHON_SAMPLES
    from wmr_mission.sim import runner
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.spec.loader import load_mission

    spent: dict[bool, list[float]] = {}  # tracking: [CPU seconds, samples]
    segment = runner._Run._segment

    def timed(self: Any, phase: Any, *args: Any) -> int:
        first = int(self.signals.counters[0])
        started = time.process_time()
        status: int = segment(self, phase, *args)
        kind = spent.setdefault(bool(phase.tracking), [0.0, 0])
        kind[0] += time.process_time() - started
        kind[1] += int(self.signals.counters[0]) - first
        return status

    runner._Run._segment = timed  # type: ignore[method-assign]
    print(f"run: plain Python up to a budget of {PLAIN_PYTHON_SAMPLES} samples")
    for path in sorted(MISSIONS.glob("*.yaml")):
        mission = plan_mission(load_mission(path))
        spent.clear()
        started = time.perf_counter()
        result = runner.run_mission(mission)
        seconds = time.perf_counter() - started
        kinds = [
            f"{name} {spent[key][1]:5d} at {spent[key][0] / spent[key][1] * 1e6:4.0f} us"
            for key, name in ((True, "tracking"), (False, "regulating"))
            if spent.get(key, [0, 0])[1]
        ]
        print(
            f"  {path.name:20s} budget {mission.max_samples:6d}, ran {result.samples:6d} samples "
            f"in {seconds:5.2f} s: {seconds / result.samples * 1e6:4.0f} us per sample "
            f"({', '.join(kinds)})"
        )
    runner._Run._segment = segment  # type: ignore[method-assign]
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def compile_tasks() -> None:
    """The tasks of `wmr-mission compile` one after another in this process,
    an empty cache: each task's CPU (the first variant carries what every
    variant shares); then, in a new process, each variant's run loaded from
    the cache they filled."""
    import shutil

    cache = tempfile.mkdtemp()
    os.environ["NUMBA_CACHE_DIR"] = cache  # before numba loads, and for the process after
    os.environ.pop("WMR_MISSION_NO_JIT", None)
    from wmr_mission.commands import compile as compile_loop

    missions = compile_loop.warm_up_missions()
    first = compile_loop.first_variant()
    order = [first, *(i for i in range(len(missions)) if i != first)]
    for variant in order:
        started = time.process_time()
        result = compile_loop._compiled_run(variant)
        mission = missions[variant]
        name = f"{mission.estimator.type} with {mission.controller.type}"
        print(f"compiled: {name:40s} {time.process_time() - started:5.1f} s CPU")
        if variant == first:
            started = time.process_time()
            compile_loop._judge(result)
            print(f"compiled: {'the passes of the judge':40s} "
                  f"{time.process_time() - started:5.1f} s CPU")  # fmt: skip
    code = (
        "import time\n"
        "from wmr_mission.commands import compile as c\n"
        "for v in range(len(c.warm_up_missions())):\n"
        "    t = time.process_time(); c._compiled_run(v)\n"
        "    print(f'loaded in a new process: variant {v} {time.process_time() - t:.2f} s CPU')\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, env=_user_env())
    shutil.rmtree(cache)
    # the judge's passes from nothing, as `wmr-mission compile` compiles them
    # beside the first variant: numba loaded, a run made as plain Python, judged
    code = (
        "import time\n"
        "from wmr_mission.commands import compile as c\n"
        "from wmr_mission.kernels import jit\n"
        "t = time.process_time(); jit.load(); c.compile_judge(c.first_variant())\n"
        "print(f'compiled: {\"the passes of the judge, from nothing\":40s} '\n"
        "      f'{time.process_time() - t:5.1f} s CPU (numba loaded with them)')\n"
    )
    env = _user_env(NUMBA_CACHE_DIR=tempfile.mkdtemp())
    subprocess.run([sys.executable, "-c", code], check=True, env=env)
    shutil.rmtree(env["NUMBA_CACHE_DIR"])
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


_ORDER = """
import time
started = time.monotonic()
from wmr_mission.commands import compile as c


class Steps:  # each task's end, timed
    def step(self, name, total=None):
        print(f"{time.monotonic() - started:6.1f} s  {name}", flush=True)

    def say(self, said):
        print(f"{time.monotonic() - started:6.1f} s    {said}", flush=True)

    def update(self, *_):
        pass


c.compile_kernels(2, Steps())
print(f"{time.monotonic() - started:6.1f} s  the end", flush=True)
"""


def compile_order() -> None:
    """`wmr-mission compile`'s tasks on two processes side by side, from an
    empty cache: the moment each ends [s of wall time from the start]."""
    import shutil

    env = _user_env(NUMBA_CACHE_DIR=tempfile.mkdtemp())
    subprocess.run([sys.executable, "-c", _ORDER], check=True, env=env, cwd=tempfile.gettempdir())
    shutil.rmtree(env["NUMBA_CACHE_DIR"])
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def compile_times(mission: str = "case2") -> None:
    """Numba's compile events for a first run of a case study, with an empty
    cache: seconds spent in each function itself (callees excluded)."""
    import collections
    import shutil

    cache = tempfile.mkdtemp()
    os.environ["NUMBA_CACHE_DIR"] = cache  # before numba loads
    os.environ.pop("WMR_MISSION_NO_JIT", None)
    from numba.core import event

    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.spec.loader import load_mission

    events = event.RecordingListener()
    event.register("numba:compile", events)
    from wmr_mission.sim.runner import run_mission

    started = time.perf_counter()
    cpu_started = time.process_time()
    run_mission(plan_mission(load_mission(MISSIONS / f"{mission}.yaml")))
    wall = time.perf_counter() - started
    cpu = time.process_time() - cpu_started
    shutil.rmtree(cache)
    own: dict[str, float] = collections.defaultdict(float)
    count: collections.Counter[str] = collections.Counter()
    open_events: list[list[float]] = []  # [start, seconds in callees]
    for stamp, record in events.buffer:
        if record.is_start:
            open_events.append([stamp, 0.0])
            continue
        start, callees = open_events.pop()
        name = record.data["dispatcher"].py_func.__qualname__
        own[name] += stamp - start - callees
        count[name] += 1
        if open_events:
            open_events[-1][1] += stamp - start
    print(f"{mission}: first run_mission, every kernel compiled: {wall:.1f} s wall, "
          f"{cpu:.1f} s CPU")  # fmt: skip
    for name, seconds in sorted(own.items(), key=lambda item: -item[1])[:12]:
        print(f"  {name:40s} {seconds:5.2f} s in {count[name]} compile(s)")
    print(
        f"  all {len(own)} functions: {sum(own.values()):.1f} s in {sum(count.values())} compiles"
    )
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def _peak_rss(command: list[str]) -> tuple[float, float]:
    """Peak resident memory [MB] and wall time [s] of a command."""
    code = (
        "import resource, subprocess, sys, time; started = time.perf_counter(); "
        "subprocess.run(sys.argv[1:], check=True, capture_output=True); "
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, "
        "time.perf_counter() - started)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, *command], check=True, capture_output=True, text=True
    )
    rss_kb, wall = done.stdout.split()
    return int(rss_kb) / 1024, float(wall)


def memory() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        run = [sys.executable, "-m", "wmr_mission", "run", str(HOUR)]
        plotted, _ = _peak_rss([*run, "--out", f"{tmp}/plots"])
        bare, _ = _peak_rss([*run, "--out", f"{tmp}/bare", "--no-plots"])
        short = [sys.executable, "-m", "wmr_mission", "run", str(MISSIONS / "case2.yaml")]
        small, _ = _peak_rss([*short, "--out", f"{tmp}/small", "--no-plots"])
    print(f"1-hour mission (360 001 samples): peak RSS {plotted:.0f} MB with figures, ")
    print(f"  {bare:.0f} MB without; case study 2 without figures: {small:.0f} MB")
    # Where it goes: `run` of the 1-hour mission in one process, the resident
    # memory at the end of each stage and its peak within the stage.
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run(
            [sys.executable, "-c", _MEMORY_STAGES, str(HOUR), f"{tmp}/run"],
            check=True,
            capture_output=True,
            text=True,
        )
    print(done.stdout, end="")


# MB as MiB, as getrusage's peak above: the resident pages, read every millisecond.
_MEMORY_STAGES = """
import contextlib, io, sys, threading, time
from pathlib import Path

def resident():
    return int(open("/proc/self/statm").read().split()[1]) * 4096 / 2**20

peak, lock = [resident()], threading.Lock()
def watch():
    while True:
        with lock:
            peak[0] = max(peak[0], resident())
        time.sleep(0.001)
threading.Thread(target=watch, daemon=True).start()
out = sys.stdout

def stage(name):
    time.sleep(0.005)
    with lock:
        now = resident()
        print(f"  {name:<44} {now:4.0f} MB, peak within {max(peak[0], now):4.0f} MB", file=out)
        peak[0] = now

import wmr_mission.commands.run as command
import wmr_mission.output.figures as figures
import wmr_mission.output.rundir as rundir
import wmr_mission.sim.runner as runner
import wmr_mission.verdicts.metrics as metrics
stage("imports")

def after(module, name, label):
    function = getattr(module, name)
    def wrapped(*args, **kwargs):
        value = function(*args, **kwargs)
        stage(label)
        return value
    setattr(module, name, wrapped)

after(rundir, "prepare_run_dir", "the loop loaded, the directory claimed")
after(runner._Run, "_result", "simulated: the record (144 bytes a sample)")
after(metrics, "judge_mission", "judged")
after(rundir, "write_trajectory", "trajectory.csv written")
after(rundir, "write_run", "the JSON files written")
after(figures, "draw_all", "the figures drawn (matplotlib imported)")
with contextlib.redirect_stdout(io.StringIO()):  # the table
    mission, run_dir = Path(sys.argv[1]), Path(sys.argv[2])
    command.run_command(mission, out=run_dir, seed=None, plots=True, animate=False)
"""


def csv_cost(repeat: int = 5) -> None:
    """trajectory.csv of the 1-hour run: CPU per sample, median of ``repeat`` writes."""
    from wmr_mission.output import rundir
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission

    result = run_mission(load_mission(HOUR))
    samples = result.samples
    with tempfile.TemporaryDirectory() as tmp:
        writes = []
        for _ in range(repeat):
            started = time.process_time()
            rundir.write_trajectory(result, Path(tmp) / "trajectory.csv")
            writes.append(time.process_time() - started)
    print(
        f"trajectory.csv, {samples} samples: {statistics.median(writes) / samples * 1e6:.2f} us "
        f"a sample (CPU, median of {repeat}); load average {os.getloadavg()[0]:.1f}"
    )


def scale(repeat: int = 5) -> None:
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission, load_mission_text

    hour = plan_mission(load_mission(HOUR))
    text = HOUR.read_text().replace("elapsed: 3600", "elapsed: 100")
    short = plan_mission(load_mission_text(text, "short.yaml"))
    run_mission(short)
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        result = run_mission(short)
        times.append(time.perf_counter() - started)
    started = time.perf_counter()
    long = run_mission(hour)
    hour_s = time.perf_counter() - started
    short_s = statistics.median(times)
    print(f"100 s: {result.samples} samples, median {short_s:.4f} s")
    ratio = hour_s / 36 / short_s
    print(f"1 h: {long.samples} samples, {hour_s:.3f} s; against 36 x 100 s: {ratio:.3f}")


def figures(repeat: int = 3) -> None:
    from wmr_mission.output.animation import write_animation
    from wmr_mission.output.figures import draw_all
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission

    result = run_mission(load_mission(MISSIONS / "case1.yaml"))
    with tempfile.TemporaryDirectory() as tmp:
        draw_all(result, Path(tmp))  # fonts and caches
        four, animation = [], []
        for _ in range(repeat):
            started = time.perf_counter(), time.thread_time()
            draw_all(result, Path(tmp))
            four.append((time.perf_counter() - started[0], time.thread_time() - started[1]))
            started = time.perf_counter(), time.thread_time()
            write_animation(result, Path(tmp) / "animation.gif")
            animation.append((time.perf_counter() - started[0], time.thread_time() - started[1]))
        gif_mb = (Path(tmp) / "animation.gif").stat().st_size / 1e6
        png_mb = sum(path.stat().st_size for path in Path(tmp).glob("*.png")) / 1e6
    for what, times in (("figures", four), ("animation", animation)):
        wall = statistics.median(t[0] for t in times)
        cpu = statistics.median(t[1] for t in times)
        print(f"case1, {what}: median wall {wall:.2f} s, CPU {cpu:.2f} s")
    print(f"case1, files: the PNGs {png_mb:.2f} MB, animation.gif {gif_mb:.2f} MB")
    # A mission of many short phases: `run` with and without its figures.
    with tempfile.TemporaryDirectory() as tmp:
        mission = Path(tmp) / "phases.yaml"
        mission.write_text(MANY_PHASES)
        run = [sys.executable, "-m", "wmr_mission", "run", str(mission)]
        bare_rss, bare_wall = _peak_rss([*run, "--no-plots", "--out", f"{tmp}/bare"])
        plotted_rss, plotted_wall = _peak_rss([*run, "--out", f"{tmp}/plotted"])
    print(
        f"10 000 phases, 50 001 samples: run {plotted_wall:.1f} s and {plotted_rss:.0f} MB "
        f"with figures, {bare_wall:.1f} s and {bare_rss:.0f} MB without"
    )
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# 10 000 phases of 0.05 s: a repeat of a lap piece and a pause, 5 000 times.
MANY_PHASES = """version: 1
name: phases
estimator: {type: constrained-observer, initial_estimate: {x: 0, y: 0, theta: 0}}
phases:
  - name: laps
    repeat:
      times: 5000
      phases:
        - name: go
          track: {path: {type: circle, center: [0, 1], radius: 1, angular_rate: 1}}
          until: {elapsed: 0.05}
        - name: pause
          hold: {}
          until: {elapsed: 0.05}
"""


def distance() -> None:
    """The distance to the path of 360 001 positions round 573 laps of a circle
    sampled every 1 cm, the robot off it by noise of each size."""
    import numpy as np

    from wmr_mission.verdicts.metrics import distance_to_path

    t = np.arange(360_001) * 0.01
    x_ref, y_ref = np.cos(t), 1 + np.sin(t)
    rng = np.random.default_rng(0)
    for noise in (0.001, 0.01, 0.1):
        x = x_ref + rng.normal(0, noise, t.size)
        y = y_ref + rng.normal(0, noise, t.size)
        started = time.process_time()
        distance_to_path(x, y, x_ref, y_ref)
        print(f"robot off by {noise} m (normal noise): {time.process_time() - started:.2f} s CPU")


def dare(repeat: int = 200) -> None:
    import numpy as np
    from scipy.linalg import solve_discrete_are

    from wmr_mission.commands.bench import one_blas_thread
    from wmr_mission.sim.reference import input_jacobian, state_jacobian

    a = state_jacobian(0.3, 1.0, 0.5, 0.01)
    b = input_jacobian(0.3, 1.0, 0.5, 0.01)
    q, r = np.eye(3), np.eye(2)
    times = []
    with one_blas_thread():
        solve_discrete_are(a, b, q, r)
        for _ in range(repeat):
            started = time.perf_counter()
            solve_discrete_are(a, b, q, r)
            times.append(time.perf_counter() - started)
    median = statistics.median(times) * 1e6
    print(f"scipy solve_discrete_are, 3 states, 2 inputs, one BLAS thread: median {median:.0f} us")


def dlqr(repeat: int = 200) -> None:
    import control  # not a dependency: pip install control

    from wmr_mission.commands.bench import one_blas_thread
    from wmr_mission.sim.reference import input_jacobian, state_jacobian

    a = state_jacobian(0.3, 1.0, 0.5, 0.01)
    b = input_jacobian(0.3, 1.0, 0.5, 0.01)
    times = []
    with one_blas_thread():
        control.dlqr(a, b, [[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[1, 0], [0, 1]])
        for _ in range(repeat):
            started = time.perf_counter()
            control.dlqr(a, b, [[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[1, 0], [0, 1]])
            times.append(time.perf_counter() - started)
    median = statistics.median(times) * 1e6
    print(f"python-control {control.__version__} dlqr, one BLAS thread: median {median:.0f} us")


CAMPAIGN = MISSIONS / "campaigns" / "case2-headings.yaml"


# `wmr-mission sweep` with its own CPU time and its workers' written, as it
# exits, to the file WMR_CPU_REPORT names: "SELF CHILDREN" [s]. The pool's
# workers are its children (joined before it exits); forked, they leave by
# os._exit, without this report.
_SWEEP_CPU = """
import atexit, os, resource, sys
def report():
    own = resource.getrusage(resource.RUSAGE_SELF)
    theirs = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(os.environ["WMR_CPU_REPORT"], "w") as out:
        out.write(f"{own.ru_utime + own.ru_stime} {theirs.ru_utime + theirs.ru_stime}")
atexit.register(report)
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import program
program()
"""


def campaign(repeat: int = 40, pairs: int = 3) -> None:
    """Where a campaign run's time goes (one process, as a sweep's worker runs
    it: the judge's passes compiled; means of CPU time over ``repeat`` runs of
    case2-headings; of run_mission, its calls of the compiled loop, and of
    those the paths sampled ahead and what a call that runs no sample costs;
    of those calls, each phase's), then `sweep --workers 2 --no-plots` of its
    2000 runs end to end, the kernel cache warm: the CPU of the sweep's own
    process and of its workers, per run, and campaign.json's
    missions_per_second; and the same sweep of 20 runs (`--runs 20`), whose
    CPU is what a sweep costs whatever its runs. With a commit's name (`campaign COMMIT`), the same
    sweep as at that commit too, in turn with this one, ``pairs`` times
    (after one untimed run of each: a checkout compiles its kernels once)."""
    import json

    from wmr_mission.campaign.comparison import comparison_metrics
    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.plan import Plan
    from wmr_mission.campaign.rows import run_row
    from wmr_mission.campaign.written import written_runs
    from wmr_mission.kernels import jit
    from wmr_mission.kernels import loop as loop_module
    from wmr_mission.sim import runner
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.verdicts.metrics import judge_run_metrics

    loaded = load_campaign(CAMPAIGN)
    plan = Plan(loaded.campaign)
    jit.judged(jit.JUDGED_COMPILED_FROM)  # as a sweep's workers judge (engine.warm_up)
    for run in range(3):  # loads the kernels, plans each noise level once
        run_row(loaded, plan.draw(run))
    runs = written_runs(loaded)
    # The CPU of sampling the paths ahead, inside the loop's stage.
    path_s = [0.0]
    path_ahead = runner.PhaseRun.path_ahead

    def timed_path_ahead(self: runner.PhaseRun, *args: Any) -> Any:
        started = time.process_time()
        block = path_ahead(self, *args)
        path_s[0] += time.process_time() - started
        return block

    # The CPU of the calls of the compiled loop (the dispatcher and the records
    # passed in included), and of each that runs no sample (a run's first,
    # which loads the loop): what a call costs beside its samples.
    calls_ns = [0]
    empty_us: list[float] = []
    # phase number -> [its name, samples, ns] over the runs, the calls that run samples
    by_phase: dict[int, list[Any]] = {}
    segment = runner._Run._segment

    def timed_segment(self: runner._Run, *args: Any) -> int:
        before = int(self.signals.counters[loop_module.K])
        started = time.thread_time_ns()
        status = segment(self, *args)
        spent = time.thread_time_ns() - started
        calls_ns[0] += spent
        ran = int(self.signals.counters[loop_module.K]) - before
        if ran == 0:
            empty_us.append(spent / 1000)
        else:
            number = args[0].number
            phase = by_phase.setdefault(number, [self.phases[number].phase.name, 0, 0])
            phase[1] += ran
            phase[2] += spent
        return status

    stages: dict[str, list[float]] = {"draw": [], "plan (written)": [], "run_mission": []}
    stages |= {"judge": [], "comparison": [], "whole row": [], "csv line": []}
    paths_ms, calls_ms = [], []
    for run in range(3, repeat + 3):
        times = [time.process_time()]
        draw = plan.draw(run)
        times.append(time.process_time())
        planned, record, _ = runs.run(draw)
        times.append(time.process_time())
        assert planned is not None
        path_s[0] = 0.0
        calls_ns[0] = 0
        runner.PhaseRun.path_ahead = timed_path_ahead  # type: ignore[method-assign]
        runner._Run._segment = timed_segment  # type: ignore[method-assign]
        result = run_mission(planned)
        runner.PhaseRun.path_ahead = path_ahead  # type: ignore[method-assign]
        runner._Run._segment = segment  # type: ignore[method-assign]
        paths_ms.append(path_s[0] * 1000)
        calls_ms.append(calls_ns[0] / 1e6)
        times.append(time.process_time())
        judge_run_metrics(result, record)
        times.append(time.process_time())
        comparison_metrics(result, record)
        times.append(time.process_time())
        row = run_row(loaded, draw, path=False)  # as a sweep without figures makes it
        times.append(time.process_time())
        row.cells()  # what the campaign process does with a row, but the file
        times.append(time.process_time())
        for stage, start, end in zip(stages, times, times[1:], strict=False):
            stages[stage].append((end - start) * 1000)
    print(f"case2-headings, one process, mean CPU over {repeat} runs [ms]:")
    print("  " + ", ".join(f"{k} {statistics.mean(v):.2f}" for k, v in stages.items()))
    python_ms = statistics.mean(stages["run_mission"]) - statistics.mean(calls_ms)
    print(
        f"  of run_mission, the calls of the compiled loop {statistics.mean(calls_ms):.2f}, "
        f"the runner's Python {python_ms:.2f}"
        f" (of it, the paths sampled ahead {statistics.mean(paths_ms):.2f}); a call of the "
        f"compiled loop that runs no sample {statistics.median(empty_us):.0f} us (median)"
    )
    print(
        "  of the calls of the compiled loop, by phase [us a run]: "
        + ", ".join(
            f"{name} {ns / 1000 / repeat:.0f} ({samples / repeat:.0f} samples, "
            f"{ns / 1000 / samples:.3f} us a sample)"
            for name, samples, ns in by_phase.values()
        )
        + f"; the call that loads it {statistics.median(empty_us):.0f}"
    )
    _set_up_as_a_task(loaded, plan, runs, repeat)
    _rows_in_the_sweeps_process(loaded)
    against = sys.argv[2] if len(sys.argv) > 2 else None
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # `python -c` puts the working directory before PYTHONPATH
        envs = {"now": _user_env()}
        if against is not None:
            os.mkdir(f"{tmp}/then")
            envs[against] = _user_env(
                PYTHONPATH=_checkout(against, f"{tmp}/then"),
                WMR_MISSION_FOREGROUND_COMPILE="1",
                NUMBA_CACHE_DIR=f"{tmp}/then-kernels",  # its own: a cache of other sources
            )
        # The sweep's process, whatever the runs: the same sweep of 20 runs
        few: list[tuple[float, float]] = []
        for round_ in range(pairs + 1):
            report = f"{tmp}/cpu"
            command = [sys.executable, "-c", _SWEEP_CPU, "sweep", str(CAMPAIGN), "--runs", "20"]
            command += ["--workers", "2", "--no-plots", "--out", f"{tmp}/few-{round_}"]
            _wall(command, {**envs["now"], "WMR_CPU_REPORT": report}, check=False)
            own, theirs = (float(x) for x in Path(report).read_text().split())
            if round_ > 0:
                few.append((own, theirs))
        measured: dict[str, list[tuple[float, float, float, float]]] = {k: [] for k in envs}
        for round_ in range(pairs + 1):  # the first untimed: bytecode, a checkout's compile
            for label, env in envs.items():
                out = f"{tmp}/{label}-{round_}"
                report = f"{tmp}/cpu"
                command = [sys.executable, "-c", _SWEEP_CPU, "sweep", str(CAMPAIGN)]
                command += ["--workers", "2", "--no-plots", "--out", out]
                wall, _ = _wall(command, {**env, "WMR_CPU_REPORT": report}, check=False)
                own, theirs = (float(x) for x in Path(report).read_text().split())
                record = json.loads(Path(f"{out}/campaign.json").read_text(encoding="utf-8"))
                if round_ > 0:
                    measured[label].append((own, theirs, wall, record["missions_per_second"]))
                runs_done = record["runs"]
    for label, rows in measured.items():
        own = [1000 * r[0] / runs_done for r in rows]
        theirs = [1000 * r[1] / runs_done for r in rows]
        print(
            f"sweep --workers 2 --no-plots, {runs_done} runs ({label}, {pairs} runs): CPU per run "
            f"[ms] the sweep's process {_medians(own)}, its workers {_medians(theirs)}, "
            f"in all {_medians([a + b for a, b in zip(own, theirs, strict=True)])}; end to end "
            f"{_medians([runs_done / r[2] for r in rows])} runs/s; missions_per_second "
            f"{_medians([r[3] for r in rows])}"
        )
    print(
        f"the same sweep of 20 runs (now, {pairs} runs): CPU [s] the sweep's process "
        f"{_medians([r[0] for r in few])}, its workers {_medians([r[1] for r in few])}"
    )
    if against is not None:
        now, then = measured["now"], measured[against]
        for name, index in (("the sweep's process", 0), ("its workers", 1)):
            ratios = [a[index] / b[index] for a, b in zip(now, then, strict=True)]
            print(f"CPU of {name}, now / {against}, pair by pair: {_medians(ratios)}")
        whole = [(a[0] + a[1]) / (b[0] + b[1]) for a, b in zip(now, then, strict=True)]
        print(f"CPU in all, now / {against}, pair by pair: {_medians(whole)}")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def _set_up_as_a_task(loaded: Any, plan: Any, runs: Any, count: int) -> None:
    """The draw and the written plan of ``count`` runs one after another, as a
    worker's task sets its runs up before it simulates the first (``run_rows``):
    the stages above time each right after a run's simulation and judging,
    their code and data out of the caches."""
    first = 1000  # runs no line above drew
    started = time.process_time()
    draws = [plan.draw(run) for run in range(first, first + count)]
    drawn = time.process_time()
    for draw in draws:
        runs.run(draw)
    written = time.process_time()
    print(
        f"  a task's set-up, its {count} runs one after another [ms a run]: the draw "
        f"{(drawn - started) * 1000 / count:.3f}, the plan (written) "
        f"{(written - drawn) * 1000 / count:.3f}"
    )


def _rows_in_the_sweeps_process(loaded: Any, count: int = 200) -> None:
    """What the sweep's own process does per row, the CPU of each step over
    ``count`` rows: a task's rows pickled (by the worker) and unpickled, each
    added to the aggregate, its runs.csv line made and written as CSV. The
    rows without their paths, as a sweep without figures sends them."""
    import csv
    import io
    import pickle

    from wmr_mission.campaign.aggregate import Aggregate
    from wmr_mission.campaign.rows import run_rows

    rows = run_rows(loaded, 0, count, paths=False)
    times = [time.process_time()]
    sent = pickle.dumps(rows)
    times.append(time.process_time())
    received = pickle.loads(sent)
    times.append(time.process_time())
    aggregate = Aggregate(dict(loaded.campaign.vary))
    for row in received:
        aggregate.add(row)
    times.append(time.process_time())
    lines = [row.cells() for row in received]
    times.append(time.process_time())
    csv.writer(io.StringIO(), lineterminator="\n").writerows(lines)
    times.append(time.process_time())
    steps = ("pickled", "unpickled", "Aggregate.add", "cells", "CSV")
    print(
        f"a row in the sweep's process, CPU over {count} rows [us]: "
        + ", ".join(
            f"{step} {(end - start) / count * 1e6:.0f}"
            for step, start, end in zip(steps, times, times[1:], strict=False)
        )
        + f"; {len(sent) / count:.0f} bytes a row"
    )


def _medians(values: list[float]) -> str:
    """The median of ``values``, then all of them in order."""
    return f"{statistics.median(values):.3g} ({', '.join(f'{v:.3g}' for v in values)})"


# Judging the pickled runs of judge_cost in a process of its own (the package
# found first on its path: this checkout's, or another commit's): CPU medians
# [us] of judge_run_metrics with the mission's formulas, without them, and of
# judge, over the case-2 runs; then judge on the hour, per sample.
_JUDGE = """
import pickle, statistics, sys, time
from dataclasses import replace
from wmr_mission.kernels import jit
from wmr_mission.verdicts.metrics import judge, judge_run_metrics
jit.load()  # as a campaign's workers and a compiled run have: the kernels loaded
runs, hour = pickle.load(open(sys.argv[1], "rb"))

def cpu(judged, result, mission):
    fresh = replace(result)  # the arrays shared: judging never writes them
    started = time.thread_time_ns()
    judged(fresh, mission)
    return (time.thread_time_ns() - started) / 1000

found = []
for judged, which in ((judge_run_metrics, 1), (judge_run_metrics, 2), (judge, 1)):
    for result, *missions in runs[:3]:
        judged(replace(result), missions[which - 1])  # first calls: imports, caches
    # the least of 3 of each run (the machine's other work left out), the median of the runs
    found.append(statistics.median(
        min(cpu(judged, result, missions[which - 1]) for _ in range(3))
        for result, *missions in runs
    ))
result, mission = hour
found.append(min(cpu(judge, result, mission) for _ in range(2)) / result.samples)
import tracemalloc
tracemalloc.start()  # the judge's own arrays at their peak, the record apart
judge(replace(result), mission)
found.append(tracemalloc.get_traced_memory()[1] / 1e6)
print(*(f"{value:.3f}" for value in found))
"""


def judge_cost(repeat: int = 40, pairs: int = 5) -> None:
    """What judging costs: runs 1..``repeat`` of case2-headings (simulated
    once), each judged as a campaign's row judges it (``judge_run_metrics``),
    with its mission's temporal formulas and without them, and as ``run``
    judges it (``judge``, every metric of summary.json); then the 1-hour
    mission as ``run`` judges it, per sample, and the peak of the judge's own
    arrays then (``tracemalloc``). CPU medians, each judged in a
    process of its own, ``pairs`` times; with a commit's name (`judge COMMIT`)
    also as at that commit, in turn (the mission handed over in its resolved
    form, which both take), and the ratios pair by pair."""
    import copy
    import pickle

    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.plan import Plan
    from wmr_mission.campaign.rows import mission_of
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission

    against = sys.argv[2] if len(sys.argv) > 2 else None
    loaded = load_campaign(CAMPAIGN)
    plan = Plan(loaded.campaign)
    runs = []
    for run in range(1, repeat + 1):
        draw = plan.draw(run)
        mission, _ = mission_of(loaded, draw)
        assert mission is not None
        result = run_mission(plan_mission(mission, draw.seed))
        resolved = mission.model_dump(mode="json")
        plain = copy.deepcopy(resolved)  # the same without temporal formulas
        for phase in plain["phases"]:
            phase["expect"]["temporal"] = None
        plain["expect"]["temporal"] = None
        runs.append((result, resolved, plain))
    hour_mission = load_mission(HOUR)
    hour = (run_mission(plan_mission(hour_mission)), hour_mission.model_dump(mode="json"))
    names = ["judge_run_metrics [us]", "the same without formulas [us]", "judge [us]",
             "judge, 1 h [us a sample]", "judge, 1 h, traced peak [MB]"]  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        with open(f"{tmp}/runs.pickle", "wb") as file:
            pickle.dump((runs, hour), file)
        envs = [_user_env()]
        if against is not None:  # its kernels compiled once, its passes loaded as now's are
            envs.append(_compiled_at(against))
        found: list[list[list[float]]] = [[] for _ in envs]
        for _ in range(pairs):
            for env, values in zip(envs, found, strict=True):
                command = [sys.executable, "-c", _JUDGE, f"{tmp}/runs.pickle"]
                # run from tmp: `python -c` puts the working directory before PYTHONPATH
                done = subprocess.run(
                    command, env=env, check=True, capture_output=True, text=True, cwd=tmp
                )
                values.append([float(v) for v in done.stdout.split()])
    samples = statistics.median(r.samples for r, _, _ in runs)
    print(f"case2-headings runs 1-{repeat} ({samples:.0f} samples), the hour ({hour[0].samples} "
          f"samples); medians of {pairs} processes:")  # fmt: skip
    for i, name in enumerate(names):
        line = f"  {name}: {statistics.median(v[i] for v in found[0]):.3f}"
        if against is not None:
            then = [v[i] for v in found[1]]
            ratio = _ratio(then, [v[i] for v in found[0]])
            line += f"; at {against} {statistics.median(then):.3f}; now / then, pair by pair "
            line += f"{ratio:.2f}"
        print(line)
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def judge_parts(repeat: int = 7) -> None:
    """A case-2 row's judge by part: runs 1-40 of case2-headings (simulated
    once), each part of each run's phases timed apart (thread CPU time, the
    least of ``repeat``), summed over the phases, the mean over the runs; the
    kernels loaded, as a campaign's workers have them. A part a measure of a
    phase computes on first use (its places, tracking, ...) is timed alone.
    Last, how much of the row its compiled passes take (:func:`_in_passes`)."""
    from dataclasses import replace

    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.plan import Plan
    from wmr_mission.campaign.rows import mission_of
    from wmr_mission.kernels import jit
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.verdicts import metrics

    jit.load()
    # as a campaign's worker after its first rows judges: by the compiled passes
    jit.judged(jit.JUDGED_COMPILED_FROM)
    loaded = load_campaign(CAMPAIGN)
    plan = Plan(loaded.campaign)
    runs = []
    for run in range(1, 41):
        draw = plan.draw(run)
        mission, _ = mission_of(loaded, draw)
        assert mission is not None
        runs.append(
            (run_mission(plan_mission(mission, draw.seed)), mission.model_dump(mode="json"))
        )
    parts = ("placement", "tracking", "inputs", "intrusion", "clearance", "stall", "overshoot")

    def timed(result: Any, mission: Any) -> dict[str, int]:
        found = dict.fromkeys(("setting the phases up", *parts, "formulas", "the row"), 0)
        started = time.thread_time_ns()
        phases = metrics._phase_samples(result, mission, metrics._off_path_bound)
        found["setting the phases up"] = time.thread_time_ns() - started
        for info, phase, _ in phases:
            for part in parts:
                started = time.thread_time_ns()
                getattr(phase, part)
                found[part] += time.thread_time_ns() - started
            started = time.thread_time_ns()
            metrics._formulas(result, info, phase, mission)
            found["formulas"] += time.thread_time_ns() - started
        started = time.thread_time_ns()
        metrics.judge_run_metrics(replace(result), mission)
        found["the row"] = time.thread_time_ns() - started
        return found

    for result, mission in runs[:3]:
        timed(result, mission)  # first calls: imports, caches
    total: dict[str, float] = {}
    for result, mission in runs:
        least = [timed(result, mission) for _ in range(repeat)]
        for key in least[0]:
            total[key] = total.get(key, 0.0) + min(found[key] for found in least) / len(runs)
    passes = _in_passes(runs, repeat)
    total["of the row, in its compiled passes"] = passes.pop("")
    print(f"case2-headings runs 1-40, CPU per row, the least of {repeat} each, mean over runs:")
    for key, ns in total.items():
        print(f"  {key}: {ns / 1000:.0f} us")
    print("    " + ", ".join(f"{name} {ns / 1000:.0f}" for name, ns in passes.items()))
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def _in_passes(runs: list[tuple[Any, Any]], repeat: int) -> dict[str, float]:
    """[ns] of a row's judge spent in its compiled passes (each call timed on
    the thread's clock, its dispatch included), in all and by pass: the row
    whose passes took least of ``repeat``, the mean over ``runs``. What a
    row costs with no Python round its passes."""
    from collections import Counter
    from dataclasses import replace

    from wmr_mission.kernels import jit
    from wmr_mission.verdicts import metrics

    spent: Counter[str] = Counter()
    compiled = jit.compiled

    def timed(fn: Any, **options: Any) -> Any:
        made = compiled(fn, **options)
        name = getattr(fn, "py_func", fn).__name__

        def call(*arguments: Any) -> Any:
            started = time.thread_time_ns()
            found = made(*arguments)
            spent[name] += time.thread_time_ns() - started
            return found

        return call

    jit.compiled = timed
    total: Counter[str] = Counter()
    try:
        for result, mission in runs:
            each = []
            for _ in range(repeat):
                spent.clear()
                metrics.judge_run_metrics(replace(result), mission)
                each.append(Counter(spent))
            least = min(each, key=lambda found: sum(found.values()))
            total.update({name: ns / len(runs) for name, ns in least.items()})
    finally:
        jit.compiled = compiled
    return {"": float(sum(total.values()))} | {name: float(ns) for name, ns in total.most_common()}


def task(pairs: int = 14, runs: int = 130) -> None:
    """A worker's task of ``runs`` runs of case2-headings as ``run_rows`` runs
    it (every run drawn and written into its plan, then each simulated),
    against each run drawn and written right before it is simulated (as
    before), in turn in one process, ``pairs`` times over further runs: CPU
    per row (medians; each in brackets) and the ratio pair by pair. The rows
    must be the same."""
    from wmr_mission.campaign.engine import warm_up
    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.plan import Plan
    from wmr_mission.campaign.rows import run_row, run_rows

    loaded = load_campaign(CAMPAIGN)
    plan = Plan(loaded.campaign)
    warm_up(loaded, 2)  # the kernels and the judge's passes, as a sweep's workers have them

    def run_by_run(start: int, stop: int) -> list[Any]:
        return [run_row(loaded, plan.draw(run)) for run in range(start, stop)]

    ways = {"set up first": lambda a, b: run_rows(loaded, a, b), "run by run": run_by_run}
    for way in ways.values():
        way(0, 20)  # each noise level's base made, the paths' samplings kept
    spent: dict[str, list[float]] = {name: [] for name in ways}
    for i in range(pairs):
        start = 20 + i * runs
        rows = {}
        for name in list(ways) if i % 2 else list(ways)[::-1]:
            started = time.thread_time_ns()
            rows[name] = ways[name](start, start + runs)
            spent[name].append((time.thread_time_ns() - started) / runs / 1000)
        first, second = ([row.cells() for row in found] for found in rows.values())
        assert first == second, "the rows differ"
    for name, values in spent.items():
        each = ", ".join(f"{value:.0f}" for value in values)
        print(f"{name}: CPU per row {statistics.median(values):.0f} us ({each})")
    ratios = [a / b for a, b in zip(*spent.values(), strict=True)]
    print(f"set up first / run by run, pair by pair: {_medians(ratios)}")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# A worker's task in a process of its own (the package found first on its
# path: this checkout's, or another commit's): case2-headings' runs after the
# warm-up a sweep's workers have, then one task timed on the thread's CPU
# clock; prints the CPU per row [us].
_TASK_ROWS = """
import inspect, sys, time
from wmr_mission.campaign.engine import warm_up
from wmr_mission.campaign.load import load_campaign
from wmr_mission.campaign.rows import run_rows
loaded = load_campaign(sys.argv[1])
warm_up(loaded, 2)
first, count = int(sys.argv[2]), int(sys.argv[3])
# the rows a sweep without figures makes, where the package tells them apart
options = {"paths": False} if "paths" in inspect.signature(run_rows).parameters else {}
run_rows(loaded, 0, 20, **options)  # each noise level's base made
started = time.thread_time_ns()
run_rows(loaded, first, first + count, **options)
print((time.thread_time_ns() - started) / count / 1000)
"""


def task_against(commit: str, pairs: int = 10, runs: int = 200) -> None:
    """A worker's task of ``runs`` runs of case2-headings (``run_rows``, its rows
    as a sweep without figures makes them), each in a process of its own after
    the warm-up a sweep's workers have, now and as at ``commit`` in turn,
    ``pairs`` times over further runs (after one untimed process of each: a
    checkout compiles its kernels once): CPU per row (medians; each in
    brackets) and the ratio pair by pair."""
    with tempfile.TemporaryDirectory() as tmp:
        os.mkdir(f"{tmp}/then")
        then = _user_env(
            PYTHONPATH=_checkout(commit, f"{tmp}/then"),
            WMR_MISSION_FOREGROUND_COMPILE="1",
            # Its own cache: kernels of other sources in the same one remove
            # this checkout's as they are written, and the other way round
            # (kernels.cache), so every process of each would compile again.
            NUMBA_CACHE_DIR=f"{tmp}/then-kernels",
        )
        envs = {"now": _user_env(), commit: then}

        def cpu_per_row(env: dict[str, str], first: int) -> float:
            command = [sys.executable, "-c", _TASK_ROWS, str(CAMPAIGN), str(first), str(runs)]
            done = subprocess.run(command, env=env, cwd=tmp, capture_output=True, text=True)
            return float(done.stdout.strip().splitlines()[-1])

        for env in envs.values():
            cpu_per_row(env, 20)
        spent: dict[str, list[float]] = {label: [] for label in envs}
        for i in range(pairs):
            first = 20 + (i * runs) % (2000 - 20 - runs)
            for label in list(envs) if i % 2 else list(envs)[::-1]:
                spent[label].append(cpu_per_row(envs[label], first))
    for label, values in spent.items():
        each = ", ".join(f"{value:.0f}" for value in values)
        print(f"{label}: CPU per row {statistics.median(values):.0f} us ({each})")
    ratios = [a / b for a, b in zip(spent["now"], spent[commit], strict=True)]
    print(f"now / {commit}, pair by pair: {_medians(ratios)}")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def workers(rounds: int = 3, runs: int = 400) -> None:
    """What two workers cost each other: a worker's task of ``runs`` runs of
    case2-headings (``_TASK_ROWS``) alone, then two at once, ``rounds`` times
    (CPU per row); then the workers' CPU of `sweep --workers 2 --no-plots`
    over 200 runs and over 2000, twice each: the CPU a run adds, and what is
    fixed."""
    with tempfile.TemporaryDirectory() as tmp:

        def started(first: int) -> subprocess.Popen[str]:
            command = [sys.executable, "-c", _TASK_ROWS, str(CAMPAIGN), str(first), str(runs)]
            return subprocess.Popen(command, stdout=subprocess.PIPE, text=True, cwd=tmp)

        def cpu_per_row(task: subprocess.Popen[str]) -> float:
            return float(task.communicate()[0].split()[-1])

        for _ in range(rounds):
            alone = cpu_per_row(started(20))
            together = [cpu_per_row(task) for task in (started(20 + runs), started(20 + 2 * runs))]
            both = statistics.mean(together) / alone
            print(
                f"a task of {runs} runs, CPU per row [us]: alone {alone:.0f}, two at once "
                f"{together[0]:.0f} and {together[1]:.0f} (x{both:.2f})"
            )
        spent: dict[int, list[float]] = {200: [], 2000: []}
        for round_ in range(2):
            for count in spent:
                out, report = f"{tmp}/out-{count}-{round_}", f"{tmp}/cpu"
                command = [sys.executable, "-c", _SWEEP_CPU, "sweep", str(CAMPAIGN), "--runs"]
                command += [str(count), "--workers", "2", "--no-plots", "--out", out]
                _wall(command, _user_env(WMR_CPU_REPORT=report), check=False)
                spent[count].append(float(Path(report).read_text().split()[1]))
    few, many = statistics.mean(spent[200]), statistics.mean(spent[2000])
    per_run = (many - few) / 1800
    print(
        f"the sweep's workers, CPU [s]: 200 runs {spent[200]}, 2000 runs {spent[2000]}: "
        f"{per_run * 1000:.2f} ms a run, {few - 200 * per_run:.2f} s fixed"
    )
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def sweep_against(pairs: int = 3) -> None:
    """`sweep missions/campaigns/case2-headings.yaml --no-plots --workers 2` as
    now and as at COMMIT (`sweep COMMIT`: its package unpacked on PYTHONPATH,
    its kernels compiled first), in turn, ``pairs`` times after one untimed
    round: CPU seconds (the command and its workers), campaign.json's
    missions_per_second, and the CPU ratios pair by pair."""
    import json
    import shutil

    if len(sys.argv) < 3:
        sys.exit("usage: python benchmarks/measure.py sweep COMMIT")
    against = sys.argv[2]
    cpu: list[list[float]] = [[], []]
    rates: list[list[float]] = [[], []]
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # `python -m` puts the working directory before PYTHONPATH
        os.mkdir(f"{tmp}/then")
        then = {**_user_env(), "PYTHONPATH": _checkout(against, f"{tmp}/then")}
        subprocess.run([sys.executable, "-m", "wmr_mission", "compile"], env=then, check=True)
        sweep = [sys.executable, "-m", "wmr_mission", "sweep", str(CAMPAIGN), "--no-plots"]
        for round_ in range(pairs + 1):  # the first round untimed: bytecode, caches
            for i, env in enumerate((_user_env(), then)):
                out = f"{tmp}/out"
                shutil.rmtree(out, ignore_errors=True)
                # exit 1 when the campaign's expect is not met: still a measurement
                _, seconds = _wall([*sweep, "--workers", "2", "--out", out], env, check=False)
                record = json.loads(Path(f"{out}/campaign.json").read_text(encoding="utf-8"))
                if round_:
                    cpu[i].append(seconds)
                    rates[i].append(record["missions_per_second"])
    for name, used, rate in zip(("now", f"at {against}"), cpu, rates, strict=True):
        print(
            f"sweep --workers 2 --no-plots {name}: CPU "
            f"{', '.join(f'{s:.1f}' for s in used)} s; missions_per_second "
            f"{', '.join(f'{r:.1f}' for r in rate)}"
        )
    ratios = ", ".join(f"{now / then:.3f}" for now, then in zip(*cpu, strict=True))
    print(f"CPU now / {against}, pair by pair: {ratios} (median {_ratio(cpu[1], cpu[0]):.3f})")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def runner_cost(repeat: int = 3) -> None:
    """The runner's own time around the compiled loop, per run of case2-headings
    (its runs 1-200, planned beforehand as a campaign's worker plans them,
    written into their base's plan, each run ``repeat`` times): medians
    of ``run_mission``, of its calls of the compiled loop (passing the records
    in included, through numba's dispatcher or straight to the compiled entry
    point) and of the rest, the runner's Python; and how many of the calls
    numba's dispatcher typed. Then the runner's parts, medians per run: the
    run set up (``_Run``), the noise drawn (``Draws``), the paths sampled
    ahead, the phases entered, the result made."""
    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.plan import Plan
    from wmr_mission.campaign.written import written_runs
    from wmr_mission.kernels import jit, loop
    from wmr_mission.sim import runner
    from wmr_mission.sim.plan import MissionPlan

    loaded = load_campaign(CAMPAIGN)
    plan = Plan(loaded.campaign)
    runs = written_runs(loaded)
    missions: list[MissionPlan] = []
    for run in range(201):
        written, _, _ = runs.run(plan.draw(run))
        assert written is not None
        missions.append(written)
    runner.run_mission(missions[0])  # loads the compiled loop
    segment = runner._Run._segment
    inside = [0, 0]  # ns in the compiled loop, calls
    typed = [0]  # calls numba's dispatcher typed

    by_phase: dict[int, list[tuple[float, int]]] = {}  # per phase: (us, samples) of each call

    def timed_segment(self: runner._Run, phase: Any, *args: Any) -> int:
        before = int(self.signals.counters[loop.K])
        started = time.perf_counter_ns()
        status = segment(self, phase, *args)
        spent = time.perf_counter_ns() - started
        inside[0] += spent
        inside[1] += 1
        samples = int(self.signals.counters[loop.K]) - before
        if samples:
            by_phase.setdefault(phase.number, []).append((spent / 1000, samples))
        return status

    class Counted:  # the run's dispatcher, its calls counted
        def __init__(self, dispatcher: Any) -> None:
            self.dispatcher, self.overloads = dispatcher, dispatcher.overloads

        def __call__(self, *args: Any) -> int:
            typed[0] += 1
            return int(self.dispatcher(*args))

    compiled = jit.compiled

    def counted(fn: Any, **options: Any) -> Any:
        made = compiled(fn, **options)
        return Counted(made) if hasattr(made, "overloads") else made

    # The runner's parts: each method's CPU per run (ns), by its wrapper.
    parts = {
        "set up": (runner._Run, "__init__"),
        "noise drawn": (runner.Draws, "__init__"),
        "noise drawn ": (runner.Draws, "ahead"),
        "paths sampled ahead": (runner.PhaseRun, "path_ahead"),
        "phases entered": (runner.PhaseRun, "enter"),
        "result made": (runner._Run, "_result"),
    }
    part_ns = dict.fromkeys(parts, 0)
    originals = {name: getattr(owner, method) for name, (owner, method) in parts.items()}

    def timed_part(name: str) -> Any:
        original = originals[name]

        def timed(*args: Any, **kwargs: Any) -> Any:
            started = time.thread_time_ns()
            done = original(*args, **kwargs)
            part_ns[name] += time.thread_time_ns() - started
            return done

        return timed

    runner._Run._segment = timed_segment  # type: ignore[method-assign]
    jit.compiled = counted  # type: ignore[assignment]  # read as a run starts
    for name, (owner, method) in parts.items():
        setattr(owner, method, timed_part(name))
    whole, inner, calls, dispatched = [], [], [], []
    per_run: dict[str, list[float]] = {name.strip(): [] for name in parts}
    try:
        for _ in range(repeat):
            for compiled_mission in missions[1:]:
                inside[:] = [0, 0]
                typed[0] = 0
                part_ns.update(dict.fromkeys(parts, 0))
                started = time.perf_counter_ns()
                runner.run_mission(compiled_mission)
                whole.append((time.perf_counter_ns() - started) / 1000)
                for name in per_run:
                    per_run[name].append(sum(v for k, v in part_ns.items() if k.strip() == name))
                inner.append(inside[0] / 1000)
                calls.append(inside[1])
                dispatched.append(typed[0])
    finally:
        runner._Run._segment = segment  # type: ignore[method-assign]
        jit.compiled = compiled
        for name, (owner, method) in parts.items():
            setattr(owner, method, originals[name])
    rest = [w - c for w, c in zip(whole, inner, strict=True)]
    print(
        f"case2-headings runs 1-200, {repeat} times each, medians per run: run_mission "
        f"{statistics.median(whole):.0f} us; the compiled loop "
        f"{statistics.median(inner):.0f} us in {statistics.mean(calls):.2f} calls, "
        f"{statistics.mean(dispatched):.2f} of them typed by numba's dispatcher; "
        f"the rest {statistics.median(rest):.0f} us"
    )
    for number, calls_of in sorted(by_phase.items()):
        spent_us = sum(us for us, _ in calls_of)
        samples_of = sum(n for _, n in calls_of)
        print(
            f"  phase {number}: {samples_of / len(missions[1:]) / repeat:.0f} samples a run, "
            f"{spent_us / samples_of:.3f} us a sample in the compiled loop (calls that ran samples)"
        )
    print(
        "  of the runner's Python, medians per run [us]: "
        + ", ".join(f"{name} {statistics.median(ns) / 1000:.0f}" for name, ns in per_run.items())
    )
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


# `sweep CAMPAIGN --no-plots --workers 2 --out DIR` in this process, the CPU
# clock (of the process, all its threads) read around each of its steps.
_SWEEP_STEPS = """
import sys, time
started = time.process_time()
from wmr_mission.campaign import sweep
from wmr_mission.cli import main
imported = time.process_time()
spent = {}
def timed(name):
    step = getattr(sweep, name)
    def run(*args, **kwargs):
        began = time.process_time()
        try:
            return step(*args, **kwargs)
        finally:
            spent[name] = spent.get(name, 0.0) + time.process_time() - began
    setattr(sweep, name, run)
for name in ("warm_up", "_execute", "_record", "_worst_and_figures"):
    timed(name)
sys.argv = ["wmr-mission", "sweep", *sys.argv[1:]]
try:
    main()
except SystemExit:
    pass
spent["_execute"] -= spent["warm_up"]
print(f"imports {imported - started:.3f}", *(f"{k} {v:.3f}" for k, v in spent.items()),
      f"in all {time.process_time() - started:.3f}")
"""


def sweep_steps(repeat: int = 3) -> None:
    """The CPU of the sweep's own process by step, `sweep
    missions/campaigns/case2-headings.yaml --no-plots --workers 2`, ``repeat``
    times: its imports, the warm-up (numba and the kernels loaded, two runs),
    the runs (the rows taken, written and counted), the record, the worst
    runs' directories [s]."""
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeat):
            command = [sys.executable, "-c", _SWEEP_STEPS, str(CAMPAIGN), "--no-plots"]
            command += ["--workers", "2", "--out", f"{tmp}/out-{i}"]
            done = subprocess.run(command, capture_output=True, text=True, cwd=tmp)
            print(done.stdout.strip().splitlines()[-1])
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def _drawing_code_at(commit: str) -> tuple[Any, Any]:
    """plots.py and campaign/figures.py as they were at ``commit``, loaded beside
    today's (the rest of the package is today's): both drawn in one process."""
    import types

    # Modules of the drawing code since removed, loaded under their names.
    for name, path in (("wmr_mission.output.unseen", "wmr_mission/output/unseen.py"),):
        shown = ["git", "-C", str(ROOT), "show", f"{commit}:{path}"]
        found = subprocess.run(shown, check=False, capture_output=True, text=True)
        if found.returncode == 0 and name not in sys.modules:
            module = types.ModuleType(name)
            sys.modules[name] = module
            exec(compile(found.stdout, f"{commit}:{path}", "exec"), module.__dict__)
    modules = []
    for name, path in (
        ("plots_then", "wmr_mission/output/figures.py"),
        ("figures_then", "wmr_mission/campaign/figures.py"),
    ):
        shown = ["git", "-C", str(ROOT), "show", f"{commit}:{path}"]
        text = subprocess.run(shown, check=True, capture_output=True, text=True).stdout
        text = text.replace("from wmr_mission.output.figures import", "from plots_then import")
        module = types.ModuleType(name)
        sys.modules[name] = module
        exec(compile(text, f"{commit}:{path}", "exec"), module.__dict__)
        modules.append(module)
    return modules[0], modules[1]


def _bounds_argument(figures: Any, loaded: Any) -> tuple[Any, ...]:
    """The mission's bounds for ``_histograms``, where the code takes them."""
    import inspect

    if "bounds" not in inspect.signature(figures._histograms).parameters:
        return ()
    from wmr_mission.campaign.sweep import _bounds, _mission

    return (_bounds(_mission(loaded)),)


def _saved(plots: Any, figure: Any, path: Path) -> None:
    """``figure`` written as ``plots`` writes figure files (by the name it had then)."""
    save = getattr(plots, "save_figure", None) or plots._save
    save(figure, path)


def _run_figure(plots: Any, result: Any, name: str, path: Path) -> None:
    if hasattr(plots, "_figure"):
        _saved(plots, plots._figure(result, name), path)
    else:  # before the figure was built apart from its file
        plots._write(result, name, path)


def drawing(repeat: int = 5) -> None:
    """CPU seconds of what a campaign draws after its runs (case2-headings, 2000
    runs): the walk counting the runs through each pixel, each campaign figure
    built and saved, each figure of the first worst run, and its whole
    directory. ``drawing COMMIT`` also draws each figure with the drawing code
    of COMMIT, in turn with today's, and prints both and their ratio."""
    import gc

    from wmr_mission.campaign import figures
    from wmr_mission.campaign.aggregate import Aggregate
    from wmr_mission.campaign.coverage import runs_per_pixel
    from wmr_mission.campaign.engine import execute, warm_up
    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.plan import Plan
    from wmr_mission.campaign.rows import simulate
    from wmr_mission.campaign.sweep import _regions, _write_run_dir
    from wmr_mission.output import figures as plots
    from wmr_mission.stopping import StopSignals

    against = sys.argv[2] if len(sys.argv) > 2 else None
    codes = {"now": (plots, figures)}
    if against is not None:
        codes[against] = _drawing_code_at(against)
    loaded = load_campaign(CAMPAIGN)
    aggregate = Aggregate(dict(loaded.campaign.vary))
    with StopSignals() as stop:
        seconds = warm_up(loaded).seconds_per_run
        for rows in execute(loaded, workers=2, scheduler=None, seconds_per_run=seconds, stop=stop):
            for row in rows:
                aggregate.add(row)
    regions = _regions(loaded)
    paths = [p for _, p in aggregate.drawn]
    worst = [run for run, *_ in aggregate.worst_runs()]
    result, _ = simulate(loaded, Plan(loaded.campaign).draw(worst[0]))

    def cpu(jobs: dict[str, Any]) -> dict[str, float]:
        """Median CPU seconds of each job, the jobs taken in turn in every round.
        Each starts with the previous one's garbage collected: a figure leaves
        thousands of artists in cycles, and whichever job ran next would pay
        for collecting them."""
        for job in jobs.values():
            job()  # fonts, caches
        times: dict[str, list[float]] = {key: [] for key in jobs}
        for _ in range(repeat):
            for key, job in jobs.items():
                gc.collect()
                started = time.process_time()
                job()
                times[key].append(time.process_time() - started)
        return {key: statistics.median(spent) for key, spent in times.items()}

    def show(what: str, spent: dict[str, float]) -> None:
        line = f"  {what}: {spent['now']:.3f}"
        if against is not None and spent[against] > 0:
            line += f" ({against}: {spent[against]:.3f}, ratio {spent['now'] / spent[against]:.2f})"
        elif against is not None:
            line += f" ({against}: not drawn then)"
        print(line)

    print(f"case2-headings, {aggregate.runs} runs, CPU seconds, median of {repeat}:")
    walk = cpu({"now": lambda: runs_per_pixel(paths, (-6.5, 6.5, -3.7, 3.7), (389, 651))})
    points = sum(p.shape[1] for p in paths)
    print(f"  runs through each pixel, {len(paths)} paths of {points} points: {walk['now']:.3f}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, build in (
            ("trajectories", lambda f: f._trajectories(aggregate, regions)),
            ("metrics", lambda f: f._histograms(aggregate, *_bounds_argument(f, loaded))),
            ("success", lambda f: f._success_over_axes(aggregate)),
        ):
            spent = cpu(
                {
                    key: lambda p=p, f=f, b=build, n=name: _saved(p, b(f), Path(tmp) / f"{n}.png")
                    for key, (p, f) in codes.items()
                }
            )
            show(f"{name}.png built and saved", spent)
        total = dict.fromkeys(codes, 0.0)
        for name in plots.FIGURE_NAMES:
            spent = cpu(
                {
                    key: lambda p=p, n=name: _run_figure(p, result, n, Path(tmp) / f"{n}.png")
                    for key, (p, _) in codes.items()
                    if name in p.FIGURE_NAMES  # a figure the code drew then
                }
            )
            spent = {key: spent.get(key, 0.0) for key in codes}
            show(f"worst run {worst[0]}, {name}.png", spent)
            total = {key: total[key] + spent[key] for key in codes}
        show(f"worst run {worst[0]}, its figures", total)
        directory = cpu({"now": lambda: _write_run_dir(loaded, worst[0], Path(tmp) / "w", True)})
        print(f"  one worst run's directory with its four figures: {directory['now']:.3f}")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def png(repeat: int = 7) -> None:
    """CPU milliseconds for Pillow to write each of case study 2's four
    figures (drawn once), at its default zlib level and at the one files use."""
    import io

    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    from wmr_mission.output.figures import FIGURE_NAMES, PNG_OPTIONS, _figure
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission

    result = run_mission(load_mission(MISSIONS / "case2.yaml"))
    for name in FIGURE_NAMES:
        canvas: Any = FigureCanvasAgg(_figure(result, name))
        canvas.draw()
        image = Image.fromarray(np.asarray(canvas.buffer_rgba()))
        shown = []
        for options in ({}, PNG_OPTIONS):
            times, size = [], 0
            for _ in range(repeat):
                stream = io.BytesIO()
                started = time.process_time()
                image.save(stream, format="png", **options)
                times.append(time.process_time() - started)
                size = stream.tell()
            what = "default" if not options else f"compress_level {options['compress_level']}"
            shown.append(f"{what} {statistics.median(times) * 1000:.1f} ms, {size / 1024:.0f} kB")
        print(f"{name}.png: " + "; ".join(shown))
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def checks(repeat: int = 3) -> None:
    """Seconds ``validate`` spends on a campaign (``check_file``): one axis of
    10 000 choice values, all the same or all different, and a campaign of
    nearly a megabyte, which is refused for its size."""
    from wmr_mission.campaign.load import MAX_CAMPAIGN_BYTES, check_file

    mission = ROOT / "tests" / "data" / "campaigns" / "short.yaml"
    axes = {
        "10 000 values, all the same": ", ".join(["0.0100"] * 10_000),
        "10 000 values, all different": ", ".join(f"0.{i:04d}" for i in range(10_000)),
    }
    with tempfile.TemporaryDirectory() as tmp:
        files = {}
        for name, values in axes.items():
            files[name] = Path(tmp) / f"{len(files)}.yaml"
            files[name].write_text(
                f"version: 1\nname: c\nmission: {mission}\nruns: 2\n"
                f"vary:\n  sensors.noise_std.x: {{choice: [{values}]}}\n"
            )
        files["nearly 1 MB"] = Path(tmp) / "large.yaml"
        line = f"  sensors.noise_std.x: {{choice: [{axes['10 000 values, all the same']}]}}\n"
        files["nearly 1 MB"].write_text(
            f"version: 1\nname: c\nmission: {mission}\nruns: 2\nvary:\n" + line * 12
        )
        for name, path in files.items():
            spent = []
            for _ in range(repeat):
                started = time.perf_counter()
                problems = check_file(path)
                spent.append(time.perf_counter() - started)
            said = "valid" if not problems else problems[0].message[:60]
            print(
                f"{name} ({path.stat().st_size} bytes, limit {MAX_CAMPAIGN_BYTES}): "
                f"{statistics.median(spent):.3f} s, {said}"
            )


def plugins(repeat: int = 7) -> None:
    """The whole loop per sample [us] on missions/figure-eight.yaml with
    Kanayama's law built in (compiled), as a numba jitclass plug-in and as a
    plain-Python plug-in (tests/plugin_examples.py), runs alternating in one
    process after one untimed run each; medians."""
    sys.path.insert(0, str(ROOT / "tests"))
    from wmr_mission.api import load_mission
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission

    gains = {"x": 10, "y": 64, "theta": 16}
    controllers = {
        "built in (kanayama)": {"type": "kanayama"},
        "jitclass plug-in": {
            "type": "python",
            "entry": "plugin_examples:compiled",
            "params": gains,
        },
        "plain-Python plug-in": {
            "type": "python",
            "entry": "plugin_examples:plain",
            "params": gains,
        },
    }
    plans = {
        name: plan_mission(load_mission(MISSIONS / "figure-eight.yaml", {"controller": settings}))
        for name, settings in controllers.items()
    }
    for plan in plans.values():
        run_mission(plan)  # loads or compiles
    times: dict[str, list[float]] = {name: [] for name in plans}
    for _ in range(repeat):
        for name, plan in plans.items():
            result = run_mission(plan)
            times[name].append(result.loop_ns / result.samples / 1000.0)
    built_in = statistics.median(times["built in (kanayama)"])
    for name, us in times.items():
        median = statistics.median(us)
        print(f"{name:<22} {median:8.3f} us per sample ({median / built_in:6.1f}x built in)")


# Each compile in a new process with an empty cache: its run made as plain
# Python, then what it compiles timed.
_COMPILE_WAITS = {
    "the campaign's pixel counts": (
        "import numpy as np; from wmr_mission.kernels import jit; jit.load(); "
        "from wmr_mission.campaign.coverage import runs_per_pixel as timed\n"
        "args = ([np.zeros((2, 3))], (0.0, 1.0, 0.0, 1.0), (4, 4))"
    ),
    "the judge's passes": (
        "from wmr_mission.kernels import jit; from wmr_mission.commands import compile as c\n"
        "jit.load()\n"
        "with jit.plain_python_meanwhile():\n"
        "    r = c._run(c.first_variant())\n"
        "timed, args = c._judge, (r,)"
    ),
    "the EKF band's replay": (
        "from wmr_mission import load_mission, run_mission; from wmr_mission.kernels import jit\n"
        "from wmr_mission.output.covariance import estimate_std as timed\n"
        "jit.load()\n"
        "with jit.plain_python_meanwhile():\n"
        f"    args = (run_mission(load_mission({str(MISSIONS / 'noisy-ekf.yaml')!r})),)"
    ),
}


def compile_waits() -> None:
    """What each compile a user may wait on besides the loop's costs from an
    empty cache, in a process of its own: CPU and wall seconds."""
    for name, setup in _COMPILE_WAITS.items():
        code = (
            f"{setup}\nimport time\nc0, w0 = time.process_time(), time.perf_counter()\n"
            "timed(*args)\nprint(time.process_time() - c0, time.perf_counter() - w0)"
        )
        with tempfile.TemporaryDirectory() as cache:
            env = {k: v for k, v in os.environ.items() if k != "WMR_MISSION_NO_JIT"}
            env["NUMBA_CACHE_DIR"] = cache
            done = subprocess.run(
                [sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True
            )
        cpu, wall = (float(word) for word in done.stdout.split()[-2:])
        print(f"{name:<28} {cpu:6.1f} s of CPU, {wall:6.1f} s of wall time")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


def band(repeat: int = 5) -> None:
    """The EKF's +-3 std band of missions/noisy-ekf.yaml (wmr_mission/output/
    covariance.py): the replay in a fresh process (its compiled form loaded
    from the cache), and as plain Python; medians of ``repeat``."""
    code = (
        "import time; from wmr_mission import load_mission, run_mission; "
        "from wmr_mission.output.covariance import estimate_std; "
        f"r = run_mission(load_mission({str(MISSIONS / 'noisy-ekf.yaml')!r})); "
        "t = time.perf_counter(); estimate_std(r); print(time.perf_counter() - t, r.samples)"
    )
    for label, extra in (("compiled", {}), ("plain Python", {"WMR_MISSION_NO_JIT": "1"})):
        env = {**os.environ, **extra}
        subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True)
        seconds, samples = [], 0
        for _ in range(repeat):
            done = subprocess.run(
                [sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True
            )
            took, count = done.stdout.split()
            seconds.append(float(took))
            samples = int(count)
        median = statistics.median(seconds)
        print(
            f"{label:<13} {median * 1000:8.2f} ms for {samples} samples "
            f"({median / samples * 1e6:.2f} us a sample)"
        )


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else ""
    jobs = {"loop": loop, "startup": startup, "compile": compile_times, "memory": memory}
    jobs |= {"plain": plain, "scale": scale, "threshold": threshold, "stages": stages}
    jobs |= {"short": short}
    jobs |= {"cuts": cuts, "imports": imports, "parts": parts, "classes": classes}
    jobs |= {"llvm": llvm, "compiletasks": compile_tasks, "compileorder": compile_order}
    jobs |= {"compilewaits": compile_waits}
    jobs |= {"figures": figures, "distance": distance, "dare": dare, "dlqr": dlqr}
    jobs |= {
        "campaign": campaign,
        "judge": judge_cost,
        "judgeparts": judge_parts,
        "sweep": sweep_against,
        "runner": runner_cost,
        "task": task,
        "workers": workers,
        "parent": sweep_steps,
        "drawing": drawing,
        "png": png,
        "checks": checks,
        "plugins": plugins,
        "band": band,
        "session": session,
        "csv": csv_cost,
    }
    if what not in jobs:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    if what == "loop" and sys.argv[2:] and not sys.argv[2].endswith(".yaml"):
        loop_against(sys.argv[2], sys.argv[3:])
    elif what == "loop":
        loop(*sys.argv[2:])
    elif what == "parts":
        parts(*sys.argv[2:])
    elif what == "task" and sys.argv[2:]:
        task_against(sys.argv[2])
    else:
        jobs[what]()
