"""Micro-benchmarks of the per-sample step, fast and reference, and a whole run.

The suite runs them once each as plain tests (``--benchmark-disable``); time
them with ``pytest tests/test_benchmarks.py --benchmark-enable``.
"""

from __future__ import annotations

import importlib.util
import math
import subprocess
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from pytest_benchmark.fixture import BenchmarkFixture

from wmr_mission.controllers import paper
from wmr_mission.controllers.paper import PaperTuning
from wmr_mission.estimators import ekf, observer
from wmr_mission.estimators.ekf import ekf_tuning
from wmr_mission.estimators.observer import observer_tuning
from wmr_mission.kernels import jit
from wmr_mission.kernels.records import Plant, scratch
from wmr_mission.sim import reference
from wmr_mission.sim.plan import MissionPlan, plan_mission
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission, load_mission_text

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
DT = 0.01
ESTIMATE = np.array([1.0, 2.0, 0.3])
MEASUREMENT = np.array([1.08, 1.97, 0.31])  # x beyond its bound: phase II acts
U_PREV = np.array([1.2, 0.4])
W, M = np.full(3, 100.0), np.full(2, 100.0)
Q, R = np.ones(3), np.ones(2)
MASK, POLES = np.ones(3), np.full(3, 0.9)
LIMITS = np.array([10.0, 20.0, math.inf, math.inf])
# Stay inside an ellipse the prediction leaves: the corrective action acts.
ELLIPSE_ROWS = (np.array([0], dtype=np.int64), np.array([[0.0, 0.0, 1.0, 2.0, 0.0, 1.0]]))

# "fast": the kernels as the loop runs them, compiled (plain Python without numba).
OBSERVERS = {"fast": jit.compiled(observer.observer_step), "reference": reference.observer_step}
TRACKERS = {"fast": jit.compiled(paper.track_input), "reference": reference.track_input}
REGULATORS = {"fast": jit.compiled(paper.regulate_input), "reference": reference.regulate_input}


@pytest.mark.parametrize("kind", list(OBSERVERS))
def test_observer_step(benchmark: BenchmarkFixture, kind: str) -> None:
    estimate = ESTIMATE.copy()
    gain = np.zeros((3, 3))
    bounds = np.full(3, 0.05)

    def step() -> int:
        estimate[:] = ESTIMATE
        observer = OBSERVERS[kind]
        return observer(
            estimate, 1.2, 0.4, DT, MEASUREMENT,
            observer_tuning(MASK, POLES, 0.0, -bounds, bounds, True, 10), gain, POLES,
        )  # fmt: skip

    assert benchmark(step) == 1
    assert MEASUREMENT[0] - estimate[0] == pytest.approx(0.05)


@pytest.mark.parametrize("kind", ["fast", "reference"])
def test_ekf_step(benchmark: BenchmarkFixture, kind: str) -> None:
    function = jit.compiled(ekf.ekf_step) if kind == "fast" else reference.ekf_step
    estimate, covariance = ESTIMATE.copy(), np.eye(3)
    process_var, measurement_var = np.full(3, 1e-6), np.full(3, 1e-4)
    work = np.zeros((4, 3, 3))

    def step() -> None:
        estimate[:] = ESTIMATE
        covariance[:, :] = 0.0
        covariance[[0, 1, 2], [0, 1, 2]] = 1.0
        function(
            estimate, covariance, 1.2, 0.4, DT, MEASUREMENT,
            ekf_tuning(MASK, process_var, measurement_var), work,
        )  # fmt: skip

    benchmark(step)
    # A confident measurement pulls the estimate almost onto it.
    np.testing.assert_allclose(estimate, MEASUREMENT, atol=1e-3)


@pytest.mark.parametrize("kind", list(TRACKERS))
def test_track_input(benchmark: BenchmarkFixture, kind: str) -> None:
    work, u = scratch(), np.zeros(2)
    path_point = np.array([1.02, 2.01, 1.0, 0.0])
    tracking = PaperTuning(0.1, 0.9, Q, R, W, M, paper.BEARING, 0.01, True)

    def step() -> None:
        TRACKERS[kind](
            ESTIMATE, U_PREV, path_point, path_point, tracking, Plant(DT, LIMITS), work, u
        )  # fmt: skip

    benchmark(step)
    assert np.all(np.isfinite(u))
    assert u[0] != U_PREV[0]


