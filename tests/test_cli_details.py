"""The command line never misleads: flags, versions, overrides, warnings, times and verdicts."""

from __future__ import annotations

import io
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from failing import UNGATED_SET
from typer.testing import CliRunner

from wmr_mission import __version__
from wmr_mission.cli import app

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ("verdicts", "xy", "states", "estimation_error", "inputs")
VALID = ROOT / "tests" / "data" / "missions" / "valid"

# Drives along +x at 0.1 m/s for 2 s towards a goal 10 m away: times out far from it.
SHORT_OF_GOAL = """\
version: 1
name: short-of-goal
robot: {limits: {v: 2, omega: 4}}
phases:
  - name: go
    track: {path: {type: line, heading: 0, speed: 0.1}}
    until: {near: {point: [10, 0], tolerance: 0.1}}
    timeout: 2
"""


def _invoke(*arguments: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(app, list(arguments))
    return result.exit_code, result.stdout, result.stderr


def test_version_and_short_help() -> None:
    code, out, _ = _invoke("--version")
    assert (code, out) == (0, f"wmr-mission {__version__}\n")
    for arguments in (["-h"], ["run", "-h"], ["validate", "-h"], ["plot", "-h"]):
        code, out, _ = _invoke(*arguments)
        assert code == 0, arguments
        assert out.startswith("Usage: wmr-mission"), arguments


def test_boolean_options_show_as_flags() -> None:
    code, out, _ = _invoke("run", "--help")
    assert code == 0
    assert "<bool>" not in out
    lines = {line.split()[0]: line for line in out.splitlines() if line.strip().startswith("--")}
    assert lines["--no-plots"].split()[1] == "Write"
    assert lines["--animate"].split()[1] == "Also"
    assert "PATH=VALUE" in lines["--set"]
    assert "--format" in lines


def _write(tmp_path: Path, text: str, name: str = "m.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.slow
def test_run_names_simulated_and_wall_time_and_prints_warnings_first(tmp_path: Path) -> None:
    # One stream, unbuffered: the order of the lines is the order they were written in.
    completed = subprocess.run(
        [
            *(sys.executable, "-u", "-m", "wmr_mission", "run"),
            *(str(VALID / "warning_not_multiple_of_dt.yaml"), "--out", str(tmp_path / "r")),
            "--no-plots",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        check=False,
    )
    assert completed.returncode == 0, completed.stdout
    output = completed.stdout
    warning = "8:22: warning: until.elapsed 1.005 s is not a multiple of robot.dt = 0.01 s"
    header = next(line for line in output.splitlines() if line.startswith("phase "))
    assert output.index(warning) < output.index(header) < output.index("outcome:")
    outcome = next(line for line in output.splitlines() if line.startswith("outcome:"))
    assert outcome.startswith("outcome: success after 1.00 s of simulated time (")
    assert " s of wall time) - all phases completed" in outcome


@pytest.mark.slow
def test_a_failed_run_says_what_it_missed(tmp_path: Path) -> None:
    mission = _write(tmp_path, SHORT_OF_GOAL)
    code, out, err = _invoke("run", str(mission), "--out", str(tmp_path / "r"), "--no-plots")
    assert code == 1
    final = next(line for line in out.splitlines() if line.startswith("final error:"))
    # the robot measured at that point's own time, the run's last sample but one
    assert re.search(r"\(from the last reference point of phase 'go', at t = [0-9.]+ s\)$", final)
    missed = next(line for line in out.splitlines() if line.startswith("not reached:"))
    match = re.fullmatch(
        r"not reached: near \(10, 0\) within 0\.1 m of phase 'go': ([0-9.]+) m away "
        "when it timed out",
        missed,
    )
    assert match is not None, missed
    assert 8.0 < float(match.group(1)) < 10.0
    assert "phase 'go' timed out" in err


def test_validate_a_directory_recurses_into_yaml_files(tmp_path: Path) -> None:
    (tmp_path / "deeper").mkdir()
    good = (VALID / "minimal.yaml").read_text()
    _write(tmp_path, good, "a.yaml")
    _write(tmp_path / "deeper", good.replace("name: minimal", "name: b"), "b.yaml")
    _write(tmp_path, good.replace("name: minimal", "name: c"), "c.yml")
    _write(tmp_path, "not a mission", "notes.txt")
    code, out, _ = _invoke("validate", str(tmp_path))
    assert code == 0
    assert out.splitlines() == [
        f"{tmp_path / 'a.yaml'}: ok",
        f"{tmp_path / 'c.yml'}: ok",
        f"{tmp_path / 'deeper/b.yaml'}: ok",
    ]
    empty = tmp_path / "empty"
    empty.mkdir()
    code, out, _ = _invoke("validate", str(empty))
    assert code == 1
    assert out == f"{empty}: no mission files (*.yaml, *.yml) below it\n"


@pytest.mark.slow
def test_set_overrides_a_field_and_the_manifest_records_it(tmp_path: Path) -> None:
    mission = VALID / "minimal.yaml"
    out_dir = tmp_path / "r"
    code, _, err = _invoke(
        "run", str(mission), "--out", str(out_dir), "--no-plots",
        "--set", "robot.dt=0.02", "--set", "controller.Q=[1, 1, 2]",
        "--set", "robot.initial_state={x: 1, y: 2}",
    )  # fmt: skip
    assert code == 0, err
    resolved = json.loads((out_dir / "manifest.json").read_text())["resolved_mission"]
    assert resolved["robot"]["dt"] == 0.02
    assert resolved["controller"]["Q"] == [1.0, 1.0, 2.0]
    assert resolved["robot"]["initial_state"] == {"x": 1.0, "y": 2.0, "theta": 0.0}
    trajectory = (out_dir / "trajectory.csv").read_text().splitlines()
    assert trajectory[2].startswith("0.02,1,2,")


@pytest.mark.parametrize(
    ("setting", "message", "exit_code"),
    [
        ("robot.dt=-1", "--set robot.dt=-1: robot.dt: should be greater than 0, got -1", 1),
        (
            "robot.dtt=1",
            "--set robot.dtt=1: robot.dtt: unknown field 'dtt'; did you mean 'dt'?",
            1,
        ),
        ("robot.dt=[1,", "--set robot.dt=[1,: VALUE is not a YAML value: YAML syntax error", 1),
        ("phases[3].timeout=1", "--set phases[3].timeout=1: phases has 1 items (0 to 0)", 1),
        ("name.x=1", "--set name.x=1: name is a str, not a mapping: it has no field 'x'", 1),
        (
            "robot.dt=!!python/none 1",
            "--set robot.dt=!!python/none 1: VALUE is not a YAML value",
            1,
        ),
        # not PATH=VALUE at all: the command line's mistake, a usage error
        ("robot.dt", "--set robot.dt: expected PATH=VALUE, e.g. robot.dt=0.02", 2),
        ("robot..dt=1", "--set robot..dt=1: 'robot..dt' is not a field path", 2),
    ],
)
def test_a_bad_set_names_itself_and_the_field(
    setting: str, message: str, exit_code: int, tmp_path: Path
) -> None:
    code, _, err = _invoke(
        "run", str(VALID / "minimal.yaml"), "--out", str(tmp_path / "r"), "--set", setting
    )
    assert code == exit_code
    assert err.startswith(message), err
    assert "Traceback" not in err
    assert not (tmp_path / "r").exists()  # nothing ran


def test_a_set_naming_a_phase_of_a_repeat_at_the_top_says_its_path(tmp_path: Path) -> None:
    # phases.NAME finds a phase written at the top of phases; one in a repeat
    # is named through it
    mission = ROOT / "missions" / "keep-out.yaml"
    code, _, err = _invoke(
        "run", str(mission), "--out", str(tmp_path / "r"), "--set", "phases.south.timeout=3"
    )
    assert code == 1
    assert err.startswith(
        "--set phases.south.timeout=3: phases has 2 items (0 to 1), no item 'south'; 'south' is "
        "a phase of repeat 'laps': phases.laps.repeat.phases.south\n"
    ), err


@pytest.mark.parametrize(("setting", "exit_code"), [("robot.dt", 2), ("robot.dt=-1", 1)])
def test_a_sweep_set_gives_the_exit_code_a_run_set_does(
    setting: str, exit_code: int, tmp_path: Path
) -> None:
    campaign = ROOT / "tests" / "data" / "campaigns" / "valid" / "grid_only.yaml"
    code, _, err = _invoke(
        "sweep", str(campaign), "--out", str(tmp_path / "c"), "--set", setting, "--no-plots"
    )
    assert code == exit_code, err
    assert err.startswith(f"--set {setting}: "), err
    assert not (tmp_path / "c").exists()


@pytest.mark.slow
def test_run_and_plot_write_the_chosen_formats(tmp_path: Path) -> None:
    out_dir = tmp_path / "r"
    code, _, err = _invoke(
        "run", str(VALID / "minimal.yaml"), "--out", str(out_dir), "--format", "svg"
    )
    assert code == 0, err
    figures = sorted(p.name for p in out_dir.iterdir() if p.suffix in (".png", ".svg", ".pdf"))
    assert figures == [
        "estimation_error.svg",
        "inputs.svg",
        "states.svg",
        "verdicts.svg",
        "xy.svg",
    ]
    assert (out_dir / "xy.svg").read_text().lstrip().startswith("<?xml")
    code, out, _ = _invoke("plot", str(out_dir), "--format", "pdf")
    assert code == 0
    assert out.split() == [str(out_dir / f"{name}.pdf") for name in FIGURES]
    assert (out_dir / "xy.pdf").read_bytes()[:5] == b"%PDF-"
    code, _, err = _invoke("plot", str(out_dir), "--format", "gif")
    assert code == 2
    assert "gif" in err


@pytest.mark.slow
@pytest.mark.parametrize("mission", sorted(p.name for p in (ROOT / "missions").glob("*.yaml")))
def test_the_run_table_fits_in_100_columns(mission: str, tmp_path: Path) -> None:
    """Every shipped mission's table, on a console 100 columns wide."""
    result = CliRunner(env={"COLUMNS": "100"}).invoke(
        app, ["run", str(ROOT / "missions" / mission), "--out", str(tmp_path / "r"), "--no-plots"]
    )
    lines = result.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("phase "))
    assert lines[header + 1].startswith("─" * 10)
    assert lines[-1] == f"outputs: {tmp_path / 'r'}"
    assert max(map(len, lines)) <= 100, "\n".join(line for line in lines if len(line) > 100)


@pytest.mark.slow
def test_a_failure_is_said_once(tmp_path: Path) -> None:
    """disturbed with its outliers let through: its circle kicks its turn rate
    and reverses it: each threshold missed is named, with its value, once
    (the message on stderr); the table marks the phase, and only it."""
    mission = ROOT / "missions" / "disturbed.yaml"
    result = CliRunner(env={"COLUMNS": "100"}).invoke(
        app, ["run", str(mission), *UNGATED_SET, "--out", str(tmp_path / "r")]
    )
    assert result.exit_code == 1
    said = result.stdout + result.stderr
    for metric in ("turn_rate_jump_max", "turn_rate_reversals"):
        assert said.count(f"circle: {metric} = ") == 1, metric
    rows = {line.split()[0]: line for line in result.stdout.splitlines() if line.strip()}
    assert rows["circle"].endswith("NOT MET")
    assert rows["stop"].endswith("ok")
    # the table names each threshold missed, with its value and bound
    assert result.stdout.count("turn_rate_jump_max") == 1
    # located at the first threshold missed: the circle's, an `auto` bound written nowhere
    assert result.stderr.startswith(f"{mission}:{_line_of(mission, '- name: circle')}:5: ")
    assert ": expectation not met: " in result.stderr


def _line_of(path: Path, text: str) -> int:
    """The number of the first line of ``path`` that holds ``text``."""
    lines = path.read_text(encoding="utf-8").splitlines()
    return next(number for number, line in enumerate(lines, 1) if text in line)


def test_a_timeout_points_at_its_timeout(tmp_path: Path) -> None:
    """A failed run's last line is FILE:LINE:COL, as a mission's errors are,
    so that an editor or a CI log goes to what failed; a value `--set` set
    is named as the command line wrote it, not by the file's line."""
    mission = _write(tmp_path, SHORT_OF_GOAL)
    code, _, err = _invoke("run", str(mission), "--out", str(tmp_path / "r"), "--no-plots")
    assert code == 1
    assert err.splitlines()[-1].startswith(f"{mission}:8:5: phase 'go' timed out after 2 s"), err
    set_there = ("--set", "phases.0.timeout=1.5", "--no-plots")
    code, _, err = _invoke("run", str(mission), "--out", str(tmp_path / "s"), *set_there)
    assert code == 1
    assert err.splitlines()[-1].startswith(
        "--set phases.0.timeout=1.5: phase 'go' timed out after 1.5 s"
    ), err


# A line driven for a second at the speed limit, and thresholds it misses (lines 8 on).
DRIVEN = """\
version: 1
name: missing
robot: {limits: {v: 0.5, omega: 4}}
phases:
  - name: go
    track: {path: {type: line, heading: 0, speed: 0.5}}
    until: {elapsed: 1}
"""
FORMULA = '      temporal: ["always(speed <= 0.05)"]\n'
AT_LIMIT = "speed_at_limit: {max: 0.001}\n"  # at its limit throughout


@pytest.mark.parametrize(
    ("expect", "at"),
    [
        ("    expect:\n" + FORMULA, "9:18"),  # the formula, in the phase's `temporal` list
        ("    expect:\n" + FORMULA + "      " + AT_LIMIT, "10:7"),  # a bound, before formulas
        ("expect:\n  " + AT_LIMIT, "9:3"),  # the mission's, for every phase
    ],
)
def test_a_missed_threshold_points_at_the_expect_that_set_it(
    expect: str, at: str, tmp_path: Path
) -> None:
    mission = _write(tmp_path, DRIVEN + expect)
    code, _, err = _invoke("run", str(mission), "--out", str(tmp_path / "r"), "--no-plots")
    assert code == 1
    assert err.splitlines()[-1].startswith(f"{mission}:{at}: expectation not met: "), err


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_long_run_shows_its_progress_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    """A mission of more than 20 000 samples shows its phase and time as it
    runs, on a terminal only; the run is the same either way."""
    from wmr_mission.commands import run
    from wmr_mission.sim.plan import plan_mission, sample_budget
    from wmr_mission.spec.loader import load_mission

    mission = load_mission(ROOT / "missions" / "coverage.yaml")
    budget = sample_budget(mission)
    assert budget > 20_000
    shown = []
    for stream in (_Terminal(), io.StringIO()):
        monkeypatch.setattr(sys, "stderr", stream)
        result = run._simulate(plan_mission(mission))
        shown.append(stream.getvalue())
    assert "coverage [" in shown[0]
    assert " t = " in shown[0]
    assert result.samples > 20_000
    assert shown[1] == ""
