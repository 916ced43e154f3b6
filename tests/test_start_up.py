"""Start-up: `run` runs a short mission as plain Python and a long one
compiled, never compiling in the background; ``wmr-mission compile``
(wmr_mission.commands.compile); the kernel cache's locator; numba loaded
without scipy's linear algebra; the plain-Python form of a kernel."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import IO, cast

import numpy as np
import pytest
from conftest import the_tests_package

from wmr_mission.commands import compile as compile_loop
from wmr_mission.controllers import CONTROLLERS
from wmr_mission.estimators import ESTIMATORS
from wmr_mission.kernels import cache as kernel_cache
from wmr_mission.kernels import jit, loop
from wmr_mission.output.progress import Steps
from wmr_mission.output.rundir import write_trajectory
from wmr_mission.sim import runner
from wmr_mission.sim.plan import plan_mission, sample_budget
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission
from wmr_mission.verdicts import passes

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
HOUR = Path(__file__).resolve().parent.parent / "benchmarks" / "hour.yaml"

pytestmark = pytest.mark.skipif(not jit.compiling(), reason="the compiled build only")


@pytest.fixture(autouse=True)
def _cache_directory_found_again() -> Iterator[None]:
    """The cache directory found afresh after each test, once its monkeypatch
    is undone: a test here that points NUMBA_CACHE_DIR at a directory of its
    own and asks for the cache directory leaves it remembered
    (``functools.cache``), and a later test in the process copied or compiled
    into that directory instead of the session's (tests/test_compile_side_by_side.py,
    compiled every loop again: 119 s of CPU)."""
    yield
    kernel_cache.cache_directory.cache_clear()


def _env(cache: Path, **more: str) -> dict[str, str]:
    """A user's environment, the kernel cache in ``cache``, the tests' package
    (conftest.the_tests_package: the processes run in ``tmp_path``)."""
    env = {key: value for key, value in os.environ.items() if key != compile_loop.NO_JIT}
    return the_tests_package({**env, "NUMBA_CACHE_DIR": str(cache), **more})


# Runs `wmr-mission run`, recording every process it starts and, as it exits,
# whether numba was loaded and which compiled functions were called.
RUN_RECORDING = """
import atexit, subprocess, sys
record = sys.argv.pop(1)
if sys.argv[1] == "--unwritable":  # no directory can be written (as root too)
    import tempfile
    sys.argv.pop(1)
    def unwritable(*args, dir=None, **kwargs):
        raise PermissionError(13, "Permission denied", str(dir))
    tempfile.TemporaryFile = unwritable
def started(args, *more, **kwargs):
    with open(record, "a") as f:
        f.write(f"started {args}\\n")
    raise OSError("no process in this test")
subprocess.Popen = started
def loaded():
    # Each compiled function Python calls loads its own cache entry.
    from wmr_mission.kernels import jit
    called = jit.entries()
    with open(record, "a") as f:
        f.write(f"numba loaded: {'numba' in sys.modules}\\n")
        f.write(f"scipy.linalg loaded: {'scipy.linalg' in sys.modules}\\n")
        if called:
            f.write(f"compiled entries: {' '.join(called)}\\n")
            f.write(f"numba's arrays loaded: {'numba.np.arrayobj' in sys.modules}\\n")
            from numba.core.runtime import nrt
            f.write(f"numba's reference counting made: {nrt.rtsys._init}\\n")
