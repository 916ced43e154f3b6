"""`wmr-mission validate` and `wmr-mission schema` on the command line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from wmr_mission.cli import app

ROOT = Path(__file__).resolve().parents[1]
CASES = [ROOT / "missions" / "case1.yaml", ROOT / "missions" / "case2.yaml"]
INVALID = ROOT / "tests" / "data" / "missions" / "invalid"
WARNING = ROOT / "tests" / "data" / "missions" / "valid" / "warning_not_multiple_of_dt.yaml"

SEVERAL_MISTAKES = """\
version: 1
name: several
robot:
  dtt: 0.01
phases:
  - name: one
    hold: {}
    until: {elapsed: -1}
"""


def _validate(*arguments: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(app, ["validate", *arguments])
    assert result.exception is None or isinstance(result.exception, SystemExit)
    return result.exit_code, result.stdout, result.stderr


def test_shipped_missions_are_valid() -> None:
    code, out, err = _validate(*map(str, CASES))
    assert code == 0
    assert out.splitlines() == [f"{CASES[0]}: ok", f"{CASES[1]}: ok"]
    assert err == ""


def test_invalid_file_lists_every_error_then_the_summary_on_one_stream(tmp_path: Path) -> None:
    path = tmp_path / "several.yaml"
    path.write_text(SEVERAL_MISTAKES, encoding="utf-8")
    code, out, err = _validate(str(path))
    assert code == 1
    # One stream, so that `validate ... > report.txt` keeps all of it.
    assert err == ""
    assert out.splitlines() == [
        f"{path}:4:3: unknown field 'dtt'; did you mean 'dt'?",
        f"{path}:8:22: phases[0].until.elapsed: should be greater than 0, got -1",
        # Checks across fields wait for a sound file, and the summary says so.
        f"{path}: 2 errors, checks across fields (observability, timing, paths) run once fixed",
    ]


def test_semantic_errors_need_no_second_pass_note(tmp_path: Path) -> None:
    path = tmp_path / "unobservable.yaml"
    path.write_text(
        "version: 1\nname: blind\nsensors: {measure: [x, theta]}\n"
        "phases:\n  - {name: wait, hold: {}, until: {elapsed: 1}}\n",
        encoding="utf-8",
    )
    code, out, _ = _validate(str(path))
    assert code == 1
    assert out.startswith(f"{path}:3:20: sensors.measure [x, theta] leaves y unobservable")
    assert out.endswith(f"\n{path}: 1 error\n")


def test_one_invalid_file_fails_the_batch() -> None:
    code, out, _ = _validate(str(CASES[0]), str(INVALID / "nan.yaml"))
    assert code == 1
    assert out.splitlines()[0].endswith(": ok")
    assert out.splitlines()[-1].endswith(
        ": 1 error, checks across fields (observability, timing, paths) run once fixed"
    )


def test_warnings_alone_keep_exit_zero() -> None:
    code, out, _ = _validate(str(WARNING))
    assert code == 0
    assert out.endswith(f"\n{WARNING}: ok (1 warning)\n")
    assert ": warning: until.elapsed 1.005 s is not a multiple" in out


def test_json_report(tmp_path: Path) -> None:
    path = tmp_path / "several.yaml"
    path.write_text(SEVERAL_MISTAKES, encoding="utf-8")
    code, out, err = _validate("--format", "json", str(CASES[1]), str(path), str(WARNING))
    assert code == 1
    assert err == ""
    report = json.loads(out)
    assert report["valid"] is False
    assert [f["valid"] for f in report["files"]] == [True, False, True]
    assert report["files"][0]["diagnostics"] == []
    first = report["files"][1]["diagnostics"][0]
    assert first == {
        "file": str(path),
        "line": 4,
        "column": 3,
        "severity": "error",
        "message": "unknown field 'dtt'; did you mean 'dt'?",
        "stage": "schema",
    }
    warning = report["files"][2]["diagnostics"][0]
    assert (warning["severity"], warning["stage"]) == ("warning", "semantics")


def test_missing_file_is_a_usage_error(tmp_path: Path) -> None:
    code, _, _ = _validate(str(tmp_path / "nope.yaml"))
    assert code == 2


def test_a_missing_file_is_in_the_json_report_and_the_others_are_checked(
    tmp_path: Path,
) -> None:
    """A CI step that reads the JSON gets it: the argument that names nothing
    among `problems`, the files given checked all the same, exit 2."""
    missing = tmp_path / "nope.yaml"
    code, out, err = _validate("--format", "json", str(CASES[1]), str(missing))
    assert code == 2
    assert err == ""
    report = json.loads(out)
    assert report["valid"] is False
    assert [(f["file"], f["valid"]) for f in report["files"]] == [(str(CASES[1]), True)]
    assert [(p["file"], p["message"]) for p in report["problems"]] == [
        (str(missing), "no such file or directory")
    ]
    code, out, _ = _validate(str(missing), str(CASES[1]))
    assert code == 2
    assert out.splitlines() == [f"{missing}: no such file or directory", f"{CASES[1]}: ok"]


def test_schema_command_prints_the_checked_in_schema() -> None:
    result = CliRunner().invoke(app, ["schema"])
    assert result.exit_code == 0
    assert result.stdout == (ROOT / "schemas" / "mission.schema.json").read_text(encoding="utf-8")


@pytest.mark.parametrize("name", ["expression_injection_import.yaml", "python_tag.yaml"])
def test_validate_in_a_subprocess_executes_nothing(name: str, tmp_path: Path) -> None:
    completed = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "validate", str(INVALID / name)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert completed.returncode == 1
    assert "Traceback" not in completed.stdout + completed.stderr
    assert "is not allowed" in completed.stdout
    assert list(tmp_path.iterdir()) == []


def test_validate_does_not_import_plotting_scipy_or_numba() -> None:
    script = (
        "import sys\n"
        "from wmr_mission.cli import app\n"
        "try:\n"
        f"    app(['validate', {str(CASES[0])!r}, {str(CASES[1])!r}])\n"
        "except SystemExit as stop:\n"
        "    code = stop.code\n"
        "heavy = ('matplotlib', 'scipy', 'numba')\n"
        "heavy = sorted(m for m in sys.modules if m.split('.')[0] in heavy)\n"
        "print(code, heavy)\n"
    )
    completed = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=False
    )
    assert completed.returncode == 0, completed.stderr
    assert completed.stdout.splitlines()[-1] == "0 []"


@pytest.mark.parametrize("text", ["null\n", "~\n", "---\n", "null\n...\n"])
def test_a_file_holding_only_null_is_no_mission_for_any_command(tmp_path: Path, text: str) -> None:
    from wmr_mission.spec.loader import MissionError, load_mission

    path = tmp_path / "n.yaml"
    path.write_text(text, encoding="utf-8")
    expected = f"{path}:1:1: the file holds only null: expected a mission mapping"
    for arguments in ([], ["--strict"]):
        code, out, _ = _validate(str(path), *arguments)
        assert code == 1
        assert out.splitlines()[0] == expected
    code, out, _ = _validate(str(path), "--format", "json")
    assert code == 1
    assert json.loads(out)["valid"] is False
    ran = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "run", str(path), "--out", str(tmp_path / "run")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert ran.returncode == 1
    assert expected in ran.stderr
    with pytest.raises(MissionError, match="expected a mission mapping"):
        load_mission(path)


def test_a_mission_file_that_cannot_be_read_is_an_io_fault_exit_2(tmp_path: Path) -> None:
    device = "/dev/null"  # a character device: exists, and is no regular file
    said = f"{device}:1:1: cannot read the file: it is a device or socket, not a regular file"
    ran = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "run", device, "--out", str(tmp_path / "run")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert (ran.returncode, ran.stderr.strip()) == (2, said)
    assert not (tmp_path / "run").exists()
    code, out, _ = _validate(device, str(CASES[0]))
    assert code == 2
    assert out.splitlines()[0] == said
    assert f"{CASES[0]}: ok" in out.splitlines()


def test_every_file_name_validate_prints_is_escaped(tmp_path: Path) -> None:
    """A file name holding a newline cannot forge a line `FILE: ok`."""
    forge = tmp_path / "forge"
    (forge / "missions").mkdir(parents=True)
    (forge / "missions" / "patrol.yaml: ok\nbad.yaml").write_text(
        SEVERAL_MISTAKES, encoding="utf-8"
    )
    (forge / "missions" / "title\x1b]0;T\x07.yaml").write_text(
        (ROOT / "tests" / "data" / "missions" / "valid" / "minimal.yaml").read_text("utf-8"),
        encoding="utf-8",
    )
    code, out, _ = _validate(str(forge))
    assert code == 1
    lines = out.splitlines()
    assert f"{forge}/missions/patrol.yaml: ok" not in lines
    assert not any(line.startswith("bad.yaml") for line in lines)
    assert "\x1b" not in out
    assert "\x07" not in out
    assert lines[-1] == f"{forge}/missions/title\\x1b]0;T\\x07.yaml: ok"
    escaped = f"{forge}/missions/patrol.yaml: ok\\x0abad.yaml"
    summary = "2 errors, checks across fields (observability, timing, paths) run once fixed"
    assert lines[-2] == f"{escaped}: {summary}"