@pytest.mark.parametrize("kind", list(REGULATORS))
@pytest.mark.parametrize("constrained", [False, True], ids=["free", "constrained"])
def test_regulate_input(benchmark: BenchmarkFixture, kind: str, constrained: bool) -> None:
    work, u, memory = scratch(), np.zeros(2), np.zeros(paper.MEMORY_SIZE)
    controller = PaperTuning(0.05, 0.0, Q, R, W, M, paper.BEARING, 0.01, True)
    kinds, params = ELLIPSE_ROWS if constrained else (np.zeros(0, dtype=np.int64), np.zeros((0, 6)))
    target = np.array([0.0, 0.0, 0.0])

    def step() -> None:
        REGULATORS[kind](
            ESTIMATE, ESTIMATE, U_PREV, target, kinds, params, controller, Plant(DT, LIMITS),
            memory, work, u,
        )  # fmt: skip

    benchmark(step)
    assert np.all(np.isfinite(u))
    assert memory[paper.CORRECTED] == float(constrained)


@pytest.fixture(scope="module")
def case2() -> MissionPlan:
    return plan_mission(load_mission(MISSIONS / "case2.yaml"))


def test_case_study_2_whole_run(benchmark: BenchmarkFixture, case2: MissionPlan) -> None:
    result = benchmark(run_mission, case2)
    assert result.outcome.value == "success"
    assert result.samples > 3000


def circle_mission(seconds: float) -> MissionPlan:
    text = f"""
version: 1
name: circle
estimator: {{type: constrained-observer, initial_estimate: {{x: 0, y: 0, theta: 0}}}}
phases:
  - name: laps
    track: {{path: {{type: circle, center: [0, 1], radius: 1, angular_rate: 1}}}}
    until: {{elapsed: {seconds}}}
"""
    return plan_mission(load_mission_text(text, "circle.yaml"))


def peak_bytes(mission: MissionPlan) -> tuple[int, int]:
    tracemalloc.start()
    try:
        result = run_mission(mission)
        return result.samples, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_memory_grows_with_the_recorder_only() -> None:
    """Peak memory per sample stays near the recorder's row size (~120 bytes
    live + the result's copies): nothing per sample outlives its step."""
    run_mission(circle_mission(1.0))  # kernels loaded before measuring
    short_samples, short_peak = peak_bytes(circle_mission(10.0))
    long_samples, long_peak = peak_bytes(circle_mission(40.0))
    assert (short_samples, long_samples) == (1001, 4001)
    per_sample = (long_peak - short_peak) / (long_samples - short_samples)
    assert per_sample < 400


def test_the_floor_reproduces_case_study_2s_tracking(monkeypatch: pytest.MonkeyPatch) -> None:
    """benchmarks/floor.py, the loop's floor fused by hand, runs case study 2's
    tracking samples (spiral-out, then 20 s of orbit) to 1e-9 of the run's
    trajectory: the ratio it prints compares the same work. As plain Python
    here, the same bytes as compiled (tests/test_loop.py)."""
    monkeypatch.setenv(jit.NO_JIT, "1")
    floor_py = Path(__file__).resolve().parent.parent / "benchmarks" / "floor.py"
    spec = importlib.util.spec_from_file_location("floor", floor_py)
    assert spec is not None
    assert spec.loader is not None
    floor = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(floor)
    calls, result, _ = floor.tracking_calls()
    assert sum(call.samples for call in calls) > 2000
    assert floor.largest_difference(calls, result, floor.floor_function()) <= 1e-9


def test_the_readme_command_script_runs_the_line_ci_runs() -> None:
    """benchmarks/readme_command.py times the line `.ci/run` runs: its reading
    of the README gives what `.ci/run`'s own line gives, and holds the extras
    its ``--extras`` replaces."""
    root = Path(__file__).resolve().parent.parent
    spec = importlib.util.spec_from_file_location(
        "readme_command", root / "benchmarks" / "readme_command.py"
    )
    assert spec is not None
    assert spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    ci = (root / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    reading = next(line for line in ci if line.startswith("test_cmd="))
    done = subprocess.run(
        ["bash", "-c", f'{reading}\nprintf %s "$test_cmd"'],
        cwd=root, capture_output=True, text=True, check=True,
    )  # fmt: skip
    line = script.test_line((root / "README.md").read_text(encoding="utf-8"))
    assert line == done.stdout
    assert script.EXTRAS in line
    assert "pytest" in line