atexit.register(loaded)
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import main
main()
"""


def _run(env: dict[str, str], out: Path, record: Path, mission: Path, *flags: str) -> str:
    run = ["run", str(mission), "--no-plots", "--out", str(out)]
    done = subprocess.run(
        [sys.executable, "-c", RUN_RECORDING, str(record), *flags, *run],
        env=env,
        cwd=record.parent,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    return done.stderr


def _long_mission(tmp_path: Path, bound: int = compile_loop.PLAIN_PYTHON_SAMPLES) -> Path:
    """benchmarks/hour.yaml cut to one sample over a plain-Python bound."""
    seconds = bound * 0.01
    path = tmp_path / f"long-{bound}.yaml"
    path.write_text(HOUR.read_text().replace("elapsed: 3600", f"elapsed: {seconds:.2f}"))
    assert sample_budget(load_mission(path)) == bound + 2
    return path


def test_a_run_before_the_compile_is_plain_python_and_starts_nothing(tmp_path: Path) -> None:
    """Case study 2 with an empty cache: its budget (15 004 samples) is over the
    bound of a ready cache, under that of an empty one, where loading the loop
    would mean compiling it (docs/performance.md, Start-up): no numba, no
    process started, no notice, the same bytes as compiled."""
    record = tmp_path / "record"
    stderr = _run(
        _env(tmp_path / "empty-cache"), tmp_path / "first", record, MISSIONS / "case2.yaml"
    )
    assert "wmr-mission:" not in stderr, stderr
    assert record.read_text().splitlines() == ["numba loaded: False", "scipy.linalg loaded: False"]
    # Nothing compiled, nothing cached: the cache was looked for (is it ready?)
    assert [p for p in (tmp_path / "empty-cache").rglob("*") if p.is_file()] == []
    compiled = write_trajectory(run_mission(load_mission(MISSIONS / "case2.yaml")), tmp_path / "c")
    assert (tmp_path / "first" / "trajectory.csv").read_bytes() == compiled.read_bytes()
    # The run directory says so: its loop_us_per_sample is plain Python's
    manifest = json.loads((tmp_path / "first" / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["loop"] == "plain Python"


def test_without_a_writable_cache_a_short_run_is_plain_python_and_says_nothing(
    tmp_path: Path,
) -> None:
    record = tmp_path / "record"
    stderr = _run(_env(tmp_path / "c"), tmp_path / "first", record, MISSIONS / "fence.yaml",
                  "--unwritable")  # fmt: skip
    assert "wmr-mission:" not in stderr
    assert record.read_text().splitlines() == ["numba loaded: False", "scipy.linalg loaded: False"]


def _cache_of_this_session(tmp_path: Path) -> Path:
    """A copy of the kernels this test session compiled (their index does not
    name its directory), every built-in loop among them: the warm-up's runs
    compile here those no test compiled yet, once for the session (a fresh
    clone's), not in the copy and again in this process."""
    for warm_up in compile_loop.warm_up_missions():
        run_mission(plan_mission(warm_up))
    run_mission(plan_mission(load_mission(MISSIONS / "fence.yaml")))
    source = kernel_cache.cache_directory()
    assert source is not None
    # numba's own, as the package pointed it when it loaded numba
    assert str(source) == os.environ["NUMBA_CACHE_DIR"]
    cache = tmp_path / "cache"
    shutil.copytree(
        source,
        cache / "wmr_mission" / source.name,
        ignore=shutil.ignore_patterns("*.lock", compile_loop.READY),
    )
    return cache


def test_the_compile_notices_say_the_times_measured() -> None:
    """The notice before a compile in the foreground and `wmr-mission
    compile`'s line say the times docs/performance.md measured ("How long a
    compile takes"): each its own, one variant's or every variant's."""
    text = (MISSIONS.parent / "docs" / "performance.md").read_text(encoding="utf-8")
    doc = " ".join(text.split())
    said = re.search(
        r'The notice before a compile in the foreground says "([^"]+)", and '
        r'`wmr-mission compile` "([^"]+)"',
        doc,
    )
    assert said is not None, "docs/performance.md no longer says what the notices say"
    one, every = said.groups()
    assert one == jit.ONE_VARIANT
    assert every == compile_loop.EVERY_VARIANT
    assert f"({one}, once;" in jit.NOTICE
    out = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "compile", "--help"],
        capture_output=True, text=True, timeout=60, check=True,
    ).stdout  # fmt: skip
    assert every.removeprefix("every variant: ") in " ".join(out.split())


