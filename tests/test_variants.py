"""Extension points: an estimator and a control law from a module outside the
package (tests/toy_variants.py) run through the loop, compiled and as plain
Python, by one registration each (docs/architecture.md, the recipes)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np
import pytest
from conftest import the_tests_package
from pydantic import Field

from wmr_mission.api import MissionError, mission_from_text, run_mission
from wmr_mission.controllers import CONTROLLERS, ControllerSettings, ControllerType
from wmr_mission.kernels import jit
from wmr_mission.kernels.model import step, wrap_angle
from wmr_mission.kernels.records import Plant

TESTS = Path(__file__).resolve().parent
DT, SPEED, TURN, TURN_SAMPLES, BLEND = 0.01, 0.5, 1.0, 30, 0.75

MISSION = f"""\
version: 1
name: toys
robot: {{dt: {DT}, limits: {{v: 2, omega: 3}}}}
sensors:
  noise_std: {{x: 0.01, y: 0.02, theta: 0.01}}
  period: 0.02
  seed: 11
estimator: {{type: toy-measured-pose, blend: {BLEND}}}
controller: {{type: toy-turns, speed: {SPEED}, turn_rate: {TURN}, turn_samples: {TURN_SAMPLES}}}
phases:
  - {{name: first, hold: {{}}, until: {{elapsed: 0.5}}}}
  - {{name: second, hold: {{}}, until: {{elapsed: 0.5}}}}
expect: {{speed_at_limit: null, turn_rate_at_limit: null, tracking_error_max: null}}
"""

# Registers the toys, validates and runs the mission, keeps the run's arrays exactly.
RUN = """
import json, sys
import numpy as np
import toy_variants
from wmr_mission.api import mission_from_text, run_mission
from wmr_mission.commands.schema import schema_text
from wmr_mission.kernels import jit
result = run_mission(mission_from_text(sys.argv[1], filename="toys.yaml"))
columns = ("t", "x", "y", "theta", "x_est", "y_est", "theta_est", "v", "omega", "phase",
           "x_meas", "y_meas", "theta_meas", "phase2_iterations")
