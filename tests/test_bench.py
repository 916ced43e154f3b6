"""``wmr-mission bench``: the numbers it returns and the table it prints.

No assertion on how fast anything is: timings depend on the machine.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from wmr_mission.cli import app
from wmr_mission.commands.bench import (
    PAPER_US_PER_SAMPLE,
    bench_command,
    bench_mission,
    format_report,
)
from wmr_mission.spec.loader import load_mission_text

SHORT_MISSION = """
version: 1
name: bench-short
robot:
  initial_state: {x: 0, y: 0, theta: 0}
estimator:
  type: constrained-observer
  initial_estimate: {x: 0.1, y: 0.1, theta: 0}
regions:
  fence: {type: circle, center: [0, 0], radius: 2}
phases:
  - name: out
    track: {path: {type: line, heading: 0.5, speed: 1}}
    until: {elapsed: 0.6}
  - name: home
    regulate: {target: {x: 0, y: 0, theta: 0}}
    constraints: [{stay_inside: fence}]
    until: {elapsed: 0.4}
"""


@pytest.fixture(scope="module")
def numbers() -> dict[str, object]:
    return bench_mission(load_mission_text(SHORT_MISSION, "short.yaml"), repeat=2)


def test_bench_reports_each_phase_and_the_whole_run(numbers: dict[str, object]) -> None:
    phases = numbers["phases"]
    assert isinstance(phases, list)
    assert [p["name"] for p in phases] == ["out", "home"]
    assert [p["kind"] for p in phases] == ["track", "regulate"]
    # 0.6 s and 0.4 s at dt = 0.01; the row that closes the run is not a step.
    assert [p["samples"] for p in phases] == [60, 40]
    overall = numbers["overall"]
    assert isinstance(overall, dict)
    assert overall["samples"] == 100
    assert numbers["samples"] == 101
    for entry in [*phases, overall]:
        for side in ("ours", "reference"):
            stats = entry[side]
            assert 0.0 < stats["median_us"] <= stats["p99_us"]
            assert stats["mean_us"] > 0.0
        assert entry["ratio"] == pytest.approx(
            entry["reference"]["median_us"] / entry["ours"]["median_us"]
        )


def test_bench_reports_the_whole_loop(numbers: dict[str, object]) -> None:
    loop = numbers["loop"]
    assert isinstance(loop, dict)
    assert loop["ours_us"] > 0.0
    assert loop["reference_us"] > 0.0
    assert loop["ratio"] == pytest.approx(loop["reference_us"] / loop["ours_us"])


def test_bench_runs_the_same_mission_both_ways(numbers: dict[str, object]) -> None:
    assert numbers["same_trajectory"] is True
    assert numbers["outcome"] == "success"
    assert numbers["repeat"] == 2
    assert isinstance(numbers["compiled"], bool)
    assert numbers["paper_us_per_sample"] == PAPER_US_PER_SAMPLE


def test_report_is_a_table_with_the_paper_figures_and_a_verdict(
    numbers: dict[str, object],
) -> None:
    report = format_report(numbers, "short.yaml")
    lines = report.splitlines()
    header = next(line for line in lines if line.startswith("phase"))
    for column in ("ours med", "ours p99", "ref med", "ref p99", "ref/ours"):
        assert column in header
    assert any(line.startswith("out ") and "track" in line for line in lines)
    assert any(line.startswith("home ") and "regulate" in line for line in lines)
    assert any(line.startswith("all ") for line in lines)
    assert "120 us (case study 1)" in report
    assert "175 us (case study 2)" in report
    assert lines[-1].startswith("verdict: ")
    assert "x faster than the plain numpy/scipy step" in lines[-1]
    assert "real-time" in lines[-1]
    assert "x faster than the plain step's loop" in lines[-1]
    assert lines[-2].startswith("target: at least 100x below the reference step")


def test_repeat_must_be_positive() -> None:
    with pytest.raises(ValueError, match="repeat must be at least 1"):
        bench_mission(load_mission_text(SHORT_MISSION, "short.yaml"), repeat=0)


def test_bench_command_prints_the_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "short.yaml"
    path.write_text(SHORT_MISSION)
    assert bench_command(path, repeat=1) == 0
    out = capsys.readouterr().out
    assert "mission bench-short" in out
    assert "verdict: " in out
    assert list(tmp_path.iterdir()) == [path]  # no run directory, no plots


def test_bench_command_reports_an_invalid_mission_with_positions(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text(SHORT_MISSION.replace("speed: 1}", "speed: -1}"))
    assert bench_command(path, repeat=1) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert f"{path}:13:53: " in captured.err
    assert "Traceback" not in captured.err


def test_bench_says_a_plug_in_that_does_not_import_as_run_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "plugged.yaml"
    entry = '{type: python, entry: "no_such_module:make"}'
    path.write_text(SHORT_MISSION.replace("robot:", f"controller: {entry}\nrobot:"))
    assert bench_command(path, repeat=1) == 1
    err = capsys.readouterr().err
    line, text = next(
        (n, text) for n, text in enumerate(path.read_text().splitlines(), 1) if "no_such" in text
    )
    column = text.index('"no_such') + 1
    assert f"{path}:{line}:{column}: cannot import 'no_such_module:make'" in err
    assert "nothing to time" not in err


def test_bench_says_a_plain_python_plug_in_ran_as_plain_python(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A plug-in of plain Python objects runs the loop as plain Python however
    numba is: bench's table says so, not "numba-compiled"."""
    monkeypatch.syspath_prepend(str(Path(__file__).parent))
    path = tmp_path / "plugged.yaml"
    entry = '{type: python, entry: "plugin_examples:plain", params: {x: 1, y: 1, theta: 1}}'
    path.write_text(SHORT_MISSION.replace("robot:", f"controller: {entry}\nrobot:"))
    assert bench_command(path, repeat=1) == 0
    out = capsys.readouterr().out
    assert "ours: plain-Python loop (the loop ran as plain Python: a plug-in" in out
    assert "numba-compiled" not in out


def test_cli_bench_exits_zero(tmp_path: Path) -> None:
    path = tmp_path / "short.yaml"
    path.write_text(SHORT_MISSION)
    result = CliRunner().invoke(app, ["bench", str(path), "--repeat", "1"])
    assert result.exit_code == 0, result.output
    assert "ref/ours" in result.output