def test_compile_compiles_the_judges_kernels_too(tmp_path: Path) -> None:
    """`wmr-mission compile` leaves nothing for a long run's judge to compile:
    its distance to the path, places on it and passes over a phase's samples
    are in the cache after it."""
    cache = _cache_of_this_session(tmp_path)
    (kernels,) = (cache / "wmr_mission").iterdir()
    judges = (
        "path_distance._distances-*",
        "path_distance._first_in_cells-*",
        "placing.place_samples-*",
        "placing.path_lengths-*",
        *(f"passes.{name}-*" for name in passes.__all__),
    )
    for pattern in judges:
        for compiled in kernels.rglob(pattern):
            compiled.unlink()
    command = [sys.executable, "-m", "wmr_mission", "compile"]
    done = subprocess.run(
        command, env=_env(cache), cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    for pattern in judges:
        assert list(kernels.rglob(pattern)), pattern


def test_compile_marks_the_cache_ready_and_a_long_run_loads_it(tmp_path: Path) -> None:
    """`wmr-mission compile`, here on kernels already compiled so that it takes
    seconds, not a compile. Before it, a mission over the bound of a ready
    cache runs as plain Python and says nothing, one over the bound of an
    empty cache loads (or compiles) the loop in the foreground and says so;
    after it, the first loads the compiled loop (run_segment and the paths'
    math, numba set up without scipy's linear algebra) and the judge's
    distance to the path, not the judge's other passes (they pay from
    kernels/jit.JUDGED_COMPILED_FROM samples on), nor numba's arrays, nor
    its reference-counting runtime (none of these counts references), and
    says nothing; its trajectory is plain Python's, byte for byte."""
    cache = _cache_of_this_session(tmp_path)
    (kernels,) = (cache / "wmr_mission").iterdir()
    ready = kernels / compile_loop.READY
    long = _long_mission(tmp_path)
    record = tmp_path / "record"
    plain_python = ["numba loaded: False", "scipy.linalg loaded: False"]
    stderr = _run(_env(cache), tmp_path / "unready", record, long)
    assert "wmr-mission:" not in stderr
    assert record.read_text().splitlines() == plain_python
    record.unlink()
    longer = _long_mission(tmp_path, compile_loop.PLAIN_PYTHON_SAMPLES_UNCOMPILED)
    stderr = _run(_env(cache), tmp_path / "longer", record, longer)
    assert stderr.count("wmr-mission: loading the simulation loop, compiled first") == 1
    assert record.read_text().splitlines()[0] == "numba loaded: True"
    command = [sys.executable, "-m", "wmr_mission", "compile"]
    done = subprocess.run(
        command, env=_env(cache), cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    assert str(kernels) in done.stdout
    assert ready.read_text().split()[0] == kernel_cache.kernel_sources_stamp()
    assert ready.read_text() == compile_loop.ready_stamp()
    again = subprocess.run(
        command, env=_env(cache), cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert "already" in again.stdout
    record.unlink()
    stderr = _run(_env(cache), tmp_path / "next", record, long)
    assert "wmr-mission:" not in stderr
    assert record.read_text().splitlines() == [
        "numba loaded: True",
        "scipy.linalg loaded: False",
        # its 5 502 samples judged by numpy but for the distance to the path
        "compiled entries: _distances _each run_segment",
        "numba's arrays loaded: False",
        "numba's reference counting made: False",
    ]
    manifest = json.loads((tmp_path / "next" / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["loop"] == "compiled"
    trajectory = "trajectory.csv"
    assert (tmp_path / "next" / trajectory).read_bytes() == (
        tmp_path / "unready" / trajectory
    ).read_bytes()
    # A marker of other kernel sources, or of another numba, is no marker.
    ready.write_text(compile_loop.ready_stamp().replace("numba-", "numba-0.1+"))
    record.unlink()
    _run(_env(cache), tmp_path / "edited", record, long)
    assert record.read_text().splitlines() == plain_python


CHOOSE = """
import sys
from wmr_mission.commands.compile import choose_loop
print(choose_loop(int(sys.argv[1])))
from wmr_mission.kernels import jit
print(jit.compiling(), jit.loaded(), "numba" in sys.modules)
"""


PLAIN = "False False False"  # not compiling, nothing loaded
COMPILED = "True False False"  # compiling: the run loads the loop next


@pytest.mark.parametrize(
    ("ready", "samples", "notice", "after"),
    [
        (True, compile_loop.PLAIN_PYTHON_SAMPLES, "None", PLAIN),
        (True, compile_loop.PLAIN_PYTHON_SAMPLES + 1, "None", COMPILED),
        (False, compile_loop.PLAIN_PYTHON_SAMPLES + 1, "None", PLAIN),
        (False, compile_loop.PLAIN_PYTHON_SAMPLES_UNCOMPILED, "None", PLAIN),
        (
            False,
            compile_loop.PLAIN_PYTHON_SAMPLES_UNCOMPILED + 1,
            "loading the simulation loop, compiled first",
            COMPILED,
        ),
    ],
)
def test_the_bounds_choose_plain_python_or_the_compiled_loop(
    ready: bool, samples: int, notice: str, after: str, tmp_path: Path
) -> None:
    """Nothing is loaded by the choice. With the cache ready a budget over
    PLAIN_PYTHON_SAMPLES compiles (the run loads it next), one at it is plain
    Python; before the compile, plain Python up to PLAIN_PYTHON_SAMPLES_UNCOMPILED,
    then a compile, said first."""
    cache = tmp_path / "cache"
    if ready:
        stamp = kernel_cache.kernel_sources_stamp()
        directory = cache / "wmr_mission" / f"{kernel_cache.PREFIX}{stamp[:16]}"
        directory.mkdir(parents=True)
        (directory / compile_loop.READY).write_text(compile_loop.ready_stamp())
    done = subprocess.run(
        [sys.executable, "-c", CHOOSE, str(samples)],
        env=_env(cache),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    printed = done.stdout.splitlines()
    assert notice in printed[0]
    assert printed[1] == after


def test_numba_is_loaded_without_scipy() -> None:
    """numba imports scipy as it loads, to check its version, and its
    array-math module imports scipy's BLAS as numba's target is set up; no
    kernel uses either (0.13-0.15 s of a cached run). Refused to that thread
    alone while numba loads and sets up: scipy.linalg imports afterwards."""
    probe = (
        "import sys; from wmr_mission.kernels import jit\n"
        "def twice(x):\n    return 2.0 * x\n"
        "assert jit.compiled(twice, cached=False)(1.5) == 3.0\n"
        "print('scipy' in sys.modules); import scipy.linalg; print('imported')"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "imported"]


# Calls a cached compiled function (the module `doubled` in argv[1]), then
# prints its result, whether it was loaded from the cache, whether numba's
# target was set up (its array-math module imported) and scipy imported,
# whether importlib.metadata was imported, and whether numba's extensions
# were looked for (the installed entry points).
CACHED_CALL = """
import sys
sys.path.insert(0, sys.argv[1])
import doubled
from wmr_mission.kernels import jit
twice = jit.compiled(doubled.twice)
print(twice(1.5), sum(twice.stats.cache_hits.values()))
print("numba.np.arraymath" in sys.modules, "scipy" in sys.modules)
print("importlib.metadata" in sys.modules)
from numba.core import entrypoints
print(entrypoints._already_initialized)
"""


def test_a_cached_function_loads_without_setting_numba_up_and_a_miss_compiles(
    tmp_path: Path,
) -> None:
    """Loading from the cache needs none of numba's typing and lowering
    registries (0.12 s of a cached run, docs/performance.md, Start-up): the
    second process loads the function with its target not set up and without
    looking for numba's extensions (0.008 s), nor importing importlib.metadata
    (0.014-0.017 s); the first, finding nothing cached, sets it up (scipy
    refused, the extensions loaded) and compiles."""
    (tmp_path / "doubled.py").write_text("def twice(x):\n    return 2.0 * x\n")
    printed = []
    for _ in range(2):
        done = subprocess.run(
            [sys.executable, "-c", CACHED_CALL, str(tmp_path)],
            env=_env(tmp_path / "cache"),
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr
        printed.append(done.stdout.split())
    assert printed == [
        ["3.0", "0", "True", "False", "True", "True"],
        ["3.0", "1", "False", "False", "False", "False"],
    ]


# A numba extension, installed as a distribution with the entry point numba
# looks for (numba_extensions: init), which writes the file MARK names when
# numba loads it.
EXTENSION = """
import os

def init():
    with open(os.environ["MARK"], "a") as mark:
        mark.write("loaded\\n")
"""


def test_numbas_extensions_load_as_it_compiles_and_only_then(tmp_path: Path) -> None:
    """numba's module of extension entry points stands in for itself as numba
    loads (jit._ExtensionsLater): numba loaded, an installed extension is not
    looked for, nor importlib.metadata imported; compiling loads it, once."""
    site = tmp_path / "site"
    info = site / "wmr_extension_probe-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: wmr-extension-probe\nVersion: 1.0\n"
    )
    (info / "entry_points.txt").write_text("[numba_extensions]\ninit = wmr_extension_probe:init\n")
    (site / "wmr_extension_probe.py").write_text(EXTENSION)
    mark = tmp_path / "mark"
    probe = (
        "import os, sys; from wmr_mission.kernels import jit\n"
        "assert jit.load()\n"
        "print(os.path.exists(os.environ['MARK']), 'importlib.metadata' in sys.modules)\n"
        "def twice(x):\n    return 2.0 * x\n"
        "assert jit.compiled(twice, cached=False)(1.5) == 3.0\n"
        "def thrice(x):\n    return 3.0 * x\n"
        "assert jit.compiled(thrice, cached=False)(1.5) == 4.5\n"
        "from numba.core import entrypoints\n"
        "print(entrypoints._already_initialized, entrypoints.logger.name)\n"
    )
    env = {**_env(tmp_path / "cache"), "MARK": str(mark)}
    env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, "-c", probe],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "False", "True", "numba.core.entrypoints"]
    assert mark.read_text() == "loaded\n"


def test_another_numba_loads_its_cache_its_own_way(monkeypatch: pytest.MonkeyPatch) -> None:
    """The cache that loads without setting numba's target up restates numba's
    own loading as of one numba (jit.LOADED_AS_IS_FOR); another numba's, which
    may do more, is used as numba made it."""
    import numba
    from numba.core.caching import FunctionCache

    written_for = jit.LOADED_AS_IS_FOR
    monkeypatch.setattr(numba, "__version__", f"{written_for}.7")
    loaded_as_is = jit._cache_class()
    assert loaded_as_is is not None
    assert issubclass(loaded_as_is, FunctionCache)
    major, minor = written_for.split(".")
    others = (f"{major}.{int(minor) + 1}.0", f"{int(major) + 1}.{minor}.0", f"{major}.{minor}0")
    for other in others:
        monkeypatch.setattr(numba, "__version__", other)
        assert jit._cache_class() is None, other


def test_the_warm_up_compiles_the_loop_every_mission_runs() -> None:
    """One loop per built-in estimator and controller, one signature each:
    every shipped mission runs one of them as the warm-up compiled it. (A
    `type: python` plug-in's loop is compiled for the user's code, never cached.)"""
    loops = [
        jit.compiled(runner.bound_loop(e.step, c.step), counted=False)
        for e in ESTIMATORS
        if not e.plugin
        for c in CONTROLLERS
        if not c.plugin
    ]
    for warm_up in compile_loop.warm_up_missions():
        run_mission(plan_mission(warm_up))
    warmed_up = [set(compiled.signatures) for compiled in loops]  # type: ignore[attr-defined]
    assert [len(s) for s in warmed_up] == [1] * len(loops)
    for path in sorted(MISSIONS.glob("*.yaml")):
        run_mission(plan_mission(load_mission(path)))
        after = [set(compiled.signatures) for compiled in loops]  # type: ignore[attr-defined]
        assert after == warmed_up, path.name


def test_the_bound_parts_the_example_missions_where_it_was_measured() -> None:
    """With the cache ready the example missions over the bound load the
    compiled loop: each was measured both ways (`python benchmarks/measure.py
    threshold`, docs/performance.md, Start-up: compiled / plain 0.40-0.98
    over the bound, park the 0.98; 0.99-1.04 under it)."""
    compiled = {
        path.name
        for path in MISSIONS.glob("*.yaml")
        if sample_budget(load_mission(path)) > compile_loop.PLAIN_PYTHON_SAMPLES
    }
    # patrol-detour: its budget counts its retries and detours (29 511 samples)
    assert compiled == {
        "case1.yaml",
        "case2.yaml",
        "coverage.yaml",
        "disturbed.yaml",
        "keep-out.yaml",
        "noisy-ekf.yaml",
        "noisy-observer.yaml",
        "park.yaml",
        "patrol.yaml",
        "patrol-detour.yaml",
        "replanned-patrol.yaml",
        "shelf.yaml",
    }


def test_the_kernels_are_cached_in_the_directory_chosen() -> None:
    """numba is pointed at the directory by NUMBA_CACHE_DIR alone, and the
    compiled loop's entry is there."""
    from numba.core import config

    directory = kernel_cache.cache_directory()
    assert directory is not None
    assert directory.name.startswith(kernel_cache.PREFIX)
    run_mission(plan_mission(load_mission(MISSIONS / "fence.yaml")))
    assert config.CACHE_DIR == os.environ["NUMBA_CACHE_DIR"] == str(directory)
    assert list(directory.glob("*/loop.run_segment-*.nbi"))


def _sources(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the kernel modules, taken as the package's."""
    package = tmp_path / "package"
    for name in kernel_cache.KERNEL_MODULES:
        (package / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(kernel_cache.PACKAGE / name, package / name)
    monkeypatch.setattr(kernel_cache, "PACKAGE", package)
    kernel_cache.cache_directory.cache_clear()
    return package


def _chosen(cache: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    kernel_cache.cache_directory.cache_clear()
    directory = kernel_cache.cache_directory()
    assert directory is not None
    return directory


def test_an_edit_to_any_kernel_module_is_a_new_cache_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """numba judges a cached function by its own file: an edited control law
    would leave loop.py's compiled copy of it stale. Here the directory
    changes with every kernel module, and the earlier one is removed."""
    package = _sources(tmp_path, monkeypatch)
    cache = tmp_path / "cache"
    first = _chosen(cache, monkeypatch)
    assert first.parent == cache / "wmr_mission"
    (first / "kept").write_text("")
    assert _chosen(cache, monkeypatch) == first  # unchanged sources: the same
    assert (first / "kept").exists()
    seen = {first}
    for name in ("controllers/paper.py", "campaign/coverage.py"):
        with open(package / name, "a") as module:
            module.write("\n# edited\n")
        directory = _chosen(cache, monkeypatch)
        assert directory not in seen, name
        seen.add(directory)
        assert [p.name for p in directory.parent.iterdir()] == [directory.name]
    # A process started by this one, NUMBA_CACHE_DIR inherited, takes it as it is.
    assert _chosen(directory, monkeypatch) == directory


def test_every_module_of_kernels_is_in_the_stamp_of_the_cache() -> None:
    """The cache directory is named after the sources of the kernels: a kernel
    declared in a module left out of it would be loaded stale after an edit."""
    import importlib
    import pkgutil

    import wmr_mission

    for module in pkgutil.walk_packages(wmr_mission.__path__, "wmr_mission."):
        if not module.name.endswith("__main__"):
            importlib.import_module(module.name)
    declaring = {
        str(Path(sys.modules[k.__module__].__file__ or "").relative_to(kernel_cache.PACKAGE))
        for k in jit._state.kernels
        if k.__module__.startswith("wmr_mission.")
    }
    assert declaring
    assert declaring <= set(kernel_cache.KERNEL_MODULES)


def test_the_plain_form_of_a_kernel_calls_no_compiled_code() -> None:
    plain = jit.plain(loop.record_sample)
    called = plain.__globals__["max_row_value"]
    assert not hasattr(called, "py_func")
    assert not hasattr(called.__globals__["row_value"], "py_func")
    # A row outside case 2's ellipse, written compiled and as plain Python.
    mission = plan_mission(load_mission(MISSIONS / "case2.yaml"))
    estimate = np.array([5.2, 1.0, 0.3])
    phase = runner.PhaseRun(mission.phases[-1], mission, 2).enter(7, estimate)
    rows = []
    for write in (jit.compiled(loop.record_sample), plain):
        record = runner.Recorder(4).record
        write(record, phase, 0.07, 5.3, 1.1, 0.2, estimate, np.ones(2), np.nan, np.nan, 3, estimate)
        rows.append(record.floats[0].copy())
    assert rows[0][11] > 0.0  # the ellipse's row is violated there
    np.testing.assert_array_equal(rows[0], rows[1])


def test_a_run_made_as_plain_python_meanwhile_compiles_nothing_and_compiling_goes_on() -> None:
    """`wmr-mission compile` judges a run made as plain Python beside the first
    variant's compile: inside jit.plain_python_meanwhile the kernels, the
    loop and the judge's passes are plain Python, numba loaded or not, with
    the same bytes; after it, they are compiled again."""
    jit.load()
    mission = load_mission(MISSIONS / "case2.yaml")
    compiled = run_mission(plan_mission(mission))
    with jit.plain_python_meanwhile():
        assert not jit.loaded()
        assert not jit.distances_compiled()
        assert not hasattr(jit.compiled(loop.record_sample), "signatures")
        assert runner._Run(plan_mission(mission), None, None).ticks_are_ns  # the plain loop
        plain = run_mission(plan_mission(mission))
    assert jit.loaded()
    assert hasattr(jit.compiled(loop.record_sample), "signatures")
    for column in ("x", "y", "theta", "v", "omega", "x_est"):
        np.testing.assert_array_equal(getattr(plain, column), getattr(compiled, column))


def test_the_loop_is_compiled_counted_where_numba_lacks_the_option(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Without numba's developer option `_nrt` the loop compiles as any kernel
    (reference counted) rather than failing at its first call."""
    from numba.core import cpu

    from wmr_mission.kernels import jit

    monkeypatch.delattr(cpu.CPUTargetOptions.__mro__[1], "_nrt")

    def steer(x: float) -> float:
        return 2.0 * x

    compiled = jit.compiled(steer, counted=False)
    assert compiled(1.5) == 3.0
    assert "_nrt" not in compiled.targetoptions  # type: ignore[attr-defined]


def test_an_unreadable_ready_marker_is_no_ready_cache(tmp_path: Path) -> None:
    """A marker that is not text (a torn write, a disk fault) means not ready,
    never a traceback out of `run`."""
    (tmp_path / compile_loop.READY).write_bytes(b"\xff\xfe")
    assert kernel_cache.is_ready(tmp_path) is False


def test_compile_takes_a_stop_between_two_variants(monkeypatch: pytest.MonkeyPatch) -> None:
    """A stop that came inside numba's compiler is dropped there, owed
    (wmr_mission.stopping): `compile` takes it before the next variant, rather
    than compile every one (SIGTERM went unheeded for minutes)."""
    import ctypes
    import signal

    from wmr_mission.stopping import STOP_SIGNALS, StopSignals

    ran: list[int] = []

    def compiled_with_a_stop_inside(plan: object) -> object:
        ran.append(1)
        ctypes.CFUNCTYPE(None)(lambda: os.kill(os.getpid(), signal.SIGTERM))()
        return run_mission(plan)  # type: ignore[arg-type]

    monkeypatch.setattr(runner, "run_mission", compiled_with_a_stop_inside)
    with StopSignals(STOP_SIGNALS) as stop, pytest.raises(KeyboardInterrupt):
        compile_loop.compile_kernels()
    assert ran == [1]
    assert stop.name == "SIGTERM"


def test_sweep_and_falsify_say_a_compile_before_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """As run and the library do (README, Quick start): one line on stderr,
    a log's too, before a warm-up that compiles; none once the cache is ready
    (test_compile_marks_the_cache_ready_and_a_long_run_loads_it)."""
    from wmr_mission.campaign.falsify.command import falsify_command
    from wmr_mission.campaign.sweep import sweep_command

    mission = Path(__file__).parent / "data" / "campaigns" / "short.yaml"
    campaign = tmp_path / "c.yaml"
    campaign.write_text(
        f"version: 1\nname: c\nmission: {mission}\nruns: 2\nseed: 1\n"
        "vary:\n  robot.initial_state.theta: {uniform: [-1.0, 1.0]}\n",
        encoding="utf-8",
    )
    line = "wmr-mission: loading the simulation loop, compiled first (stand-in)"
    monkeypatch.setattr(jit, "foreground_notice", lambda: line)
    assert sweep_command(campaign, out=tmp_path / "s", workers=1, scheduler=None, plots=False) == 0
    falsify_command(
        campaign, budget=2, method="random", seed=0, objective=None, first=False,
        workers=1, scheduler=None, out=tmp_path / "f", plots=False,
    )  # fmt: skip
    assert capsys.readouterr().err.splitlines().count(line) == 2


def test_compile_leaves_no_ready_marker_when_stopped_in_its_last_compile(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A stop owed from inside the last variant's compile (or the judge's) is
    taken before the marker: no marker of a cache the stop left unfilled."""
    import ctypes
    import signal

    from wmr_mission.stopping import STOP_SIGNALS, StopSignals

    def stopped_at_the_end(processes: int, steps: object) -> None:
        ctypes.CFUNCTYPE(None)(lambda: os.kill(os.getpid(), signal.SIGTERM))()

    monkeypatch.setattr(kernel_cache, "cache_directory", lambda: tmp_path)
    monkeypatch.setattr(compile_loop, "compile_kernels", stopped_at_the_end)
    if not jit.compiling():
        pytest.fail("numba is needed here: it compiles")
    with StopSignals(STOP_SIGNALS), pytest.raises(KeyboardInterrupt):
        compile_loop.compile_command()
    assert not (tmp_path / compile_loop.READY).exists()


def test_a_loop_that_does_not_compile_is_not_marked_ready(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A variant whose loop fails to compile ends its warm-up run in an error
    (kept as data, not raised): `compile` said "compiled" and marked the
    cache ready over it. It now says so and exits 1, with no marker."""
    from wmr_mission.record import Outcome

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(compile_loop, "is_ready", lambda directory: False)
    monkeypatch.setattr(jit, "compiling", lambda: True)

    class Failed:
        outcome = Outcome.error
        message = "an error inside the loop: TypingError"

    monkeypatch.setattr(runner, "run_mission", lambda plan: Failed())
    assert compile_loop.compile_command() == 1
    assert "failed to compile" in capsys.readouterr().out
    assert not list((tmp_path / "cache").rglob(compile_loop.READY))


# Compiles small functions counted as the judge's (their module, tiny, put
# in the judge's place in jit.COMPILED_WHAT): one in each of two processes
# forked once numba is loaded, then two in the process they were forked from.
TINY_KERNELS = """
import multiprocessing, sys
sys.path.insert(0, sys.argv[1])
import tiny
from wmr_mission.kernels import jit

judges = jit.COMPILED_WHAT[1]
assert judges[1] == "the judge's passes"
jit.COMPILED_WHAT = (jit.COMPILED_WHAT[0], ("tiny", *judges[1:]), *jit.COMPILED_WHAT[2:])

def halved():
    jit.compiled(tiny.half)(1.0)

if __name__ == "__main__":
    jit.load()  # as a sweep's warm-up, before its workers fork
    forked = [multiprocessing.get_context("fork").Process(target=halved) for _ in range(2)]
    for process in forked:
        process.start()
    for process in forked:
        process.join()
        assert process.exitcode == 0
    jit.compiled(tiny.double)(1.0)
    jit.compiled(tiny.triple)(1.0)
"""
TINY = """
def double(x):
    return 2.0 * x

def triple(x):
    return 3.0 * x

def half(x):
    return 0.5 * x
"""
JUDGES_LINE = "wmr-mission: compiling the judge's passes, not in the cache yet"


def test_a_compile_is_said_once_as_it_starts_and_not_from_a_warm_cache(tmp_path: Path) -> None:
    """A first compile of the judge's passes says so on stderr, one line for
    all of them and for the processes forked after numba loaded, which
    compile the same (a campaign's worst runs, docs/performance.md,
    Start-up); from the cache, nothing is said."""
    (tmp_path / "tiny.py").write_text(TINY, encoding="utf-8")
    script = tmp_path / "tiny_kernels.py"
    script.write_text(TINY_KERNELS, encoding="utf-8")
    env = _env(tmp_path / "cache")
    first = subprocess.run(
        [sys.executable, str(script), str(tmp_path)],
        capture_output=True, text=True, timeout=300, env=env, check=False,
    )  # fmt: skip
    assert first.returncode == 0, first.stderr
    lines = first.stderr.splitlines()
    assert [line for line in lines if "compiling" in line] == [
        f"{JUDGES_LINE} (15 s to a minute and a half by the machine's load, once; "
        "from the cache, under a second)"
    ], first.stderr
    again = subprocess.run(
        [sys.executable, str(script), str(tmp_path)],
        capture_output=True, text=True, timeout=300, env=env, check=False,
    )  # fmt: skip
    assert again.returncode == 0, again.stderr
    assert "compiling" not in again.stderr, again.stderr


def test_the_loops_compile_said_before_it_is_not_said_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The notice before the loop is loaded (jit.NOTICE, printed by run, sweep,
    falsify and the library) says its compile: its misses say nothing more,
    and the judge's, the campaign's and the EKF band's compiles each say
    theirs once; `wmr-mission compile`, which says its own, says none."""
    monkeypatch.setattr(jit._state, "said", jit._said_memory())
    monkeypatch.setattr(kernel_cache, "cache_directory", lambda: tmp_path)
    monkeypatch.setattr(jit._state, "ready", False)
    assert jit.foreground_notice() == jit.NOTICE
    assert jit.compiling_notice("wmr_mission.kernels.loop") is None
    assert jit.compiling_notice("wmr_mission.kernels.scalar_math") is None
    said = [
        jit.compiling_notice(module)
        for module in (
            "wmr_mission.verdicts.passes", "wmr_mission.verdicts.path_distance",
            "wmr_mission.campaign.coverage", "wmr_mission.campaign.coverage",
            "wmr_mission.output.covariance",
        )
    ]  # fmt: skip
    assert [line is not None for line in said] == [True, False, True, False, True]
    assert "the campaign's pixel counts" in str(said[2])
    assert "the EKF band's replay" in str(said[4])
    monkeypatch.setattr(jit._state, "said", jit._said_memory())
    jit.compiles_said_elsewhere()
    assert jit.compiling_notice("wmr_mission.verdicts.passes") is None


class _Terminal:
    """A file that says it is a terminal, shared by a process and its forks."""

    encoding = "utf-8"

    def __init__(self, path: Path) -> None:
        self._file = path.open("w", encoding="utf-8")

    def isatty(self) -> bool:
        return True

    def write(self, text: str) -> int:
        return self._file.write(text)

    def flush(self) -> None:
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def test_a_compile_is_said_above_a_commands_steps(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """While a command's steps are drawn on a terminal (a sweep's, a run's),
    a compile's line is printed above them, where a bare line on stderr would
    be drawn over: this process's, and a forked one's (a campaign's worker)
    with its copy of the steps; after the steps, on stderr."""
    drawn = tmp_path / "terminal"
    shared = _Terminal(drawn)
    steps = Steps(cast(IO[str], shared))
    steps.step("worst runs and figures")
    jit._say("wmr-mission: compiling (here)")
    forked = os.fork()
    if forked == 0:
        jit._say("wmr-mission: compiling (forked)")
        os._exit(0)
    assert os.waitpid(forked, 0)[1] == 0
    steps.close()
    shared.close()
    jit._say("after")
    terminal = drawn.read_text(encoding="utf-8")
    assert "wmr-mission: compiling (here)\n" in terminal
    assert "wmr-mission: compiling (forked)\n" in terminal
    assert capfd.readouterr().err.splitlines() == ["after"]
