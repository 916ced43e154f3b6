from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

# One BLAS thread per process, this one's and those it starts, set before numpy
# loads OpenBLAS: the suite's matrices are 3x3 to 6x6, and with `-n auto` every
# core runs a test already, so BLAS threads only spin waiting for a core (the
# reference step through case study 1: 23 s of wall time with two, 15 s with
# one, the same CPU, on the loaded 2-core machine).
for _threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")

import matplotlib  # noqa: E402 - after the threads are set
import numpy as np  # noqa: E402
import pytest  # noqa: E402

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

# `pytest -m smoke`: a subset for contributors, under a minute on 2 cores. The
# mission format, the paper's equations (model, observer, corrective law),
# paths, regions, routes, expressions, metrics, reactions and the command
# line's help: every test of these files, as plain Python (the same bytes as
# compiled, tests/test_loop.py), so that no kernel compiles.
SMOKE = {
    "test_spec_loader.py",
    "test_model.py",
    "test_corrective.py",
    "test_observer.py",
    "test_paths.py",
    "test_regions.py",
    "test_routes.py",
    "test_expressions.py",
    "test_output_metrics.py",
    "test_reactions.py",
    "test_cli_help.py",
}


@pytest.hookimpl(trylast=True)  # after the terminal's reporter is made
def pytest_configure(config: pytest.Config) -> None:
    if config.option.markexpr.strip() == "smoke":
        os.environ.setdefault("WMR_MISSION_NO_JIT", "1")
    elif _the_whole_suite_on_workers(config):
        _compile_first(config)


def _the_whole_suite_on_workers(config: pytest.Config) -> bool:
    """`pytest -n N` on the whole suite (no file named), here in the process
    that starts the workers, with numba compiling."""
    from wmr_mission.kernels import jit

    return (
        not hasattr(config, "workerinput")
        and bool(getattr(config.option, "tx", None))
        and config.args_source == pytest.Config.ArgsSource.TESTPATHS
        and not config.option.collectonly
        and jit.compiling()
    )


def _compile_first(config: pytest.Config) -> None:
    """The built-in loops compiled into the kernel cache before the workers
    start, by `wmr-mission compile` (on every core, each variant once)
    instead of by whichever worker's test runs a loop first, at times by both
    at once (numba's cache takes no lock, so neither knows the other is
    compiling). The tests' commands then load the compiled loop where a
    user's would after that command (`run` of a mission over 5 500 samples
    compiled: the commands of docs/tutorial.md, tests/test_tutorial.py, take
    35 s of CPU as plain Python, 12 s so). A failure here is left to the
    tests that run the loop to report."""
    import subprocess
    import sys

    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None:
        reporter.write_line("compiling the built-in loops first (wmr-mission compile)")
    # The package the workers import (the source tree under `python -m pytest`,
    # else the installed one), whose cache is theirs; started outside the
    # checkout's root, whose package `python -m` would import first.
    done = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "compile"],
        env=the_tests_package(dict(os.environ)),
        cwd=Path(__file__).parent,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0 and reporter is not None:
        reporter.write_line(
            f"compiling first failed, the tests compile instead:\n{done.stdout}{done.stderr}"
        )


# The files whose tests take longest (CPU, their subprocesses' included, in a
# run of the suite from an empty kernel cache: tests/suite_costs.py), run
# first, so that with `-n auto` no worker is left running one of them at the
# end while the other waits (`--no-loadscope-reorder` in pyproject.toml: xdist
# hands the files out in this order, not by their number of tests).
LONGEST_FIRST = (
    "test_same_bytes.py",
    "test_controllers_doc.py",
    "test_start_up.py",
    "test_figure_styles.py",
    "test_ros2_plans.py",
    "test_backends.py",
    "test_tutorial.py",
    "test_plugins.py",
    "test_campaign.py",
    "test_reference.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if item.path.name in SMOKE:
            item.add_marker(pytest.mark.smoke)
    first = {name: rank for rank, name in enumerate(LONGEST_FIRST)}
    # sorted() keeps the order of the tests within a file and of the other files
    items.sort(key=lambda item: first.get(item.path.name, len(first)))


def the_tests_package(env: dict[str, str]) -> dict[str, str]:
    """``env`` for a Python process that a test starts in a directory of its own
    (``cwd``), to import the package the tests import. Started in the
    checkout's root, `python -m` and `python -c` import the checkout's package
    before an installed one (the README's `pip install .`), whose kernels numba
    caches apart, by their source's path: such a process compiles again the
    loops the session's cache holds (a sweep's 22 s of CPU; tests/test_start_up.py's
    `compile` 70 s)."""
    import wmr_mission

    root = str(Path(wmr_mission.__file__).resolve().parent.parent)
    return {**env, "PYTHONPATH": os.pathsep.join(p for p in (root, env.get("PYTHONPATH", "")) if p)}


@pytest.fixture(autouse=True)
def _loop_undecided() -> Iterator[None]:
    """`run` chooses plain Python for its process when its mission is short
    (wmr_mission.commands.compile.choose_loop: a command's process runs one
    mission); a test that calls it here leaves the next tests undecided."""
    from wmr_mission.kernels import jit

    chosen = jit._state.plain_chosen
    yield
    jit._state.plain_chosen = chosen


@pytest.fixture(autouse=True)
def _close_figures() -> Iterator[None]:
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240611)


# A small campaign directory as `sweep` writes it, with figures and worst runs
# (some of which fail their expect: the runs drawn a final error of at most
# 1 mm): the data of the report and export tests.
LOOKING_CAMPAIGN = """version: 1
name: looking
mission: {mission}
runs: 4
seed: 11
vary:
  robot.initial_state.theta: {{uniform: [-3.0, 3.0]}}
  sensors.noise_std.x: {{choice: [0.0, 0.01]}}
  estimator.type: {{choice: [constrained-observer, ekf]}}
  controller.Q: {{grid: [[1, 1, 1], [1, 1, 10]]}}
  expect.final_position_error.max: {{choice: [0.05, 0.001]}}
"""


@pytest.fixture(scope="session")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from wmr_mission import run_campaign
    from wmr_mission.campaign import sweep

    root = tmp_path_factory.mktemp("looking")
    mission = Path(__file__).parent / "data" / "campaigns" / "short.yaml"
    path = root / "looking.yaml"
    path.write_text(LOOKING_CAMPAIGN.format(mission=mission), encoding="utf-8")
    out = root / "campaign"
    # The campaign's figures, not the worst runs' (most of the time, and unused).
    with pytest.MonkeyPatch.context() as patch:
        _worst_runs_without_figures(patch, sweep)
        run_campaign(path, out=out, workers=1, plots=True)
    return out


def _worst_runs_without_figures(patch: pytest.MonkeyPatch, sweep: Any) -> None:
    write_run = sweep.write_run

    def without_figures(*args: Any, **kwargs: Any) -> Any:
        return write_run(*args, **{**kwargs, "plots": False})

    patch.setattr(sweep, "write_run", without_figures)


@pytest.fixture
def campaign_figures_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """A sweep with figures writes its worst runs' directories without theirs:
    five run directories of five figures each, seconds of matplotlib per test,
    where the test is about the campaign's own figures, a fault or the steps
    shown. A worst run's figures are a run directory's, drawn by the same
    `write_run` as `run`'s (tests/test_output_figures.py, tests/test_output_plots.py)."""
    from wmr_mission.campaign import sweep

    _worst_runs_without_figures(monkeypatch, sweep)
