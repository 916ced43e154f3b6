"""Campaign files: each invalid one names the error it must produce, at its line and column;
the checked-in schema is current and a third-party validator agrees with `validate`."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from wmr_mission.campaign.load import check_campaign, check_file
from wmr_mission.commands.schema import campaign_schema_text
from wmr_mission.spec.checks import Finding

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "campaigns"
VALID = sorted((DATA / "valid").glob("*.yaml"))
INVALID = sorted((DATA / "invalid").glob("*.yaml"))
SHIPPED = sorted((ROOT / "missions" / "campaigns").glob("*.yaml"))
EXPECT = re.compile(r"^# expect: (\d+):(\d+): (.*)$")


def _expectation(path: Path) -> tuple[int, int, str]:
    match = EXPECT.match(path.read_text(encoding="utf-8").split("\n", 1)[0])
    assert match is not None, f"{path.name}: first line must be '# expect: LINE:COL: message'"
    return int(match.group(1)), int(match.group(2)), match.group(3)


def _schema_invalid(path: Path) -> bool:
    return "\n# schema-invalid\n" in path.read_text(encoding="utf-8")


def _ids(paths: list[Path]) -> list[str]:
    return [p.stem for p in paths]


def test_enough_invalid_examples() -> None:
    assert len(INVALID) >= 30
    assert sum(_schema_invalid(p) for p in INVALID) >= 15
    assert len(SHIPPED) >= 3


@pytest.mark.parametrize("path", INVALID, ids=_ids(INVALID))
def test_invalid_campaign_reports_expected_error(path: Path) -> None:
    line, column, message = _expectation(path)
    loaded, diagnostics = check_campaign(path)
    assert loaded is None
    errors = [d for d in diagnostics if d.severity == "error" and d.file == str(path)]
    found = [(d.line, d.column, d.message) for d in errors]
    assert any((d.line, d.column) == (line, column) and message in d.message for d in errors), (
        f"expected {line}:{column}: {message!r}; got {found}"
    )
    for diagnostic in errors:
        assert str(diagnostic).startswith(f"{path}:{diagnostic.line}:{diagnostic.column}: ")
        assert "internal error" not in diagnostic.message
    assert check_file(path) == diagnostics  # `validate` sees a campaign and says the same


@pytest.mark.parametrize("path", VALID + SHIPPED, ids=_ids(VALID) + _ids(SHIPPED))
def test_valid_campaign_is_accepted(path: Path) -> None:
    loaded, diagnostics = check_campaign(path)
    assert diagnostics == []
    assert loaded is not None
    assert loaded.mission_path.is_file()


@pytest.mark.parametrize("path", SHIPPED, ids=_ids(SHIPPED))
def test_shipped_campaigns_point_editors_at_the_schema(path: Path) -> None:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first == "# yaml-language-server: $schema=../../schemas/campaign.schema.json"


def test_checked_in_campaign_schema_is_current() -> None:
    checked_in = (ROOT / "schemas" / "campaign.schema.json").read_text(encoding="utf-8")
    assert checked_in == campaign_schema_text(), "run: python -m wmr_mission.commands.schema"


def test_error_names_the_axis_and_the_value() -> None:
    path = DATA / "invalid" / "grid_value_breaks_mission.yaml"
    _, diagnostics = check_campaign(path)
    (error,) = diagnostics
    assert "'robot.dt'" in error.message
    assert "-0.01" in error.message
    assert "should be greater than 0" in error.message


def test_a_fault_of_the_checker_at_an_axis_value_is_placed_at_the_axis(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Bad input never gets a traceback, nor loses its place: a checker that
    fails at one axis value is reported at that axis, with the value."""
    from wmr_mission.spec import loader

    checked = loader._check_document

    def failing(
        document: loader.Document, findings: list[Finding], filename: str, overrides: list[Any]
    ) -> object:
        if overrides:  # the mission itself checks; an axis value breaks the checker
            raise OverflowError("cannot convert float infinity to integer")
        return checked(document, findings, filename, overrides)

    monkeypatch.setattr(loader, "_check_document", failing)
    path = DATA / "invalid" / "grid_value_breaks_mission.yaml"
    _, diagnostics = check_campaign(path)
    (error,) = diagnostics
    assert (error.line, error.column) == _expected_position(path)
    assert "vary 'robot.dt'" in error.message
    assert "internal error while checking (OverflowError" in error.message


