"""The Python API: every way in is checked, results carry the run directory's metrics,
and the examples of docs/python-api.md run as written."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import wmr_mission
from wmr_mission import (
    Mission,
    MissionError,
    load_mission,
    load_run,
    mission_from_dict,
    mission_from_text,
    run_mission,
)
from wmr_mission.spec.loader import Diagnostic

ROOT = Path(__file__).resolve().parents[1]
CASE2 = ROOT / "missions" / "case2.yaml"

SHORT = """\
version: 1
name: short
robot: {limits: {v: 2, omega: 4}}
phases:
  - name: out
    track: {path: {type: line, heading: 0, speed: 1}}
    until: {elapsed: 1}
  - name: back
    regulate: {target: {x: 0, y: 0, theta: 0}}
    until: {settled: {position: 0.02, heading: 0.02}}
    timeout: 20
expect:
  final_position_error: {max: 0.05}
"""


def test_importing_the_package_loads_nothing_heavy() -> None:
    code = "import sys, wmr_mission; sys.exit('numpy' in sys.modules or 'pydantic' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_dir_lists_the_lazy_names_for_tab_completion() -> None:
    listed = dir(wmr_mission)
    assert {"run_mission", "load_mission", "plot_verdicts", "plot_xy", "RunResult"} <= set(listed)
    assert set(wmr_mission.__all__) <= set(listed)


def test_plot_verdicts_is_exported() -> None:
    from wmr_mission.output.figures import plot_verdicts

    assert "plot_verdicts" in wmr_mission.__all__
    assert wmr_mission.plot_verdicts is plot_verdicts


def test_every_public_name_resolves() -> None:
    for name in wmr_mission.__all__:
        assert getattr(wmr_mission, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        _ = wmr_mission.nothing  # type: ignore[attr-defined]


def test_overrides_use_the_paths_of_set_and_are_checked_as_a_whole() -> None:
    mission = load_mission(CASE2, {"robot.initial_state.theta": 1.2, "controller.Q": [1, 1, 2]})
    assert mission.robot.initial_state.theta == 1.2
    assert mission.controller.Q == (1.0, 1.0, 2.0)
    by_name = load_mission(CASE2, {"phases.orbit.until.elapsed": 5, "phases[2].timeout": 60})
    assert by_name.phases[1].until.elapsed == 5.0
    assert by_name.phases[2].timeout == 60.0
    with pytest.raises(MissionError) as caught:
        load_mission(CASE2, {"robot.dt": -1, "robot.dtt": 1})
    assert [str(d) for d in caught.value.diagnostics] == [
        "overrides['robot.dt']: robot.dt: should be greater than 0, got -1",
        "overrides['robot.dtt']: robot.dtt: unknown field 'dtt'; did you mean 'dt'?",
    ]
    with pytest.raises(MissionError, match=r"overrides\['robot\.\.dt'\]: 'robot\.\.dt' is not"):
        load_mission(CASE2, {"robot..dt": 1})


def test_an_override_checked_across_fields_names_itself() -> None:
    # a phase shorter than one sample: found by the checks across fields
    with pytest.raises(MissionError) as caught:
        load_mission(CASE2, {"phases.orbit.until.elapsed": 0.005})
    assert [str(d) for d in caught.value.diagnostics] == [
        "overrides['phases.orbit.until.elapsed']: phases[1].until.elapsed: until.elapsed "
        "0.005 s is shorter than one sample (robot.dt = 0.01 s)"
    ]


def test_text_and_dict_report_like_files() -> None:
    assert mission_from_text(SHORT).name == "short"
    with pytest.raises(MissionError) as caught:
        mission_from_text(SHORT.replace("theta: 0}", "thet: 0}"), filename="short.yaml")
    assert str(caught.value) == "short.yaml:9:37: unknown field 'thet'; did you mean 'theta'?"
    data = {"version": 1, "name": "d", "phases": [{"name": "w", "hold": {}, "until": {}}]}
    with pytest.raises(MissionError) as caught:
        mission_from_dict(data)
    (diagnostic,) = caught.value.diagnostics
    assert (diagnostic.file, diagnostic.line) == ("<dict>", 0)
    assert str(diagnostic).startswith("<dict>: phases[0]: ")
    data["phases"][0]["until"] = {"elapsed": 1}
    assert mission_from_dict(data).phases[0].until.elapsed == 1.0


def test_a_mission_from_a_dict_with_tuples_and_numpy_numbers() -> None:
    np = pytest.importorskip("numpy")
    mission = mission_from_dict(
        {
            "version": 1,
            "name": "n",
            "controller": {"Q": np.array([1.0, 2.0, 3.0])},
            "robot": {"dt": np.float32(0.02), "initial_state": {"x": np.int64(1)}},
            "phases": ({"name": "w", "hold": {}, "until": {"elapsed": 1}},),
        }
    )
    assert mission.controller.Q == (1.0, 2.0, 3.0)
    assert mission.robot.initial_state.x == 1.0
    with pytest.raises(MissionError, match="a key must be text"):
        mission_from_dict({1: 2})  # type: ignore[dict-item]


def test_no_unchecked_mission_runs() -> None:
    mission = load_mission(CASE2)
    # pydantic's model_copy(update=...) skips validation
    broken = mission.model_copy(update={"robot": mission.robot.model_copy(update={"dt": -1})})
    with pytest.raises(MissionError, match=r"robot\.dt: should be greater than 0"):
        run_mission(broken)
    # model_validate has no loader context and skips the checks across fields
    data = mission.model_dump(mode="json")
    data["sensors"]["measure"] = ["x", "theta"]
    unobservable = Mission.model_validate(data)
    with pytest.raises(MissionError, match="leaves y unobservable"):
        run_mission(unobservable)
    with pytest.raises(TypeError, match="run_mission takes a Mission"):
        run_mission(data)  # type: ignore[arg-type]


@pytest.mark.slow
def test_result_summary_dataframe_and_run_directory(tmp_path: Path) -> None:
    result = run_mission(mission_from_text(SHORT), seed=3)
    assert result.phase_names == ["out", "back"]
    assert result.outcome.value == "success"
    assert result.mission is not None
    assert result.mission["sensors"]["seed"] == 3
    summary = result.summary()
    assert summary["expectations"][0]["metric"] == "final_position_error"
    out = result.write(tmp_path / "run", formats=("svg",))
    written = json.loads((out / "summary.json").read_text())
    assert json.loads(json.dumps(summary)) == written  # the same code, the same numbers
    assert sorted(p.suffix for p in out.glob("xy.*")) == [".svg"]
    again = load_run(out)
    assert again.samples == result.samples
    # How the loop ran is known for the run simulated here, not for one rebuilt
    assert json.loads((out / "manifest.json").read_text())["loop"] in ("compiled", "plain Python")
    rewritten = json.loads(
        (again.write(tmp_path / "again", plots=False) / "manifest.json").read_text()
    )
    assert rewritten["loop"] is None
    # trajectory.csv keeps 12 significant digits
    assert again.summary()["final"]["position_error"] == pytest.approx(
        summary["final"]["position_error"], rel=1e-9
    )
    frame = result.to_dataframe()
    assert list(frame.columns[:10]) == [
        "t", "x", "y", "theta", "x_est", "y_est", "theta_est", "v", "omega", "phase",
    ]  # fmt: skip
    assert list(frame["phase"].cat.categories) == ["out", "back"]
    assert frame["phase"].iloc[0] == "out"
    assert frame["phase"].iloc[-1] == "back"
    assert len(frame) == result.samples
    with pytest.raises(FileExistsError):
        result.write(out)


@pytest.mark.slow
def test_run_mission_judges_expectations_like_the_command_line() -> None:
    strict = SHORT.replace("{max: 0.05}", "{max: 0.0000001}")
    result = run_mission(mission_from_text(strict))
    assert result.outcome.value == "expect-failed"
    assert result.message.startswith("expectation not met: final_position_error = ")


def test_diagnostic_without_position_prints_its_source_only() -> None:
    assert str(Diagnostic("--set robot.dt=-1", 0, 0, "robot.dt: bad")) == (
        "--set robot.dt=-1: robot.dt: bad"
    )


# --- docs/python-api.md ----------------------------------------------------------

DOC = ROOT / "docs" / "python-api.md"


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)


@pytest.mark.slow
def test_every_python_block_of_the_docs_runs_and_keeps_the_backend(tmp_path: Path) -> None:
    blocks = _blocks()
    assert len(blocks) >= 10
    (tmp_path / "missions").symlink_to(ROOT / "missions")
    # A backend that is not Agg: any switch by the package would show.
    script = "\n".join(
        [
            "import matplotlib",
            "matplotlib.use('svg')",
            *blocks,
            "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()",
            "print('DOC-OK')",
        ]
    )
    # The session's kernel cache, if one is set: without it the blocks' runs
    # would compile their loops afresh into another (a minute of CPU).
    cache = {k: v for k, v in os.environ.items() if k == "NUMBA_CACHE_DIR"}
    completed = subprocess.run(
        [sys.executable, "-c", script],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
        env={"PATH": "", "MPLBACKEND": "svg", "HOME": str(tmp_path), **cache},
    )
    assert completed.returncode == 0, completed.stderr[-3000:]
    assert completed.stdout.splitlines()[-1] == "DOC-OK"
    assert "Traceback" not in completed.stderr


def test_bench_checks_the_mission_it_is_given() -> None:
    from wmr_mission.commands.bench import bench_mission

    mission = load_mission(CASE2)
    broken = mission.model_copy(update={"robot": mission.robot.model_copy(update={"dt": -1})})
    with pytest.raises(MissionError, match=r"robot\.dt: should be greater than 0"):
        bench_mission(broken, repeat=1)


def test_phase_colours_apply_to_every_lap_of_a_repeat() -> None:
    from wmr_mission.sim.plan import plan_mission

    repeat = ROOT / "tests" / "data" / "missions" / "valid" / "repeat.yaml"
    mission = load_mission(repeat, {"plot.phase_colors": {"out": "red", "rest": "#0000ff"}})
    compiled = plan_mission(mission)
    assert [(p.name, p.color) for p in compiled.phases] == [
        ("out#1", "red"), ("back#1", None), ("out#2", "red"), ("back#2", None),
        ("rest", "#0000ff"),
    ]  # fmt: skip
    with pytest.raises(MissionError) as caught:
        load_mission(repeat, {"plot.phase_colors": {"laps": "red"}})
    assert str(caught.value) == (
        "overrides['plot.phase_colors']: plot.phase_colors.laps: no phase is named 'laps' "
        "(phases: out, back, rest)"
    )


def test_a_mission_s_parameters_cannot_be_changed_in_place() -> None:
    """A number written with a parameter (``radius: r``) is computed when the
    mission is read: a change made afterwards would be silently ignored by
    ``run_mission`` (it was), so the mission is frozen down to its parameters."""
    import copy
    import pickle

    text = """version: 1
name: p
parameters: {r: 1.0}
phases:
  - name: go
    track: {path: {type: circle, center: [0, 0], radius: r, angular_rate: 1}}
    until: {elapsed: 0.2}
"""
    mission = mission_from_text(text)
    with pytest.raises(TypeError, match="a mission's parameters cannot be changed"):
        mission.parameters["r"] = 3.0
    for change in ("clear", "popitem"):
        with pytest.raises(TypeError):
            getattr(mission.parameters, change)()
    with pytest.raises(TypeError):
        mission.parameters.update(r=3.0)
    assert mission.parameters == {"r": 1.0}
    # copied, pickled (to a campaign's workers) and written as before
    assert pickle.loads(pickle.dumps(mission)) == mission
    assert copy.deepcopy(mission).parameters == {"r": 1.0}
    assert json.loads(mission.model_dump_json())["parameters"] == {"r": 1.0}
    # the way to another value: the mission read again with it
    again = mission_from_text(text, {"parameters.r": 3.0})
    assert again.phases[0].track.path.radius == 3.0  # type: ignore[union-attr]
    assert run_mission(again).x_ref[10] == pytest.approx(3.0 * math.cos(0.1))
