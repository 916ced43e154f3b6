"""Untrusted text shown on a terminal (wmr_mission/terminal.py): escaped, never
obeyed, and cut so that every message fits a terminal."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from wmr_mission.cli import app
from wmr_mission.output.environment import own_fingerprint
from wmr_mission.spec.loader import check_mission_text
from wmr_mission.terminal import ECHO_LIMIT, shown

ROOT = Path(__file__).resolve().parents[1]
MINIMAL = ROOT / "tests" / "data" / "missions" / "valid" / "minimal.yaml"
# What a terminal acts on: C0 and C1 controls, DEL, line separators, bidi controls.
ACTED_ON = re.compile(
    "[\x00-\x08\x0b-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f\u202a-\u202e\u2066-\u2069]"
)
# The title sequence, a screen clear, a C1 CSI, a right-to-left override.
HOSTILE = "k\x1b]0;TITLE\x07\x1b[2J\x9b\u202e"
# The longest message line a long value may make: three echoes of it cut to
# ECHO_LIMIT characters, each with its "... (130,009 characters)" (`--set
# PATH=VALUE: PATH: unknown field 'KEY'`), and the words, with the fields
# the hint lists, around them.
LONGEST_LINE = 3 * (ECHO_LIMIT + len("... (130,009 characters)")) + 150


def test_shown_escapes_what_a_terminal_acts_on_and_cuts_long_text() -> None:
    assert shown(HOSTILE) == "k\\x1b]0;TITLE\\x07\\x1b[2J\\x9b\\u202e"
    assert shown("line\nnext\ttab", keep="\n") == "line\nnext\\x09tab"
    assert shown("é 😀 plain") == "é 😀 plain"
    assert shown("x" * 130_000) == "x" * 80 + "... (130,000 characters)"
    assert shown("x" * 130_000, None) == "x" * 130_000
    assert shown("\x1b" * 100, 3) == "\\x1b" * 3 + "... (100 characters)"


def _mission_with_hostile_keys() -> str:
    return (
        "version: 1\nname: t\nparameters:\n"
        f'  "{HOSTILE.encode("unicode_escape").decode()}": 1\n'
        "phases:\n  - name: a\n    hold: {}\n    until: {elapsed: 1}\n"
        '    "x\\e[2J": 3\n'
    )


def test_validate_shows_a_mission_s_keys_escaped(tmp_path: Path) -> None:
    """Through the command line's own streams, in a process of its own."""
    mission = tmp_path / "hostile.yaml"
    mission.write_text(_mission_with_hostile_keys(), encoding="utf-8")
    named = tmp_path / "a\x1b]0;NAME\x07.yaml"  # a file name from the directory
    named.write_bytes(MINIMAL.read_bytes())
    done = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "validate", str(tmp_path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1
    output = done.stdout + done.stderr
    assert ACTED_ON.search(output) is None, repr(output)
    assert "parameters.k\\x1b]0;TITLE\\x07\\x1b[2J\\x9b\\u202e:" in output
    assert "unknown field 'x\\x1b[2J'" in output
    assert "a\\x1b]0;NAME\\x07.yaml: ok" in done.stdout


def test_a_diagnostic_is_one_escaped_line_wherever_it_is_printed() -> None:
    mission = _mission_with_hostile_keys().replace("name: t", 'name: "a\\nb\\e]0;T\\a"')
    _, diagnostics = check_mission_text(mission, "m\x1b[2J.yaml")
    assert diagnostics
    for diagnostic in diagnostics:
        text = str(diagnostic)
        assert ACTED_ON.search(text) is None, text
        assert "\n" not in text
        assert text.startswith("m\\x1b[2J.yaml:")


@pytest.mark.parametrize(
    "setting",
    ["robot.dt={}", "robot.dt=[{}", "robot.d{}=1", "name=a{}", "{}"],
)
def test_a_long_set_value_is_cut_in_every_message(setting: str, tmp_path: Path) -> None:
    value = setting.format("x" * 130_000)
    result = CliRunner().invoke(
        app, ["run", str(MINIMAL), "--set", value, "--out", str(tmp_path / "run")]
    )
    assert result.exit_code in (1, 2), result.output
    lines = result.stderr.splitlines()
    assert lines
    assert all(len(line) <= LONGEST_LINE for line in lines), [len(line) for line in lines]
    assert "(130,0" in result.stderr  # the length of what was cut
    assert not (tmp_path / "run").exists()


def test_a_long_campaign_value_is_cut(tmp_path: Path) -> None:
    campaign = tmp_path / "c.yaml"
    for values in (f"[0.01, {'x' * 90_000}]", f'[a, "b\\e]0;T\\a{"x" * 90_000}"]'):
        campaign.write_text(
            f"version: 1\nname: c\nmission: {MINIMAL}\nruns: 1\n"
            f"vary:\n  {'robot.dt' if '0.01' in values else 'name'}: {{grid: {values}}}\n",
            encoding="utf-8",
        )
        sweep = ["sweep", str(campaign), "--no-plots", "--out", str(tmp_path / "o")]
        for command in (["validate", str(campaign)], sweep):
            result = CliRunner().invoke(app, command)
            assert result.exit_code in (1, 2), result.output
            # validate reports on stdout, sweep's errors go to stderr
            printed = result.stdout + result.stderr
            lines = printed.splitlines()
            assert lines
            assert all(len(line) <= LONGEST_LINE for line in lines), [len(n) for n in lines]
            assert ACTED_ON.search(printed) is None
            assert "(90,0" in printed


@pytest.mark.parametrize(
    "fingerprint", ["ab\n\x1b]0;T\x07", "0BADF00D", "0badf00", "0badf00d0", "x" * 100_000, ""]
)
def test_expect_environment_takes_a_fingerprint_only(fingerprint: str, tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app,
        ["run", str(MINIMAL), "--expect-environment", fingerprint, "--out", str(tmp_path / "r")],
    )
    assert result.exit_code == 2
    assert result.stdout == ""
    assert result.stderr.count("\n") == 1
    assert result.stderr.startswith("--expect-environment ")
    assert "not a fingerprint: 8 hexadecimal digits" in result.stderr
    assert ACTED_ON.search(result.stderr) is None
    assert len(result.stderr) <= LONGEST_LINE
    assert not (tmp_path / "r").exists()


def test_expect_environment_takes_its_own_fingerprint(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app,
        [
            "run",
            str(MINIMAL),
            "--expect-environment",
            own_fingerprint(),
            "--no-plots",
            "--out",
            str(tmp_path / "r"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "fingerprint" not in result.stderr