def _expected_position(path: Path) -> tuple[int, int]:
    match = EXPECT.match(path.read_text(encoding="utf-8").splitlines()[0])
    assert match is not None
    return int(match[1]), int(match[2])


def _check_jsonschema(files: list[Path]) -> tuple[int, set[str]]:
    completed = subprocess.run(
        [
            sys.executable,
            "-m",
            "check_jsonschema",
            "--schemafile",
            str(ROOT / "schemas" / "campaign.schema.json"),
            "--output-format",
            "json",
            *map(str, files),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    report = json.loads(completed.stdout)
    failed = {
        str(Path(error["filename"]).resolve())
        for error in report.get("errors", []) + report.get("parse_errors", [])
    }
    return completed.returncode, failed


def test_third_party_validator_agrees() -> None:
    """It accepts every valid campaign and rejects every schema-level invalid one."""
    schema_level = [p for p in INVALID if _schema_invalid(p)]
    returncode, failed = _check_jsonschema(VALID + SHIPPED + schema_level)
    assert returncode == 1
    assert sorted(str(p.resolve()) for p in schema_level) == sorted(failed)


def test_validate_command_takes_campaigns_and_missions() -> None:
    files = [DATA / "valid" / "grid_only.yaml", DATA / "short.yaml"]
    completed = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "validate", *map(str, files)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert completed.returncode == 0, completed.stderr
    assert completed.stdout.count(": ok") == 2
    bad = DATA / "invalid" / "uniform_end_breaks_mission.yaml"
    completed = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "validate", str(bad)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert completed.returncode == 1
    assert f"{bad}:8:3: vary 'robot.dt' (uniform) at 2.0: " in completed.stdout
    assert "Traceback" not in completed.stdout + completed.stderr


def test_schema_command_prints_the_campaign_schema() -> None:
    completed = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "schema", "--campaign"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert completed.stdout == campaign_schema_text()


def test_a_campaign_says_its_mission_s_warnings_and_strict_fails_on_them(tmp_path: Path) -> None:
    """`validate --strict` of a campaign passed a mission whose path cannot reach
    its goal before the phase's timeout, which `validate --strict` of the mission
    refuses; and a sweep of it said nothing before 0 of its runs succeeded."""
    from typer.testing import CliRunner

    from wmr_mission.cli import app

    mission = tmp_path / "short.yaml"
    mission.write_text(
        "version: 1\nname: short\n"
        "robot: {dt: 0.02, initial_state: {x: 0, y: 0, theta: 0}, limits: {v: 1.5, omega: 2.5}}\n"
        "phases:\n"
        "  - name: out\n"
        "    track: {path: {type: polyline, points: [[6, 0]], speed: 0.8}}\n"
        "    until: {near: {point: [6, 0], tolerance: 0.05}}\n"
        "    timeout: 5\n",
        encoding="utf-8",
    )
    campaign = tmp_path / "c.yaml"
    campaign.write_text(
        "version: 1\nname: c\nmission: short.yaml\nruns: 3\n"
        "vary:\n  robot.initial_state.theta: {uniform: [-0.5, 0.5]}\n",
        encoding="utf-8",
    )
    loaded, diagnostics = check_campaign(campaign)
    assert loaded is not None
    [warning] = diagnostics
    assert warning.severity == "warning"
    assert warning.file == str(mission)
    assert "never comes within 0.05 m of (6, 0)" in warning.message
    done = CliRunner().invoke(app, ["validate", "--strict", str(campaign)])
    assert done.exit_code == 1
    assert f"{mission}:7:" in done.output
    assert CliRunner().invoke(app, ["validate", str(campaign)]).exit_code == 0
