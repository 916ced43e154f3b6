import re

import pytest
from typer.testing import CliRunner

from wmr_mission.cli import app


def test_help_lists_every_command() -> None:
    result = CliRunner().invoke(app, ["--help"])
    assert result.exit_code == 0
    for command in ("run", "falsify", "validate", "schema", "plot", "view", "export", "bench"):
        assert command in result.output


@pytest.mark.parametrize(
    "command", ["run", "sweep", "falsify", "validate", "schema", "plot", "view", "export", "bench"]
)
def test_help_names_each_value_by_a_plain_word(command: str) -> None:
    """`--format FORMAT`, `MISSION`: no `<list[png|svg|pdf]>`, `<file>` or `{MISSION}`."""
    result = CliRunner().invoke(app, [command, "-h"], env={"COLUMNS": "100"})
    assert result.exit_code == 0
    lines = result.output.splitlines()
    assert re.fullmatch(rf"Usage: wmr-mission {command} \[OPTIONS\]( [A-Z_]+(\.\.\.)?)*", lines[0])
    sections = [lines.index(title) for title in ("Arguments:", "Options:") if title in lines]
    entries = [
        line.split("  ")[1]
        for start in sections
        for line in lines[start + 1 : lines.index("", start) if "" in lines[start:] else None]
        if re.match(r"  \S", line)
    ]
    assert len(entries) >= 2
    for entry in entries:
        assert re.fullmatch(r"(-h, )?--[a-z-]+( [A-Z_=]+)?|[A-Z_]+(\.\.\.)?", entry), entry
