"""Example mission files: each invalid file names the error it must produce."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from wmr_mission.commands.schema import (
    REFERENCE_BEGIN,
    REFERENCE_END,
    reference_markdown,
    schema_text,
)
from wmr_mission.spec.loader import Diagnostic, check_mission

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "missions"
VALID = sorted((DATA / "valid").glob("*.yaml"))
INVALID = sorted((DATA / "invalid").glob("*.yaml"))
SHIPPED = sorted((ROOT / "missions").glob("*.yaml"))
EXPECT = re.compile(rb"^# expect(-warning)?: (\d+):(\d+): (.*)$")


def _expectation(path: Path) -> tuple[int, int, str]:
    match = EXPECT.match(path.read_bytes().split(b"\n", 1)[0])
    assert match is not None, f"{path.name}: first line must be '# expect: LINE:COL: message'"
    return int(match.group(2)), int(match.group(3)), match.group(4).decode()


def _schema_invalid(path: Path) -> bool:
    return b"\n# schema-invalid\n" in path.read_bytes()


def _ids(paths: list[Path]) -> list[str]:
    return [p.stem for p in paths]


def test_enough_invalid_examples() -> None:
    assert len(INVALID) >= 40
    assert sum(_schema_invalid(p) for p in INVALID) >= 20


@pytest.mark.parametrize("path", INVALID, ids=_ids(INVALID))
def test_invalid_file_reports_expected_error(path: Path) -> None:
    line, column, message = _expectation(path)
    mission, diagnostics = check_mission(path)
    errors = [d for d in diagnostics if d.severity == "error"]
    assert mission is None
    assert errors, f"{path.name} was accepted"
    found = [(d.line, d.column, d.message) for d in errors]
    assert any((d.line, d.column) == (line, column) and message in d.message for d in errors), (
        f"expected {line}:{column}: {message!r}; got {found}"
    )
    for diagnostic in errors:
        assert str(diagnostic).startswith(f"{path}:{diagnostic.line}:{diagnostic.column}: ")
        assert "Traceback" not in diagnostic.message
        assert "internal error" not in diagnostic.message


@pytest.mark.parametrize("path", VALID + SHIPPED, ids=_ids(VALID) + _ids(SHIPPED))
def test_valid_file_is_accepted(path: Path) -> None:
    mission, diagnostics = check_mission(path)
    assert [d for d in diagnostics if d.severity == "error"] == []
    assert mission is not None
    first = path.read_bytes().split(b"\n", 1)[0]
    warnings = [d for d in diagnostics if d.severity == "warning"]
    if first.startswith(b"# expect-warning:"):
        line, column, message = _expectation(path)
        assert any(
            (d.line, d.column) == (line, column) and message in d.message for d in warnings
        ), warnings
    else:
        assert warnings == []


@pytest.mark.parametrize("path", SHIPPED, ids=_ids(SHIPPED))
def test_shipped_missions_point_editors_at_the_schema(path: Path) -> None:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first == "# yaml-language-server: $schema=../schemas/mission.schema.json"


def test_checked_in_schema_is_current() -> None:
    checked_in = (ROOT / "schemas" / "mission.schema.json").read_text(encoding="utf-8")
    assert checked_in == schema_text(), "run: python -m wmr_mission.commands.schema"


def test_checked_in_reference_is_current() -> None:
    document = (ROOT / "docs" / "mission-format.md").read_text(encoding="utf-8")
    inside = document.split(REFERENCE_BEGIN, 1)[1].split(REFERENCE_END, 1)[0]
    assert inside.strip() == reference_markdown().strip(), (
        "run: python -m wmr_mission.commands.schema"
    )


def test_reference_lists_every_field() -> None:
    from wmr_mission.estimators.ekf import Ekf
    from wmr_mission.geometry.paths.expression import ExpressionPath
    from wmr_mission.spec.models import Mission, Robot

    text = reference_markdown()
    for model in (Mission, Robot, Ekf, ExpressionPath):
        assert f"### {model.__name__}" in text
        for name in model.model_fields:
            assert f"| `{name}` |" in text


def _check_jsonschema(files: list[Path]) -> tuple[int, dict[str, list[str]]]:
    """Run the third-party validator once: its exit code and the files it failed."""
    completed = subprocess.run(
        [
            sys.executable,
            "-m",
            "check_jsonschema",
            "--schemafile",
            str(ROOT / "schemas" / "mission.schema.json"),
            "--output-format",
            "json",
            *map(str, files),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    report = json.loads(completed.stdout)
    failed: dict[str, list[str]] = {}
    for error in report.get("errors", []) + report.get("parse_errors", []):
        failed.setdefault(str(Path(error["filename"]).resolve()), []).append(
            str(error.get("message"))
        )
    return completed.returncode, failed


def test_third_party_validator_accepts_valid_examples() -> None:
    returncode, failed = _check_jsonschema(VALID + SHIPPED)
    assert failed == {}
    assert returncode == 0


def test_third_party_validator_rejects_schema_invalid_examples() -> None:
    schema_level = [p for p in INVALID if _schema_invalid(p)]
    returncode, failed = _check_jsonschema(schema_level)
    assert returncode == 1
    accepted = [p.name for p in schema_level if str(p.resolve()) not in failed]
    assert accepted == []


def test_diagnostic_text_format() -> None:
    error = Diagnostic("m.yaml", 3, 5, "unknown field 'dtt'; did you mean 'dt'?")
    warning = Diagnostic("m.yaml", 4, 1, "not a multiple of dt", "warning")
    assert str(error) == "m.yaml:3:5: unknown field 'dtt'; did you mean 'dt'?"
    assert str(warning) == "m.yaml:4:1: warning: not a multiple of dt"