np.savez(sys.argv[2], **{name: getattr(result, name) for name in columns})
print(json.dumps({
    "outcome": result.outcome.value,
    "compiled": jit.loaded(),
    "in the schema": all(t in schema_text() for t in ("toy-turns", "toy-measured-pose")),
}))
"""


def _run(tmp_path: Path, build: str) -> tuple[dict[str, np.ndarray], dict[str, object]]:
    env = {key: value for key, value in os.environ.items() if key != jit.NO_JIT}
    env["PYTHONPATH"] = os.pathsep.join([str(TESTS), env.get("PYTHONPATH", "")])
    if build == "plain Python":
        env[jit.NO_JIT] = "1"
    arrays = tmp_path / f"{build.replace(' ', '-')}.npz"
    done = subprocess.run(
        [sys.executable, "-c", RUN, MISSION, str(arrays)],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    with np.load(arrays) as saved:
        return {name: saved[name] for name in saved.files}, json.loads(done.stdout)


def test_a_toy_estimator_and_control_law_run_through_the_loop(tmp_path: Path) -> None:
    runs = {build: _run(tmp_path, build) for build in ("compiled", "plain Python")}
    for build, (_, said) in runs.items():
        assert said == {
            "outcome": "success",
            "compiled": build == "compiled" and jit.compiling(),
            "in the schema": True,
        }
    r, _ = runs["compiled"]
    plain, _ = runs["plain Python"]
    for name, column in r.items():  # the same bytes, compiled or not
        assert column.tobytes() == plain[name].tobytes(), name
    n = r["t"].size
    assert n == 101  # two phases of 50 samples and the closing row
    assert list(r["phase"]) == [0] * 50 + [1] * 51

    # The control law: constant speed; its turn reversed after 30 samples of
    # each phase, its memory zeroed as the second phase begins.
    local = np.concatenate([np.arange(50), np.arange(51)])
    assert np.all(r["v"] == SPEED)
    expected_turn = np.where(local < TURN_SAMPLES, TURN, -TURN)
    np.testing.assert_array_equal(r["omega"][:-1], expected_turn[:-1])
    assert r["omega"][-1] == r["omega"][-2]  # the closing row repeats the last input
    # The plant moved by exactly these inputs (eq. (1), no disturbance).
    for k in range(n - 1):
        moved = step(r["x"][k], r["y"][k], r["theta"][k], r["v"][k], r["omega"][k], DT)
        assert moved == (r["x"][k + 1], r["y"][k + 1], r["theta"][k + 1]), k

    # The estimator: every second sample has a measurement; there the estimate
    # moves 0.75 of the way from the prediction to it, elsewhere it is the
    # prediction; it counts 1 per measurement taken.
    measured = ~np.isnan(r["x_meas"])
    assert list(np.flatnonzero(measured)) == list(range(2, n, 2))
    np.testing.assert_array_equal(r["phase2_iterations"][1:], measured[1:].astype(np.int64))
    for k in range(1, n):
        predicted = step(
            r["x_est"][k - 1], r["y_est"][k - 1], r["theta_est"][k - 1],
            r["v"][k - 1], r["omega"][k - 1], DT,
        )  # fmt: skip
        estimate = (r["x_est"][k], r["y_est"][k], r["theta_est"][k])
        if not measured[k]:
            assert estimate == predicted, k
            continue
        wanted = (
            predicted[0] + BLEND * (r["x_meas"][k] - predicted[0]),
            predicted[1] + BLEND * (r["y_meas"][k] - predicted[1]),
            predicted[2] + BLEND * wrap_angle(r["theta_meas"][k] - predicted[2]),
        )
        assert estimate == wanted, k
        assert estimate != predicted  # the noisy measurement moved it


def test_a_type_nobody_registered_is_refused_with_the_registered_ones() -> None:
    """Without the registration the types are unknown: the registry is what
    the mission is validated against."""
    with pytest.raises(MissionError) as refused:
        mission_from_text(MISSION, filename="toys.yaml")
    messages = [d.message for d in refused.value.diagnostics]
    assert any(
        "unknown type 'toy-measured-pose'" in m and "constrained-observer, ekf, python" in m
        for m in messages
    ), messages
    assert any(
        m.endswith(
            "unknown type 'toy-turns' (expected one of: paper, pure-pursuit, kanayama, python)"
        )
        for m in messages
    ), messages
    # The fields of a type nobody registered are not reported one by one.
    assert not any("unknown field" in m for m in messages), messages


class Logged(ControllerSettings):
    """A control law of plain Python objects: it keeps every estimate in a list."""

    type: Literal["test-logged"] = Field(description="Controller kind.")
    speed: float


class LoggedTuning(NamedTuple):
    speed: float


ESTIMATES_SEEN: list[float] = []


def logged_step(
    tuning: LoggedTuning, phase: Any, aim_now: Any, aim: Any, estimate: np.ndarray,
    estimate_prev: Any, u_prev: Any, plant: Plant, memory: Any, scratch: Any, u: np.ndarray,
) -> None:  # fmt: skip
    ESTIMATES_SEEN.append(float(estimate[0]))  # no numba compiles this
    u[0], u[1] = tuning.speed, 0.0


def test_a_step_numba_cannot_compile_runs_in_a_plain_python_loop() -> None:
    """A variant that says its step does not compile runs the loop as plain
    Python, whatever the build: the seam for plug-ins of plain Python objects."""
    logged = ControllerType(
        settings=Logged,
        tuning_record=LoggedTuning,
        tuning_of=lambda settings, plant: LoggedTuning(settings.speed),
        memory_size=0,
        new_scratch=lambda tuning: None,
        step=logged_step,
        compiles=False,
    )
    CONTROLLERS.register(logged)
    ESTIMATES_SEEN.clear()
    try:
        text = MISSION.replace("estimator: {type: toy-measured-pose, blend: 0.75}\n", "")
        text = text.replace(
            f"controller: {{type: toy-turns, speed: {SPEED}, turn_rate: {TURN}, "
            f"turn_samples: {TURN_SAMPLES}}}",
            "controller: {type: test-logged, speed: 0.25}",
        )
        result = run_mission(mission_from_text(text, filename="logged.yaml"))
    finally:
        CONTROLLERS.unregister("test-logged")
    assert result.samples == 101
    assert list(result.x_est[:-1]) == ESTIMATES_SEEN
    assert np.all(result.v == 0.25)
    with pytest.raises(MissionError, match="unknown type 'test-logged'"):
        mission_from_text(text, filename="logged.yaml")


BAND = """
import json, sys
import toy_variants
from wmr_mission.api import mission_from_text, run_mission
from wmr_mission.output.covariance import estimate_std
from wmr_mission.output.figures import plot_estimation_error
result = run_mission(mission_from_text(sys.argv[1], filename="toys.yaml"))
std = estimate_std(result)
print(json.dumps({
    "std": std[:, 0].tolist(),
    "measured": [x == x for x in result.x_meas.tolist()],
    "title": plot_estimation_error(result).get_suptitle(),
}))
"""


def test_an_estimator_that_registers_a_spread_gets_the_figure_s_band() -> None:
    """The +-3 std band is a registration too (`spread`): the toy's own
    spread, replayed through its own step, is what the figure shades."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]),
    }
    done = subprocess.run(
        [sys.executable, "-c", BAND, MISSION], env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    said = json.loads(done.stdout)
    taken = np.cumsum(said["measured"]) - said["measured"][0]  # the first row is no update
    np.testing.assert_array_equal(said["std"], 1.0 / (1.0 + taken))
    assert "TOY-MEASURED-POSE's +-3 std" in said["title"]
    # The toy's replay is kept out of the disk cache: a process that never
    # imports the toy still loads the EKF's (the cache's index would name it).
    mission = TESTS.parent / "missions" / "noisy-ekf.yaml"
    ekf = (
        "from wmr_mission import load_mission, run_mission; "
        "from wmr_mission.output.covariance import estimate_std; "
        f"print(estimate_std(run_mission(load_mission({str(mission)!r})))[-1, 0])"
    )
    done = subprocess.run(
        [sys.executable, "-c", ekf],
        cwd=TESTS,
        env=the_tests_package(dict(os.environ)),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert 0.0 < float(done.stdout) < 0.02
